"""The support rows of the ``"candidates"`` observation (``lookahead=True``): one row per action
describing the child structure it would build, from support functions alone (see
:mod:`.features`)."""

from __future__ import annotations

import numpy as np

from modquad_gym.envs.assembly.features import CANDIDATE_FEATURES
from modquad_gym.envs.assembly.types import AssemblyState, Episode


def candidate_rows(ep: Episode, state: AssemblyState) -> np.ndarray:
    """float32 (actions, k) rows of ``state`` in episode ``ep``: those of valid actions
    filled, the others zero."""
    actions, modules = ep.actions, ep.modules
    cand = np.zeros((actions.n_actions, CANDIDATE_FEATURES), dtype=np.float32)
    valid = np.flatnonzero(state.mask)
    mass0 = modules.mass(state.types)
    for k in range(modules.n_types):  # one child mass per type: one batch each
        acts = valid if modules.n_types == 1 else valid[valid // actions.block == k]
        if len(acts):
            keys = [
                modules.key((*state.cells, actions.decode(state, a)[0]), (*state.types, k))
                for a in acts
            ]
            mass = modules.child_mass(mass0, k)
            cand[acts] = ep.evaluator.candidate_rows(keys, state.task, mass, ep.cand_memo)
    return cand
