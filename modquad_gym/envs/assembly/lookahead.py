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
call, :mod:`.bounds`): upper bounds on its satisfied share and on its clipped mean
margin, the two numbers greedy ranks by. The k best by those bounds stay valid actions with
their full rows (the flag on greedy's choice among them); the others leave the action set of
this state (mask 0, rows zero), so the exact oracle decides k children a step, not all of them.
"""

from __future__ import annotations

from bisect import bisect_left
from collections.abc import Iterator

import numpy as np

from modquad_gym.envs.assembly.bounds import (
    Bounds,
    margin_bound,
    projections,
    ray_ratios,
    support_bounds,
)
from modquad_gym.envs.assembly.exact import CLIP_GAMMA, Lineage, exact_rows
from modquad_gym.envs.assembly.features import CANDIDATE_FEATURES, lookahead_width
from modquad_gym.envs.assembly.types import AssemblyState, Episode
from modquad_gym.oracle import TOL
from modquad_gym.search.baselines import TIE_DECIMALS, greedy_rank

SHARE, MARGIN, GREEDY = CANDIDATE_FEATURES, CANDIDATE_FEATURES + 1, CANDIDATE_FEATURES + 2
"""Columns of the exact entries in a row."""


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
    parent = inherited(ep, state) if exact else None
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
    the new module's columns go in at its place among them, with unknown bounds), the child's
    gamma bounds ``lower`` (or None), its new cell and that module's first column."""
    r = ep.evaluator.module.n_rotors
    order = sorted(state.cells)
    tights, signs = (None, None) if walks is None else (walks[0].astype(np.int64), walks[1])
    out = []
    for i, c in enumerate(cells):
        start, at = None, r * bisect_left(order, c)
        if walks is not None:
            child = np.zeros((len(signs), signs.shape[1] + r), dtype=np.int8)
            child[:, :at], child[:, at + r :] = signs[:, :at], signs[:, at:]
            start = (tights + r * (tights >= at), child)
        out.append(Lineage(start, None if lower is None else lower[i], c, at))
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


def flagged(candidates: np.ndarray, mask: np.ndarray) -> int | None:
    """The valid action of ``mask`` that a ``"candidates"`` observation (exact lookahead) flags
    as greedy's choice, or None when none is flagged."""
    flags = np.asarray(candidates).reshape(len(mask), -1)[:, GREEDY]
    found = np.flatnonzero((flags == 1.0) & np.asarray(mask, dtype=bool))
    return int(found[0]) if len(found) else None


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


def inherited(ep: Episode, state: AssemblyState) -> tuple | None:
    """The optimal vertices of ``state``'s own walks (tight columns, column bounds per wrench),
    left by the step that computed its exact entries as a child, or None."""
    return ep.walk_memo.get(ep.modules.key(state.cells, state.types))


def parent_directions(ep: Episode, state: AssemblyState) -> np.ndarray:
    """(2, t, 6): per task wrench, two directions that nearly decide its gauge in a child of
    ``state``'s structure: the last direction of that structure's own exact walk from the
    dual-metric direction (a facet normal where the wrench leaves its zonotope, or a direction
    proving it lies beyond :data:`~.exact.CLIP_GAMMA`; one exact evaluation a step, where the
    children would take one each), and the dual-metric direction ``(A A^T)^+ (w - c)`` (the
    normal where the ray from the centre leaves the ellipsoid of the same second moment).

    Where ``state``'s exact entries left a walk's optimal vertex (:func:`inherited`) that is
    the unique optimum below the clip, its direction is that walk's end (up to round-off):
    read off the vertex (:func:`~modquad_gym.oracle.vertices.vertex_directions`), not walked."""
    from modquad_gym.oracle import vertices
    from modquad_gym.oracle.compiled import gamma_compiled

    ev = ep.evaluator
    key = ep.modules.key(state.cells, state.types)
    A = ev.capability_of(key).A
    W = ev.at_mass(state.task, ep.modules.mass(state.types))[0]
    z = ev.oracle.zonotope(A, key=key)
    R, off = z.reduce(W)
    on = np.flatnonzero(~off)
    dirs, found = np.zeros((len(on), z.rank)), np.zeros(len(on), dtype=bool)
    walks = inherited(ep, state)
    if walks is not None and walks[0].shape == (len(W), max(z.rank - 1, 1)):
        vertices.vertex_directions(z.G, R[on], walks[0][on], walks[1][on], CLIP_GAMMA, dirs, found)
    rest = np.flatnonzero(~found)
    if len(rest):
        walked = np.zeros((len(rest), z.rank))
        gamma_compiled(z, R[on[rest]], CLIP_GAMMA, walked)
        dirs[rest] = walked
    ev.tests += len(rest)
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
