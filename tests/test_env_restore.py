"""``env.restore(state)`` takes only states the environment itself makes for the current task
(modquad_gym/envs/assembly/restore.py): every kind of edit (a derived field, the cells or types,
the task arrays, the counters and end flags; a state is immutable, so an edit makes a copy) is
refused in one line naming the field; genuine states of every variant, taken before later
steps, restore to the same observation and the same next step, also where the state is
recomputed (a copy, or a fresh environment with empty memos)."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from modquad_gym import dynamics as dy
from modquad_gym.envs.assembly import ModQuadAssemblyEnv
from modquad_gym.envs.assembly.restore import check_restore
from modquad_gym.tasks import PlantedTasks, make_generator

TASK = PlantedTasks(n_modules=5, n_wrenches=8)(np.random.default_rng(0))
VARIANTS = {
    "grid": dict(n_max=6),
    "support lookahead": dict(n_max=6, lookahead=True),
    "exact lookahead": dict(n_max=6, lookahead="exact"),
    "shortlist": dict(n_max=6, lookahead="exact", lookahead_top_k=3),
    "faces": dict(n_max=6, actions="faces", lookahead="exact", lookahead_top_k=4),
    "palette": dict(n_max=6, modules="t45,t45m,flat", lookahead="exact"),
    "dynamic": dict(n_max=5, tasks=dy.circle(radius=1.0, speed=2.0, f_max=2.0, rate=10)),
    "terminate": dict(n_max=6, invalid_action="terminate", max_steps=8),
}


def task_of(kwargs: dict):
    if "tasks" in kwargs:
        return kwargs["tasks"]
    if "modules" in kwargs:
        return make_generator("planted-mixed-external")(np.random.default_rng(1))
    return TASK


def recomputed(env: ModQuadAssemblyEnv, state) -> None:
    """The full check (no digest of a handed-out state)."""
    check_restore(env._episode, env._state, state)


def episode(env: ModQuadAssemblyEnv, seed: int, invalid: bool = True) -> list:
    """The states of a random masked episode (one invalid action first, if ``invalid``)."""
    rng = np.random.default_rng(seed)
    states = [env.state]
    if invalid:
        env.step(int(np.flatnonzero(env.action_masks() == 0)[0]))
        states.append(env.state)
    while not states[-1].done:
        env.step(int(rng.choice(np.flatnonzero(env.action_masks()))))
        states.append(env.state)
    return states


@pytest.mark.parametrize("name", list(VARIANTS))
def test_genuine_states_restore_to_the_same_observation_and_next_step(name):
    """Every state of an episode (taken before the later steps) passes the full check and
    restores to its observation; from each, a fresh environment of the same task (empty memos:
    every field recomputed) accepts it and steps to the same observation as the original."""
    kwargs = VARIANTS[name]
    env, fresh = ModQuadAssemblyEnv(**kwargs), ModQuadAssemblyEnv(**kwargs)
    task = task_of(kwargs)
    obs0 = [env.reset(options={"task": task})[0]]
    fresh.reset(options={"task": task})
    states = episode(env, 0, invalid=name != "terminate")
    for state in states:
        recomputed(env, state)
        obs = env.restore(state)
        assert env.state is state and set(obs) == set(obs0[0])
    for state in states[:-1]:
        if state.done:
            continue
        env.restore(state)
        action = int(np.flatnonzero(env.action_masks())[-1])
        want = env.step(action)[0]
        fresh.restore(state)
        got = fresh.step(action)[0]
        for key in want:
            np.testing.assert_allclose(got[key], want[key], atol=1e-5, err_msg=key)
        if not fresh.state.done:  # an invalid action after a restore: no error
            assert fresh.step(-1)[4]["invalid_action"]
            recomputed(fresh, fresh.state)  # (with "terminate": ended by it)


def edits(env: ModQuadAssemblyEnv, state) -> dict:
    """field named (a pattern) -> edited copies of ``state`` (a grid state of two modules or
    more)."""
    cand = None if state.candidates is None else state.candidates.copy()
    if cand is not None:
        cand[0, 0] += 0.25
    occupancy = state.occupancy.copy()
    occupancy[0] = 1
    vec = state.structure_vec.copy()
    vec[-1] += 0.5
    far = (*state.cells[:-1], (env.n_max - 1, env.n_max - 1))
    moved = ((0, 0), (0, 1), *state.cells[2:]) if state.cells[1] != (0, 1) else None
    task = dataclasses.replace(state.task, W=state.task.W * 1.01)
    out = {
        "occupancy": [{"occupancy": occupancy}],
        "structure_vec": [{"structure_vec": vec}],
        "frac": [{"frac": state.frac + 1.0 / len(state.task.W)}],
        "success": [{"success": not state.success}],
        "task": [{"task": task}],
        "cells": [{"cells": far}, {"cells": (*state.cells, state.cells[-1])},
                  {"cells": ((1, 0), *state.cells[1:])}, {"cells": ((0.0, 0.0), *state.cells[1:])}],
        "steps": [{"steps": state.steps + 40}, {"steps": -1}, {"steps": 1.5}],
        "evaluated": [{"evaluated": state.evaluated + 1}],
        "oracle_calls": [{"oracle_calls": -1}],
        "terminated": [{"terminated": not state.terminated}],
        "truncated": [{"truncated": True}],
    }  # fmt: skip
    if moved is not None:
        out["(frac|structure_vec|occupancy)"] = [{"cells": moved}]  # another structure
    if cand is not None:
        out["candidates"] = [{"candidates": cand}]
    return out


@pytest.mark.parametrize("name", ["grid", "exact lookahead"])
def test_each_kind_of_edit_is_refused_with_the_field_named(name):
    env = ModQuadAssemblyEnv(**VARIANTS[name])
    env.reset(options={"task": TASK})
    env.step(env.action_of((1, 0)))
    env.step(env.action_of((1, 1)))
    state = env.state
    for field, changes in edits(env, state).items():
        for change in changes:
            with pytest.raises(ValueError, match=f"^restore: the state's {field}[^\n]*$"):
                env.restore(dataclasses.replace(state, **change))
    mask = state.mask.copy()
    mask[np.flatnonzero(mask)[0]] = 0
    with pytest.raises(ValueError, match="^restore: .*(mask|lookahead rows)[^\n]*$"):
        env.restore(dataclasses.replace(state, mask=mask))
    with pytest.raises(ValueError, match="read-only"):  # an edit makes a copy: refused above
        state.occupancy[0] = 1
    env.restore(dataclasses.replace(state))  # a copy: recomputed, the same
    other = ModQuadAssemblyEnv(**VARIANTS[name])
    other.reset(options={"task": PlantedTasks(n_modules=5, n_wrenches=8)(np.random.default_rng(3))})
    with pytest.raises(ValueError, match="^restore: the state belongs to an episode of another"):
        env.restore(other.state)


def test_edits_of_types_shortlists_faces_and_dynamic_tasks_are_refused():
    palette = ModQuadAssemblyEnv(**VARIANTS["palette"])
    palette.reset(options={"task": task_of(VARIANTS["palette"])})
    palette.step(palette.action_of((1, 0), 2))
    state = palette.state
    retyped = (((0, 1), "(frac|structure_vec|types_onehot)"), ((0, 7), "types"), ((0,), "types"))
    for types, field in retyped:
        with pytest.raises(ValueError, match=f"^restore: the state's {field}"):
            palette.restore(dataclasses.replace(state, types=types))
    short = ModQuadAssemblyEnv(**VARIANTS["shortlist"])
    short.reset(options={"task": TASK})
    short.step(int(np.flatnonzero(short.action_masks())[0]))
    state = short.state
    free = state.free.copy()
    free[np.flatnonzero(free == 0)[0]] = 1
    with pytest.raises(ValueError, match="^restore: the state's free"):
        short.restore(dataclasses.replace(state, free=free))
    kept, dropped = np.flatnonzero(state.mask), np.flatnonzero(state.free > state.mask)
    mask = state.mask.copy()
    mask[kept[0]], mask[dropped[-1]] = 0, 1  # a cut the bounds do not make
    with pytest.raises(ValueError, match="^restore: the state's mask"):
        short.restore(dataclasses.replace(state, mask=mask))
    faces = ModQuadAssemblyEnv(**VARIANTS["faces"])
    faces.reset(options={"task": TASK})
    faces.step(0)
    state = faces.state
    for field, value in (("faces", state.faces[::-1].copy()), ("sites", state.sites[::-1].copy())):
        with pytest.raises(ValueError, match=f"^restore: the state's {field}"):
            faces.restore(dataclasses.replace(state, **{field: value}))
    dynamic = ModQuadAssemblyEnv(**VARIANTS["dynamic"])
    dynamic.reset(seed=0)
    dynamic.step(dynamic.action_of((1, 0)))
    state = dynamic.state
    for task in (dataclasses.replace(state.task, WD=state.task.WD + 0.1),
                 dataclasses.replace(state.task, name="other")):  # fmt: skip
        with pytest.raises(ValueError, match="^restore: the state's task"):
            dynamic.restore(dataclasses.replace(state, task=task))


def test_a_shortlist_cut_between_equal_children_is_accepted():
    """At the start, docking at (1, 0) or (-1, 0) builds the same structure (up to translation):
    a shortlist of one may keep either (round-off decides between equal children); a cut
    keeping a child of other bounds is refused."""
    env = ModQuadAssemblyEnv(n_max=5, lookahead="exact", lookahead_top_k=1)
    env.reset(options={"task": TASK})
    state = env.state
    kept = int(np.flatnonzero(state.mask)[0])
    twin = env.action_of(tuple(-v for v in env.cell_of(kept)))
    mask = np.zeros_like(state.mask)
    mask[twin] = 1
    recomputed(env, dataclasses.replace(state, mask=mask))
    others = [a for a in np.flatnonzero(state.free) if a not in (kept, twin)]
    refused = 0
    for a in others:
        mask = np.zeros_like(state.mask)
        mask[a] = 1
        try:
            recomputed(env, dataclasses.replace(state, mask=mask))
        except ValueError as err:
            assert str(err).startswith("restore: the state's mask")
            refused += 1
    assert refused >= 1
