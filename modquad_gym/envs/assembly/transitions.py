"""The transitions of the assembly environment: pure functions from an :class:`~.types.Episode`
(the context: grid, module set, evaluator, memos), a state and an action to the next state
(Jumanji keeps these beside ``step``)."""

from __future__ import annotations

import numpy as np

from modquad_gym.envs.assembly.lookahead import candidate_rows
from modquad_gym.envs.assembly.types import AssemblyState, Episode, TaskArrays


def decided_fields(ep: Episode, state: AssemblyState, cells: tuple, types: tuple) -> dict:
    """The state fields of the structure (cells, types) against the episode's task."""
    key = ep.modules.key(cells, types)
    n_sat, vec, tests = ep.evaluator.evaluate(key, state.task, ep.modules.mass(types), ep.memo)
    t = len(state.task.W)
    return {
        "structure_vec": vec,
        "frac": n_sat / t,
        "success": n_sat == t,
        "evaluated": state.evaluated + 1,
        "oracle_calls": state.oracle_calls + tests,
    }


def initial_state(ep: Episode, task: TaskArrays, types: tuple[int, ...]) -> AssemblyState:
    """One module at cell (0, 0) (of type ``types[0]`` with a palette) facing ``task``; no
    action is valid when it already satisfies the task (see the env's "Episode End")."""
    grid = ep.grid
    onehot = None
    if types:
        onehot = np.zeros(grid.n_actions, dtype=np.float32)
        onehot[types[0] * grid.n_cells + grid.centre] = 1.0
    occ = grid.initial_occupancy()
    state = AssemblyState(task, ((0, 0),), occ, grid.initial_mask.copy(), None, 0.0, False,
                          evaluated=0, types=types, types_onehot=onehot)  # fmt: skip
    fields = decided_fields(ep, state, state.cells, state.types)
    if fields["success"]:  # one module suffices: nothing may be added
        fields["mask"] = np.zeros_like(state.mask)
    return _with_candidates(ep, state.but(**fields))


def dock(ep: Episode, state: AssemblyState, a: int) -> AssemblyState:
    """The state after docking action ``a`` (valid) to ``state``."""
    G2 = ep.grid.n_cells
    c, k = a % G2, a // G2
    cells, types = (*state.cells, ep.grid.cell(c)), (*state.types, k) if state.types else ()
    occ, mask = ep.grid.dock(state.occupancy, state.mask, c)
    onehot = state.types_onehot
    if onehot is not None:
        onehot = onehot.copy()
        onehot[a] = 1.0
    fields = decided_fields(ep, state, cells, types)
    terminated = fields["success"] or len(cells) >= ep.rules.n_max or not mask.any()
    return state.but(
        cells=cells, types=types, occupancy=occ, mask=mask, types_onehot=onehot,
        steps=state.steps + 1, terminated=terminated, **fields,
    )  # fmt: skip


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
    end = {"truncated": not nxt.terminated and nxt.steps >= ep.rules.max_steps}
    if nxt.terminated:
        end["mask"] = np.zeros_like(nxt.mask)
    nxt = nxt.but(**end)
    if len(nxt.cells) > len(state.cells) or nxt.terminated:
        nxt = _with_candidates(ep, nxt)
    return nxt


def _with_candidates(ep: Episode, state: AssemblyState) -> AssemblyState:
    """``state`` with its lookahead rows (``lookahead=True``)."""
    if not ep.rules.lookahead:
        return state
    return state.but(candidates=candidate_rows(ep, state))
