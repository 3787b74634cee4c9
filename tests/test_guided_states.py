"""The states the policy-guided search queues are small (a grid state keeps only its valid
actions' lookahead rows, int8 occupancy and type one-hot), and nothing a policy sees or the
search answers depends on it: observations against the dense rows of the lookahead, the
search against a plain replay that keeps no state."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from modquad_gym.envs.assembly import ModQuadAssemblyEnv
from modquad_gym.envs.assembly.lookahead import candidate_rows
from modquad_gym.policy import DEFAULT_MODEL
from modquad_gym.policy.guided import GuidedSolver
from modquad_gym.policy.models import SCALE_MODEL, TOP_K
from modquad_gym.tasks import PlantedTasks

PALETTE = "t45,t45m,flat"


def _task(n_modules: int, seed: int):
    return PlantedTasks(n_modules=n_modules, n_wrenches=8)(np.random.default_rng(seed))


def _dense_observation(env: ModQuadAssemblyEnv) -> dict:
    """The grid observation as the dense state made it: every action's lookahead row (the
    lookahead's own dense array, its memos shared, a walk memo of its own), the occupancy and
    the type one-hot from the cells."""
    state, grid = env.state, env.grid
    ep = dataclasses.replace(env._episode, walk_memo={})
    occupancy = np.zeros(grid.n_cells, dtype=np.float32)
    types = np.zeros(grid.n_actions, dtype=np.float32)
    for cell, k in zip(state.cells, state.types or [0] * len(state.cells)):
        occupancy[grid.action_of(cell)] = 1.0
        types[grid.action_of(cell, k)] = 1.0
    out = {"occupancy": occupancy, "candidates": candidate_rows(ep, state).reshape(-1)}
    return out | ({"types": types} if env.palette is not None else {})


@pytest.mark.parametrize(
    ("n_max", "modules", "lookahead", "top_k"),
    [
        (7, None, "exact", None),
        (24, None, "exact", TOP_K),
        (16, PALETTE, "exact", TOP_K),
        (7, PALETTE, True, None),
    ],
)
def test_observations_are_the_dense_ones(n_max, modules, lookahead, top_k):
    """Each step's observation equals the dense one (bit for bit, one machine), and the state
    holds only the valid actions' rows; the blocks keep their spaces' dtypes."""
    env = ModQuadAssemblyEnv(tasks="planted", n_max=n_max, modules=modules,
                             lookahead=lookahead, lookahead_top_k=top_k)  # fmt: skip
    rng = np.random.default_rng(n_max)
    obs, info = env.reset(options={"task": _task(min(n_max, 12), n_max)})
    for _ in range(6):
        assert env.observation_space.contains(obs)
        for key, want in _dense_observation(env).items():
            np.testing.assert_array_equal(obs[key], want, err_msg=key)
        state = env.state
        assert len(state.candidates) == np.count_nonzero(state.mask)
        assert state.occupancy.dtype == np.int8
        if info["success"]:
            break
        obs, _, done, _, info = env.step(int(rng.choice(np.flatnonzero(state.mask))))


def test_restore_refuses_a_state_of_another_lookahead():
    """Rows of another width (another lookahead) are refused like any other shape."""
    task = _task(5, 0)
    envs = [ModQuadAssemblyEnv(n_max=7, lookahead=la) for la in (True, "exact")]
    for env in envs:
        env.reset(options={"task": task})
    with pytest.raises(ValueError, match="restore: the state was made by another env"):
        envs[0].restore(envs[1].state)
    envs[1].restore(envs[1].state)


def test_restore_refuses_an_edited_state_in_one_line():
    """A state whose rows no longer match its valid actions (an extra valid action, a row cut),
    or whose arrays have another dtype or shape (a bool or int64 mask, float occupancy, a short
    structure vector, no cells), is refused with a one-line ValueError, not numpy's IndexError
    or TypeError from the observation."""
    env = ModQuadAssemblyEnv(n_max=5, lookahead=True)
    env.reset(options={"task": _task(5, 0)})
    env.step(int(np.flatnonzero(env.action_masks())[0]))
    state = env.state
    mask = state.mask.copy()
    mask[np.flatnonzero(mask == 0)[0]] = 1
    edits = {"lookahead rows for": [{"mask": mask}, {"candidates": state.candidates[:-1]}],
             "made by another env": [{"mask": state.mask.astype(bool)},
                                     {"mask": state.mask.astype(np.int64)},
                                     {"occupancy": state.occupancy.astype(float)},
                                     {"structure_vec": state.structure_vec[:3]},
                                     {"cells": None}]}  # fmt: skip
    for message, changes in edits.items():
        for change in changes:
            with pytest.raises(ValueError, match=f"^restore: .*{message}[^\n]*$"):
                env.restore(dataclasses.replace(state, **change))
    env.restore(state)


def _replayed(solver: GuidedSolver, task) -> GuidedSolver:
    """``solver`` whose environment restores a state by replaying its dockings from reset."""
    env, policy = solver.policy.env, solver.policy

    def replay(state):
        policy.reset(task, state.types[0] if policy.typed else None)
        for cell, k in zip(state.cells[1:], state.types[1:] or [0] * len(state.cells)):
            env.step(env.action_of(cell, k))

    env.restore = replay
    return solver


@pytest.mark.skipif(not (DEFAULT_MODEL.is_file() and SCALE_MODEL.is_file()), reason="no models")
@pytest.mark.parametrize(
    ("n_max", "n_modules", "n_wrenches", "modules", "budget", "dive", "seeds"),
    [
        (7, 7, 30, None, 32, True, (1, 5)),
        (20, 14, 30, None, 24, False, (0,)),
        (16, 10, 16, PALETTE, 16, True, (0, 1)),
    ],
)
def test_guided_answers_are_those_of_a_replay(n_max, n_modules, n_wrenches, modules, budget,
                                              dive, seeds):  # fmt: skip
    """The search from its queued states answers what it answers when every branch is
    replayed from reset (same structures, same evaluated counts), on tasks where it branches
    past its dive (or has none)."""
    from modquad_gym.geometry.module import palette

    def solver():
        s = GuidedSolver(n_max=n_max, budget=budget, top_k=TOP_K, dive=dive)
        if modules:
            s.policy.use_palette(palette(modules))
        return s

    for seed in seeds:
        task = PlantedTasks(n_modules=n_modules, n_wrenches=n_wrenches)(np.random.default_rng(seed))
        a, b = solver().solve(task), _replayed(solver(), task).solve(task)
        assert a.evaluated == b.evaluated and a.n_modules == b.n_modules
        assert a.evaluated > n_modules  # it branched
        assert (a.structure is None) == (b.structure is None)
        if a.structure is not None:
            assert a.structure.cells == b.structure.cells
            assert [m.name for m in a.structure.modules] == [m.name for m in b.structure.modules]
