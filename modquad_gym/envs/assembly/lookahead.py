"""The lookahead rows of the ``"candidates"`` observation: one row per action describing the
child structure it would build.

``lookahead=True``: the child's support features alone (no oracle call, see :mod:`.features`).
``lookahead="exact"``: also what the greedy rule ranks children by, from the exact oracle (the
child's satisfied share and clipped mean margin) and a flag on greedy's own choice, so a policy
sees the exact one-step lookahead greedy uses and can learn a correction to it. Every child is
decided, so the step that docks it finds its decision memoised; the oracle tests count in
``info["oracle_calls"]``.

``lookahead_top_k=k`` (with ``"exact"``): the exact entries for a shortlist only. Every valid
child gets two cheap bounds from its support function on the feature directions (no oracle
call, :func:`support_bounds`): upper bounds on its satisfied share and on its clipped mean
margin, the two numbers greedy ranks by. The k best by those bounds stay valid actions with
their full rows (the flag on greedy's choice among them); the others leave the action set of
this state (mask 0, rows zero), so the exact oracle decides k children a step, not all of them.
"""

from __future__ import annotations

from collections.abc import Iterator

import numpy as np

from modquad_gym.envs.assembly.features import CANDIDATE_FEATURES, lookahead_width
from modquad_gym.envs.assembly.types import AssemblyState, Episode
from modquad_gym.search.baselines import TIE_DECIMALS, greedy_rank

SHARE, MARGIN, GREEDY = CANDIDATE_FEATURES, CANDIDATE_FEATURES + 1, CANDIDATE_FEATURES + 2
"""Columns of the exact entries in a row."""
CHUNK = 2**21
"""Most (child, wrench, direction) entries :func:`support_bounds` holds at once (16 MB)."""


def children(ep: Episode, state: AssemblyState, acts: np.ndarray) -> Iterator[tuple]:
    """(actions, child keys, child mass) of the actions ``acts`` of ``state``, one batch per
    module type (one child mass each)."""
    actions, modules = ep.actions, ep.modules
    mass0 = modules.mass(state.types)
    for k in range(modules.n_types):
        batch = acts if modules.n_types == 1 else acts[acts // actions.block == k]
        if len(batch):
            cells = [actions.decode(state, a)[0] for a in batch.tolist()]
            keys = [modules.key((*state.cells, c), (*state.types, k)) for c in cells]
            yield batch, cells, keys, modules.child_mass(mass0, k)


def candidate_rows(ep: Episode, state: AssemblyState) -> np.ndarray:
    """float32 (actions, width) rows of ``state`` in episode ``ep``: those of valid actions
    filled, the others zero."""
    actions = ep.actions
    exact = ep.rules.lookahead == "exact"
    cand = np.zeros((actions.n_actions, lookahead_width(ep.rules.lookahead)), dtype=np.float32)
    valid = np.flatnonzero(state.mask)
    cells, scores = {}, {}
    for acts, batch_cells, keys, mass in children(ep, state, valid):
        cells.update(zip(acts.tolist(), batch_cells))
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


def shortlisted(ep: Episode, state: AssemblyState) -> AssemblyState:
    """``state`` with its valid actions cut to the ``ep.rules.top_k`` best by
    :func:`support_bounds` (share bound, then margin bound, then (cell, type) order as greedy
    breaks ties), the encoding's own mask kept in ``free`` (None when nothing was cut)."""
    valid = np.flatnonzero(state.mask)
    if len(valid) <= ep.rules.top_k:
        return state.but(free=None)
    acts, order, share, margin = [], [], [], []
    for batch, cells, keys, mass in children(ep, state, valid):
        s, m = child_bounds(ep.evaluator, state.task, keys, mass)
        acts.append(batch)
        share.append(s)
        margin.append(m)
        order += [(c, ep.actions.type_of(a)) for a, c in zip(batch.tolist(), cells)]
    tie = np.empty(len(order), dtype=np.int64)
    tie[sorted(range(len(order)), key=order.__getitem__)] = np.arange(len(order))
    share, margin = np.concatenate(share), np.round(np.concatenate(margin), TIE_DECIMALS)
    best = np.concatenate(acts)[np.lexsort((tie, -margin, -share))[: ep.rules.top_k]]
    mask = np.zeros_like(state.mask)
    mask[best] = 1
    return state.but(mask=mask, free=state.mask)


def child_bounds(evaluator, task, keys: list, mass: float) -> tuple[np.ndarray, np.ndarray]:
    """:func:`support_bounds` of the child structures ``keys`` (one size, one mass) against
    ``task`` (a dynamic task: each child against its own wrenches)."""
    h, slack = evaluator.supports_of(keys)
    if not task.per_structure:
        return support_bounds(h, slack, evaluator.at_mass(task, mass)[2])
    own = [evaluator.task_of(task, k).WD for k in keys]
    rows = [support_bounds(h[i : i + 1], slack[i : i + 1], WD) for i, WD in enumerate(own)]
    return np.concatenate([r[0] for r in rows]), np.concatenate([r[1] for r in rows])


def support_bounds(
    h_Cn: np.ndarray, slack: np.ndarray, WD: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """(share bound (L,), margin bound (L,)) of L structures with supports ``h_Cn`` (L, K) and
    slacks (L,) (:meth:`~.features.AssemblyFeatures.supports`) against wrenches of projections
    ``WD`` (t, K) (all divided by denom, which cancels in a ratio).

    A wrench w lies in gamma W only if d . w <= gamma h_W(d) in every direction d, so
    max_d (d . w) / h_W(d) bounds its gamma from below and 1 minus it bounds its margin
    1 - gamma from above; clipped to [-1, 1] and averaged, the exact lookahead's mean margin
    from above. The share bound counts the wrenches the support test cannot reject (the
    oracle accepts every wrench it decides feasible; see ``slack``)."""
    n, t, k = len(h_Cn), len(WD), WD.shape[1]
    share, margin = np.empty(n), np.empty(n)
    step = max(1, CHUNK // max(t * k, 1))
    for i in range(0, n, step):
        h, cut = h_Cn[i : i + step, None, :], slice(i, i + step)
        share[cut] = np.count_nonzero((WD[None] - h).max(axis=2) <= slack[cut, None], axis=1) / t
        with np.errstate(divide="ignore", invalid="ignore"):
            ratio = np.where(h > 0.0, WD[None] / h, np.where(WD[None] > 0.0, np.inf, -np.inf))
        margin[cut] = np.clip(1.0 - ratio.max(axis=2), -1.0, 1.0).mean(axis=1)
    return share, margin
