"""The exact lookahead's entries of a state's children: each child's satisfied share and mean
clipped margin, what the greedy rule ranks children by
(:func:`~modquad_gym.search.baselines.greedy_search`), from the exact oracle.

A child differs from its parent by one module, so what the parent computed starts the child's
work (a :class:`Lineage` per child; without one, the plain path: the same entries up to
round-off):

* its walks start at the parent's optimal vertices (per wrench: the tight columns renumbered to
  the child's columns, with the other columns' bounds), a few pivots from the child's optimum,
  or at the optimum of the nearest sibling walked before it where that holds none of the
  sibling's own module (siblings share the parent's module and nearly its shift of the centre
  of mass: about a sixth fewer pivots at n_max 64);
* a wrench whose gamma the shortlist's support bounds already prove past :data:`CLIP_GAMMA`
  is not walked: its margin is -1 and it is infeasible whatever gamma is.
"""

from __future__ import annotations

from typing import Any, NamedTuple

import numpy as np

from modquad_gym.core.jit import njit
from modquad_gym.envs.assembly.types import TaskArrays
from modquad_gym.oracle.backends import gamma_capped_from, proved_above
from modquad_gym.oracle.tolerance import BAND, TOL, decide_from_gamma, margin_from_gamma

CLIP_GAMMA = 2.0
"""The exact lookahead's margins are clipped at ``1 - CLIP_GAMMA`` = -1: past it, gamma itself is
not needed."""


class Lineage(NamedTuple):
    """What a child's exact entries start from (each field None: not known).

    Attributes:
        start: the parent's optimal vertex per wrench in the child's columns: (tight columns
            (t, rank - 1), column bounds int8 (t, m)).
        lower: lower bounds (t,) on the child's gammas (the shortlist's support bounds).
        cell: the docked module's grid cell.
        at: its first column in the child's matrix (its others follow).
    """

    start: tuple | None = None
    lower: np.ndarray | None = None
    cell: tuple | None = None
    at: int = -1


def exact_rows(
    ev: Any,
    keys: list,
    task: TaskArrays,
    mass: float,
    memo: dict,
    exact_memo: dict,
    walks: dict | None = None,
    lineages: list | None = None,
) -> list[tuple[float, float]]:
    """(satisfied share, mean margin clipped to [-1, 1]) of the child structures ``keys`` (one
    size, one mass) against ``task`` by the evaluator ``ev``, memoised per task in
    ``exact_memo``.

    The margins are ``1 - gamma`` by the compiled walk (as :func:`~modquad_gym.oracle.margin`,
    without its sign repair within the LP's accuracy of the boundary: a feature, not a
    decision), which stops as soon as it proves gamma > :data:`CLIP_GAMMA` (the margin is then
    -1 whatever gamma is). The share is the one a step to that child would report: read off
    gamma (the tolerance rule, on which every method agrees outside
    :data:`~modquad_gym.oracle.tolerance.BAND`), or, with a ``fault`` or a gamma within the band
    of the threshold, decided through ``ev.evaluate`` (whose ``memo`` the step then hits).

    Each walk's optimal vertex per wrench (tight columns int16 (t, rank - 1), column bounds int8
    (t, m)) goes to ``walks`` (key -> both): the starts of the chosen child's own children.
    ``lineages[i]``: key i's :class:`Lineage` (None: the plain path). Oracle tests are counted
    in ``ev.tests``, the wrenches proved past the clip without a walk not."""
    lines = dict(zip(keys, lineages)) if lineages is not None else {}
    walked = []  # (cell, at, tight columns, bounds) of the children walked so far
    for k in dict.fromkeys(keys):
        if k in exact_memo:
            continue
        own = ev.task_of(task, k)
        W = ev.at_mass(own, mass)[0]
        line = lines.get(k) or Lineage()
        z = ev.oracle.cached(k)  # else from its matrix: supports wait for a docking
        if z is None:  # prepared for its gammas alone (no SVD) where it can be
            z = ev.oracle.gamma_zonotope(ev.matrix_of(k), key=k)
        start = line.start
        if start is not None and start[0].shape != (len(W), max(z.rank - 1, 1)):
            start = None  # another rank (or wrench count): no vertex to start from
        if start is not None and walked and line.cell is not None:
            start = from_sibling(start, line, walked, ev.module.n_rotors)
        gamma, (tights, signs) = gamma_capped_from(z, W, CLIP_GAMMA, start, line.lower)
        if line.cell is not None:
            walked.append((line.cell, line.at, tights, signs))
        if walks is not None:
            walks[k] = (tights.astype(np.int16), signs)
        proved = 0 if line.lower is None else np.count_nonzero(proved_above(line.lower, CLIP_GAMMA))
        ev.tests += len(W) - int(proved)
        decided = memo.get(k)
        if decided is not None:
            n_sat = decided[0]
        elif ev.fault is None and not np.any(np.abs(gamma - (1.0 + TOL)) <= BAND):
            n_sat = int(np.count_nonzero(decide_from_gamma(gamma)))
        else:
            n_sat = ev.evaluate(k, own, mass, memo)[0]
        margins = np.clip(margin_from_gamma(gamma), -1.0, 1.0)
        exact_memo[k] = (n_sat / len(W), float(margins.mean()))
    return [exact_memo[k] for k in keys]


def from_sibling(start: tuple, line: Lineage, walked: list, r: int) -> tuple:
    """``start`` (tight columns, bounds per wrench) with each row's vertex replaced by the
    optimum of the nearest ``walked`` sibling (grid distance of the docked cells; the first
    among equals) where that holds none of the sibling's own ``r`` module columns: the rest
    are the parent's, renumbered to this child's columns (its own module's bounds unknown)."""
    cell = line.cell
    near, a0, T0, S0 = min(walked, key=lambda w: abs(w[0][0] - cell[0]) + abs(w[0][1] - cell[1]))
    if T0.shape != start[0].shape:
        return start
    tights, signs = start[0].copy(), start[1].copy()
    if not _sibling_rows(T0, S0, a0, line.at, r, tights, signs):
        return start
    return tights, signs


@njit(cache=True)
def _sibling_rows(T0, S0, a0, at, r, tights, signs):  # pragma: no cover - compiled
    """Rows of (tights, signs) replaced by the sibling's vertex (T0, S0; its module's columns
    at a0) where that holds none of its own module's columns, renumbered to the child's
    columns (the child's module at ``at``, bounds 0); False when no row was."""
    rows, m = signs.shape
    any_ok = False
    for i in range(rows):
        ok = True
        for q in range(T0.shape[1]):
            ok = ok and T0[i, q] >= 0 and not a0 <= T0[i, q] < a0 + r
        if not ok:
            continue
        any_ok = True
        for q in range(T0.shape[1]):
            parent = T0[i, q] - r * (T0[i, q] >= a0)
            tights[i, q] = parent + r * (parent >= at)
        for j in range(m):  # child column j <- parent column p <- sibling column
            if at <= j < at + r:
                signs[i, j] = 0
            else:
                p = j if j < at else j - r
                signs[i, j] = S0[i, p if p < a0 else p + r]
    return any_ok
