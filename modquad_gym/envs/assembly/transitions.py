"""The transitions of the assembly environment: pure functions from an :class:`~.types.Episode`
(the context: action encoding, module set, evaluator, memos), a state and an action to the next
state (Jumanji keeps these beside ``step``)."""

from __future__ import annotations

import numpy as np

from modquad_gym.envs.assembly.lookahead import shortlisted
from modquad_gym.envs.assembly.types import AssemblyState, Episode, TaskArrays


def decided_fields(ep: Episode, state: AssemblyState, cells: tuple, types: tuple) -> dict:
    """The state fields of the structure (cells, types) against the episode's task (with the
    structure's own task arrays: those of a dynamic task change with it)."""
    key = ep.modules.key(cells, types)
    task = ep.evaluator.task_of(state.task, key)  # a dynamic task: the structure's own wrenches
    t = len(task.W)
    entry = ep.exact_memo.get(key)  # its exact lookahead entry: the count, by the same rule
    known = None if entry is None else round(entry[0] * t)
    n_sat, vec, tests = ep.evaluator.evaluate(key, task, ep.modules.mass(types), ep.memo, known)
    return {
        "task": task,
        "structure_vec": vec,
        "frac": n_sat / t,
        "success": n_sat == t,
        "evaluated": state.evaluated + 1,
        "oracle_calls": state.oracle_calls + tests,
    }


def satisfied(ep: Episode, state: AssemblyState) -> np.ndarray:
    """bool (t,): the task wrenches the state's structure satisfies, by the decision that
    ``state.frac`` counts (``fault`` and ``fault_margin`` included): what pictures show."""
    key = ep.modules.key(state.cells, state.types)
    return ep.evaluator.satisfied(key, state.task, ep.modules.mass(state.types))


def initial_state(ep: Episode, task: TaskArrays, types: tuple[int, ...]) -> AssemblyState:
    """One module at cell (0, 0) (of type ``types[0]`` with a palette) facing ``task``."""
    fields = ep.actions.initial_fields(types)
    state = AssemblyState(task, ((0, 0),), structure_vec=None, frac=0.0, success=False,
                          evaluated=0, types=types, **fields)  # fmt: skip
    return _with_candidates(ep, state.but(**decided_fields(ep, state, state.cells, state.types)))


def dock(ep: Episode, state: AssemblyState, a: int) -> AssemblyState:
    """The state after docking action ``a`` (valid) to ``state``."""
    cell, k = ep.actions.decode(state, a)
    cells, types = (*state.cells, cell), (*state.types, k) if state.types else ()
    fields = ep.actions.docked_fields(state, a)
    fields.update(decided_fields(ep, state, cells, types))
    terminated = fields["success"] or len(cells) >= ep.rules.n_max or not fields["mask"].any()
    return state.but(
        cells=cells, types=types, steps=state.steps + 1, terminated=terminated, **fields
    )


def transition(ep: Episode, state: AssemblyState, a: int | None, valid: bool) -> AssemblyState:
    """The state after action ``a`` (None: not an action of the space), ``valid`` or not (see
    the env's "Episode End")."""
    if state.success:  # solved at reset: this step (any action) only ends the episode
        nxt = state.but(steps=state.steps + 1, terminated=True)
    elif valid:
        nxt = dock(ep, state, a)
    else:
        terminated = ep.rules.invalid_action == "terminate"
        nxt = state.but(steps=state.steps + 1, terminated=terminated)
    nxt = nxt.but(truncated=not nxt.terminated and nxt.steps >= ep.rules.max_steps)
    if len(nxt.cells) > len(state.cells):
        nxt = _with_candidates(ep, nxt)
    return nxt


def _with_candidates(ep: Episode, state: AssemblyState) -> AssemblyState:
    """``state`` with its ``"candidates"`` rows, where the encoding has them (the exact
    lookahead's oracle tests counted in ``oracle_calls``), its actions cut to the lookahead's
    shortlist with ``lookahead_top_k``."""
    before, bounds = ep.evaluator.tests, {}
    if ep.rules.top_k is not None:
        state, bounds = shortlisted(ep, state)
    rows = ep.actions.candidates(ep, state, bounds)
    if rows is None:
        return state
    return state.but(candidates=rows, oracle_calls=state.oracle_calls + ep.evaluator.tests - before)
