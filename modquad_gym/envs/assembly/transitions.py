"""The transitions of the assembly environment: from one :class:`~.types.AssemblyState` and an
action to the next (Jumanji keeps these beside ``step``; here they take the env for its grid,
evaluator and the hooks of the mixed env)."""

from __future__ import annotations

from typing import Any

import numpy as np

from modquad_gym.envs.assembly.lookahead import candidate_rows
from modquad_gym.envs.assembly.types import AssemblyState


def decided_fields(env: Any, state: AssemblyState, cells: tuple, types: tuple) -> dict:
    """The state fields of the structure (cells, types) against the episode's task."""
    n_sat, vec, tests = env.evaluator.evaluate(
        env._key(cells, types), state.task, env._mass(types), env._memo
    )
    t = len(state.task.W)
    return {
        "structure_vec": vec,
        "frac": n_sat / t,
        "success": n_sat == t,
        "evaluated": state.evaluated + 1,
        "oracle_calls": state.oracle_calls + tests,
    }


def dock(env: Any, state: AssemblyState, a: int) -> AssemblyState:
    """The state after docking action ``a`` (valid) to ``state``."""
    G2 = env.grid.n_cells
    c, k = a % G2, a // G2
    cells, types = (*state.cells, env.grid.cell(c)), (*state.types, k) if state.types else ()
    occ, mask = env.grid.dock(state.occupancy, state.mask, c)
    onehot = state.types_onehot
    if onehot is not None:
        onehot = onehot.copy()
        onehot[a] = 1.0
    fields = decided_fields(env, state, cells, types)
    terminated = fields["success"] or len(cells) >= env.n_max or not mask.any()
    return state.but(
        cells=cells, types=types, occupancy=occ, mask=mask, types_onehot=onehot,
        steps=state.steps + 1, terminated=terminated, **fields,
    )  # fmt: skip


def transition(env: Any, state: AssemblyState, a: int | None, valid: bool) -> AssemblyState:
    """The state after action ``a`` (None: not an action of the space), ``valid`` or not (see
    the env's "Episode End")."""
    if state.success:  # solved at reset: this step (any action) only ends the episode
        nxt = state.but(steps=state.steps + 1, terminated=True)
    elif valid:
        nxt = dock(env, state, a)
    else:
        terminated = env.invalid_action == "terminate"
        nxt = state.but(steps=state.steps + 1, terminated=terminated)
    nxt.truncated = not nxt.terminated and nxt.steps >= env.max_steps
    if nxt.terminated:
        nxt.mask = np.zeros_like(nxt.mask)
    if env.lookahead and (len(nxt.cells) > len(state.cells) or nxt.terminated):
        nxt.candidates = candidate_rows(env, nxt)
    return nxt
