"""The ``"candidates"`` observation (``lookahead=True``): one row per action describing the
child structure it would build, from support functions alone (see :mod:`.features`)."""

from __future__ import annotations

import numpy as np

from modquad_gym.envs.assembly.features import CANDIDATE_FEATURES
from modquad_gym.envs.assembly.types import AssemblyState, Episode


def candidate_rows(ep: Episode, state: AssemblyState) -> np.ndarray:
    """float32 (actions, k) rows of ``state`` in episode ``ep``: those of valid actions
    filled, the others zero."""
    grid, modules = ep.grid, ep.modules
    cand = np.zeros((grid.n_actions, CANDIDATE_FEATURES), dtype=np.float32)
    valid = np.flatnonzero(state.mask)
    mass0 = modules.mass(state.types)
    G2 = grid.n_cells
    for k in range(modules.n_types):  # one child mass per type: one batch each
        acts = valid if modules.n_types == 1 else valid[valid // G2 == k]
        if len(acts):
            keys = [modules.key((*state.cells, grid.cell_of(a)), (*state.types, k)) for a in acts]
            mass = modules.child_mass(mass0, k)
            cand[acts] = ep.evaluator.candidate_rows(keys, state.task, mass, ep.cand_memo)
    return cand
