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

from bisect import bisect_left
from collections.abc import Iterator
from typing import NamedTuple

import numpy as np
from numba import njit

from modquad_gym.envs.assembly.exact import CLIP_GAMMA, Lineage, exact_rows
from modquad_gym.envs.assembly.features import CANDIDATE_FEATURES, lookahead_width
from modquad_gym.envs.assembly.types import AssemblyState, Episode
from modquad_gym.oracle import TOL
from modquad_gym.search.baselines import TIE_DECIMALS, greedy_rank

SHARE, MARGIN, GREEDY = CANDIDATE_FEATURES, CANDIDATE_FEATURES + 1, CANDIDATE_FEATURES + 2
"""Columns of the exact entries in a row."""
FLAT = 1e-9
"""Widths (and offsets) below this (in units of denom) count as zero: a flat direction of a
rank-deficient W bounds nothing but what lies off it."""


class Bounds(NamedTuple):
    """What the shortlist knows of L children without an oracle call."""

    share: np.ndarray
    """(L,) upper bounds on the satisfied share."""
    gamma: np.ndarray
    """(L, t) lower bounds on each wrench's gamma (:func:`margin_bound`: on the mean margin)."""
    h: np.ndarray
    """(L, K) supports on the feature directions / denom (the support rows' input)."""
    slack: np.ndarray
    """(L,) the support screen's slack (:meth:`~.features.AssemblyFeatures.support`)."""


def children(ep: Episode, state: AssemblyState, acts: np.ndarray) -> Iterator[tuple]:
    """(actions, their cells, module type, child mass) of the actions ``acts`` of ``state``,
    one batch per module type (one child mass each)."""
    actions, modules = ep.actions, ep.modules
    mass0 = modules.mass(state.types)
    for k in range(modules.n_types):
        batch = acts if modules.n_types == 1 else acts[acts // actions.block == k]
        if len(batch):
            cells = [actions.decode(state, a)[0] for a in batch.tolist()]
            yield batch, cells, k, modules.child_mass(mass0, k)


def child_keys(ep: Episode, state: AssemblyState, cells: list, k: int) -> list:
    """The evaluator's keys of the children of ``state`` with a module of type ``k`` at
    ``cells``."""
    return [ep.modules.key((*state.cells, c), (*state.types, k)) for c in cells]


def child_matrices(ep: Episode, state: AssemblyState, cells: list, k: int) -> np.ndarray:
    """(L, 6, m) configuration matrices of those children, straight from their cells (no key:
    a key of 128 cells costs more to build than the child's bounds)."""
    n = len(state.cells)
    grid = np.empty((len(cells), n + 1, 2))
    grid[:, :n], grid[:, n] = state.cells, cells
    types = np.zeros((len(cells), n + 1), dtype=np.int64)
    types[:, :n], types[:, n] = state.types or 0, k
    return ep.evaluator.cell_matrices(grid, types)


def candidate_rows(ep: Episode, state: AssemblyState, bounds: dict | None = None) -> np.ndarray:
    """float32 (actions, width) rows of ``state`` in episode ``ep``: those of valid actions
    filled, the others zero. ``bounds``: action -> its child's :class:`Bounds` (the
    shortlist's, :func:`shortlisted`): its supports need no second pass, a wrench whose gamma
    they prove past the clip no walk."""
    actions = ep.actions
    exact = ep.rules.lookahead == "exact"
    cand = np.zeros((actions.n_actions, lookahead_width(ep.rules.lookahead)), dtype=np.float32)
    valid = np.flatnonzero(state.mask)
    cells, scores = {}, {}
    parent = ep.walk_memo.get(ep.modules.key(state.cells, state.types)) if exact else None
    ep.walk_memo.clear()  # only this state's children: one of them is the next parent
    for acts, batch_cells, k, mass in children(ep, state, valid):
        keys = child_keys(ep, state, batch_cells, k)
        cells.update(zip(acts.tolist(), batch_cells))
        known = [bounds.get(a) for a in acts.tolist()] if bounds else None
        supports = None if known is None else [b and (b.h, b.slack) for b in known]
        cand[acts, :CANDIDATE_FEATURES] = ep.evaluator.candidate_rows(
            keys, state.task, mass, ep.cand_memo, supports
        )
        if exact:
            lower = None if known is None else [b and b.gamma for b in known]
            lines = lineages(ep, state, batch_cells, parent, lower)
            rows = exact_rows(
                ep.evaluator, keys, state.task, mass, ep.memo, ep.exact_memo, ep.walk_memo, lines
            )
            cand[acts, SHARE:GREEDY] = rows
            scores.update(zip(acts.tolist(), rows))
    if exact and len(valid):
        cand[greedy_choice(scores, cells, actions), GREEDY] = 1.0
    return cand


def lineages(ep: Episode, state: AssemblyState, cells: list, walks, lower: list | None) -> list:
    """The :class:`~.exact.Lineage` of each child of ``state`` with a module at one of
    ``cells``: the optimal vertices of the parent's walks (``walks``: tight columns and column
    bounds per wrench, or None) renumbered to the child's columns (a key sorts its cells, so
    the new module's columns go in at its place among them, with unknown bounds), and the
    child's gamma bounds ``lower`` (or None)."""
    r = ep.evaluator.module.n_rotors
    order = sorted(state.cells)
    tights, signs = (None, None) if walks is None else (walks[0].astype(np.int64), walks[1])
    out = []
    for i, c in enumerate(cells):
        start = None
        if walks is not None:
            at = r * bisect_left(order, c)
            child = np.zeros((len(signs), signs.shape[1] + r), dtype=np.int8)
            child[:, :at], child[:, at + r :] = signs[:, :at], signs[:, at:]
            start = (tights + r * (tights >= at), child)
        out.append(Lineage(start, None if lower is None else lower[i]))
    return out


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


def shortlisted(ep: Episode, state: AssemblyState) -> tuple[AssemblyState, dict]:
    """(``state`` with its valid actions cut to the first ``ep.rules.top_k`` of
    :func:`ranked`, the encoding's own mask kept in ``free`` (None when nothing was cut),
    kept action -> its child's :class:`Bounds` (one row))."""
    valid = np.flatnonzero(state.mask)
    if len(valid) <= ep.rules.top_k:
        return state.but(free=None), {}
    order, bounds = ranking(ep, state, valid)
    kept = order[: ep.rules.top_k].tolist()
    mask = np.zeros_like(state.mask)
    mask[kept] = 1
    rows = {a: Bounds(*(field[i] for field in bounds)) for i, a in enumerate(kept)}
    return state.but(mask=mask, free=state.mask), rows


def ranked(ep: Episode, state: AssemblyState, acts: np.ndarray) -> np.ndarray:
    """The actions ``acts`` of ``state``, best first by :func:`child_bounds`: the share
    bound, then the margin bound (rounded as greedy rounds), then (cell, type) order."""
    return ranking(ep, state, acts)[0]


def ranking(ep: Episode, state: AssemblyState, acts: np.ndarray) -> tuple[np.ndarray, Bounds]:
    """(:func:`ranked`, the :class:`Bounds` of :func:`child_bounds` in that order)."""
    batches, order, parts = [], [], []
    directions = None if state.task.per_structure else parent_directions(ep, state)
    for batch, cells, k, mass in children(ep, state, acts):
        parts.append(child_bounds(ep, state, cells, k, mass, directions))
        batches.append(batch)
        order += [(c, ep.actions.type_of(a)) for a, c in zip(batch.tolist(), cells)]
    tie = np.empty(len(order), dtype=np.int64)
    tie[sorted(range(len(order)), key=order.__getitem__)] = np.arange(len(order))
    bounds = Bounds(*(np.concatenate(field) for field in zip(*parts)))
    margin = np.round(margin_bound(bounds.gamma), TIE_DECIMALS)
    best = np.lexsort((tie, -margin, -bounds.share))
    return np.concatenate(batches)[best], Bounds(*(field[best] for field in bounds))


def parent_directions(ep: Episode, state: AssemblyState) -> np.ndarray:
    """(2, t, 6): per task wrench, two directions that nearly decide its gauge in a child of
    ``state``'s structure: the last direction of that structure's own exact walk (a facet
    normal where the wrench leaves its zonotope, or a direction proving it lies beyond
    :data:`~.exact.CLIP_GAMMA`; one exact evaluation a step, where the children would
    take one each), and the dual-metric direction ``(A A^T)^+ (w - c)`` (the normal where the
    ray from the centre leaves the ellipsoid of the same second moment)."""
    from modquad_gym.oracle.compiled import gamma_compiled

    ev = ep.evaluator
    key = ep.modules.key(state.cells, state.types)
    A = ev.capability_of(key).A
    W = ev.at_mass(state.task, ep.modules.mass(state.types))[0]
    z = ev.oracle.zonotope(A, key=key)
    R, off = z.reduce(W)
    on = np.flatnonzero(~off)
    dirs = np.zeros((len(on), z.rank))
    gamma_compiled(z, R[on], CLIP_GAMMA, dirs)
    ev.tests += len(on)
    out = np.zeros((2, len(W), 6))
    out[0, on] = dirs @ z.Q.T
    # (A A^T)^+ = Q diag(1 / S^2) Q^T from the zonotope's SVD (S = 2 sigma: 1 / S^2 = dual / 4)
    centred = (W - A.sum(axis=1) * (ev.features.f_max / 2.0)) @ z.Q
    out[1] = (centred * (z.dual / 4.0)) @ z.Q.T
    return out


def child_bounds(
    ep: Episode, state: AssemblyState, cells: list, k: int, mass: float, directions=None
) -> Bounds:
    """The :class:`Bounds` of the children of ``state`` with a module of type ``k`` (of
    ``mass`` kg with it) at ``cells`` against its task: :func:`support_bounds` on the feature
    directions and :func:`ray_bounds` on ``directions`` (s, t, 6) per wrench (a dynamic task:
    each child against its own wrenches, feature directions only)."""
    ev, task = ep.evaluator, state.task
    if task.per_structure:
        keys = child_keys(ep, state, cells, k)
        h, slack, centre = ev.supports_of(keys, centres=True)
        parts = [
            support_bounds(h[i : i + 1], slack[i : i + 1], centre[i : i + 1], own.WD)
            for i, own in enumerate(ev.task_of(task, k) for k in keys)
        ]
        share, gamma = (np.concatenate(field) for field in zip(*parts))
        return Bounds(share, gamma, h, slack)
    A, f = child_matrices(ep, state, cells, k), ev.features
    rays = () if directions is None else tuple(directions)
    absolute, signed = projections(np.vstack([f.D, *rays]), A)  # every direction in one pass
    h = (absolute[:, : f.k] + signed[:, : f.k]) * (f.f_max / 2.0) / f.denom
    slack = ((2.0 * TOL * f.f_max * absolute[:, : f.k] + 1e-12) / f.denom).max(axis=1)
    W, _, WD = ev.at_mass(task, mass)
    share, gamma = support_bounds(h, slack, signed[:, : f.k] * (f.f_max / 2.0) / f.denom, WD)
    norms = np.linalg.norm(A, axis=1).sum(axis=1)
    for i, D in enumerate(rays):
        cut = slice(f.k + i * len(W), f.k + (i + 1) * len(W))
        bound = ray_ratios(absolute[:, cut], signed[:, cut], D, W, f.f_max, norms)
        gamma = np.maximum(gamma, bound)
    return Bounds(share, gamma, h, slack)


def margin_bound(gamma: np.ndarray) -> np.ndarray:
    """The mean over wrenches of ``1 - gamma`` clipped to [-1, 1], per row of ``gamma``."""
    return np.clip(1.0 - gamma, -1.0, 1.0).mean(axis=1)


def support_bounds(
    h_Cn: np.ndarray, slack: np.ndarray, centre: np.ndarray, WD: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """(share bound (L,), gamma bound (L, t)) of L structures with supports ``h_Cn`` (L, K),
    slacks (L,) and centres ``centre`` (L, K) (:meth:`~.features.AssemblyFeatures.supports`)
    against wrenches of projections ``WD`` (t, K), all divided by denom (which cancels).

    gamma is a wrench's gauge about W's centre c (the oracle's: its margin is 1 - gamma). W is
    symmetric about c, so w = c + gamma z with z in W - c gives |d . (w - c)| <= gamma
    (h_W(d) - d . c) in every direction d: the largest ratio bounds gamma from below, hence
    the margin from above. The share bound counts the wrenches the support test cannot
    reject (it never rejects one the oracle accepts; see ``slack``)."""
    share, gamma = np.empty(len(h_Cn)), np.empty((len(h_Cn), len(WD)))
    _support_bounds(h_Cn, slack, centre, WD, FLAT, share, gamma)
    return share, gamma


@njit(cache=True)
def _support_bounds(h_Cn, slack, centre, WD, flat, share, gamma):  # pragma: no cover - compiled
    """:func:`support_bounds` in one pass, no (L, t, K) arrays: per structure and wrench the
    largest deficit ``WD - h`` and the largest :func:`ratios` of ``|WD - c|`` to ``h - c``
    (the same operations on the same numbers as numpy's element-wise version)."""
    L, t, K = h_Cn.shape[0], WD.shape[0], WD.shape[1]
    for l in range(L):
        kept = 0
        for i in range(t):
            deficit = -np.inf
            ratio = -np.inf
            for d in range(K):
                deficit = max(deficit, WD[i, d] - h_Cn[l, d])
                off = abs(WD[i, d] - centre[l, d])
                width = h_Cn[l, d] - centre[l, d]
                if width > flat:
                    ratio = max(ratio, off / width)
                else:
                    ratio = max(ratio, np.inf if off > flat else 0.0)
            kept += deficit <= slack[l]
            gamma[l, i] = ratio
        share[l] = kept / t


def ray_bounds(A: np.ndarray, D: np.ndarray, W: np.ndarray, f_max: float) -> np.ndarray:
    """gamma bound (L, t) of the structures of configuration matrices ``A`` (L, 6, m) for the
    wrenches ``W`` (t, 6), each in its own direction (a row of ``D``, (t, 6); zero: none),
    by the inequality of :func:`support_bounds`."""
    absolute, signed = projections(D, A)
    return ray_ratios(absolute, signed, D, W, f_max, np.linalg.norm(A, axis=1).sum(axis=1))


def ray_ratios(absolute, signed, D, W, f_max: float, norms) -> np.ndarray:
    """:func:`ray_bounds` from the :func:`projections` of the directions ``D`` and the
    structures' sums of column norms ``norms`` (L,) (the scale of a flat width)."""
    half = f_max / 2.0
    off = np.abs(np.einsum("ti,ti->t", D, W)[None] - signed * half)
    flat = FLAT * half * np.linalg.norm(D, axis=1)[None] * norms[:, None]
    return ratios(off, absolute * half, flat)


@njit(cache=True, fastmath={"reassoc", "contract"})
def projections(D, A):  # pragma: no cover - compiled
    """(sum_k |d . a_k|, sum_k d . a_k), each (L, R), for directions D (R, 6) and the columns
    a_k of the matrices A (L, 6, m): one pass, no (L, R, m) array (the supports, W's centre
    and the widths about it follow). The sums over k are reordered (SIMD: 5x faster at 100
    columns), so they differ from numpy's in the last bits: bounds, not decisions."""
    L, m, R = A.shape[0], A.shape[2], D.shape[0]
    absolute = np.empty((L, R))
    signed = np.empty((L, R))
    for l in range(L):
        a0, a1, a2, a3, a4, a5 = A[l, 0], A[l, 1], A[l, 2], A[l, 3], A[l, 4], A[l, 5]
        for r in range(R):
            d0, d1, d2, d3, d4, d5 = D[r, 0], D[r, 1], D[r, 2], D[r, 3], D[r, 4], D[r, 5]
            total, size = 0.0, 0.0
            for k in range(m):
                p = d0 * a0[k] + d1 * a1[k] + d2 * a2[k] + d3 * a3[k] + d4 * a4[k] + d5 * a5[k]
                size += abs(p)
                total += p
            absolute[l, r] = size
            signed[l, r] = total
    return absolute, signed


def ratios(off: np.ndarray, width: np.ndarray, flat) -> np.ndarray:
    """off / width where the width exceeds ``flat``; else inf where the offset does too (off a
    flat direction: not in W), 0 where it does not (no bound)."""
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(width > flat, off / width, np.where(off > flat, np.inf, 0.0))
