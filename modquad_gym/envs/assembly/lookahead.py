"""The lookahead rows of the ``"candidates"`` observation: one row per action describing the
child structure it would build.

``lookahead=True``: the child's support features alone (no oracle call, see :mod:`.features`).
``lookahead="exact"``: also what the greedy rule ranks children by, from the exact oracle (the
child's satisfied share and clipped mean margin) and a flag on greedy's own choice, so a policy
sees the exact one-step lookahead greedy uses and can learn a correction to it. Every child is
decided, so the step that docks it finds its decision memoised; the oracle tests count in
``info["oracle_calls"]``.
"""

from __future__ import annotations

import numpy as np

from modquad_gym.envs.assembly.features import CANDIDATE_FEATURES, lookahead_width
from modquad_gym.envs.assembly.types import AssemblyState, Episode
from modquad_gym.search.baselines import greedy_rank

SHARE, MARGIN, GREEDY = CANDIDATE_FEATURES, CANDIDATE_FEATURES + 1, CANDIDATE_FEATURES + 2
"""Columns of the exact entries in a row."""


def candidate_rows(ep: Episode, state: AssemblyState) -> np.ndarray:
    """float32 (actions, width) rows of ``state`` in episode ``ep``: those of valid actions
    filled, the others zero."""
    actions, modules = ep.actions, ep.modules
    exact = ep.rules.lookahead == "exact"
    cand = np.zeros((actions.n_actions, lookahead_width(ep.rules.lookahead)), dtype=np.float32)
    valid = np.flatnonzero(state.mask)
    mass0 = modules.mass(state.types)
    cells, scores = {}, {}
    for k in range(modules.n_types):  # one child mass per type: one batch each
        acts = valid if modules.n_types == 1 else valid[valid // actions.block == k]
        if not len(acts):
            continue
        for a in acts.tolist():
            cells[a] = actions.decode(state, a)[0]
        keys = [modules.key((*state.cells, cells[a]), (*state.types, k)) for a in acts.tolist()]
        mass = modules.child_mass(mass0, k)
        cand[acts, :CANDIDATE_FEATURES] = ep.evaluator.candidate_rows(
            keys, state.task, mass, ep.cand_memo
        )
        if exact:
            rows = ep.evaluator.exact_rows(keys, state.task, mass, ep.memo, ep.exact_memo)
            cand[acts, SHARE:GREEDY] = rows
            scores.update(zip(acts.tolist(), rows))
    if exact and len(valid):
        cand[greedy_choice(scores, cells, actions), GREEDY] = 1.0
    return cand


def greedy_choice(scores: dict, cells: dict, actions) -> int:
    """The action greedy docks among ``scores`` (action -> (share, margin)): the largest
    :func:`~modquad_gym.search.baselines.greedy_rank`, the first in (cell, type) order among
    equals."""
    best, best_score = -1, None
    for a in sorted(scores, key=lambda a: (cells[a], actions.type_of(a))):
        score = greedy_rank(*scores[a])
        if best_score is None or score > best_score:
            best, best_score = a, score
    return best
