"""The ``"candidates"`` observation (``lookahead=True``): one row per action describing the
child structure it would build, from support functions alone (see :mod:`.features`)."""

from __future__ import annotations

from typing import Any

import numpy as np

from modquad_gym.envs.assembly.features import CANDIDATE_FEATURES
from modquad_gym.envs.assembly.types import AssemblyState


def candidate_rows(env: Any, state: AssemblyState) -> np.ndarray:
    """float32 (actions, k) rows of ``env`` (a :class:`~.env.ModQuadAssemblyEnv`) in
    ``state``: those of valid actions filled, the others zero."""
    cand = np.zeros((env.grid.n_actions, CANDIDATE_FEATURES), dtype=np.float32)
    valid = np.flatnonzero(state.mask)
    mass0 = env._mass(state.types)
    G2 = env.grid.n_cells
    for k in range(env.n_types):  # one child mass per type: one batch each
        acts = valid if env.n_types == 1 else valid[valid // G2 == k]
        if len(acts):
            keys = [env._key((*state.cells, env.cell_of(a)), (*state.types, k)) for a in acts]
            mass = mass0 + env._masses[k] if env.n_types > 1 else mass0
            cand[acts] = env.evaluator.candidate_rows(keys, state.task, mass, env._cand_memo)
    return cand
