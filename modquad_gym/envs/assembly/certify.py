"""Fast exact feasibility decisions for the env: compiled certificates, the oracle for the rest.

The env decides every step's structure against up to hundreds of task wrenches, and the exact
oracle (:class:`~modquad_gym.oracle.WrenchOracle`, method ``"auto"``) spends most of its time in
vectorised iterations and DAQP calls whose Python overhead dwarfs the arithmetic. Here one
compiled call per structure and task does the env's support test and, for each wrench left, in
the oracle's centred reduced coordinates r (those of :meth:`~modquad_gym.oracle.Zonotope.reduce`):
the off-range rule, the bounding box, the minimum-norm allocation, the directions that separated
earlier wrenches of the structure, then the phase-1 simplex of :mod:`.simplex`, which ends with

* an allocation x: after the correction x - P (G x - r) onto G x = r (P the pseudo-inverse of
  G), ``|x|_inf <= 1 + TOL - BAND`` certifies gamma(r) <= 1 + TOL: feasible; or
* a dual direction y: ``y . r > (1 + TOL + BAND) * sum_j |y . g_j|`` (the zonotope's support in
  direction y) certifies gamma(r) > 1 + TOL: infeasible.

Both tests are evaluated here in float64 from x or y alone, so they are exact whatever the
simplex did, and each keeps a clearance of :data:`~modquad_gym.oracle.BAND` from the threshold,
outside which every method of the oracle agrees. A wrench that no certificate decides (within
BAND of the boundary, within 1 % of the off-range rule, too large, or a simplex stopped by its
pivot limit) goes to the oracle itself: the decisions are the oracle's, row for row.
"""

from __future__ import annotations

from collections.abc import Hashable
from typing import Any

import numpy as np
from numba import njit

from modquad_gym.envs.assembly.simplex import phase_one
from modquad_gym.oracle import BAND, RESIDUAL_TOL, TOL, WrenchOracle

ACCEPT = 1.0 + TOL - BAND
"""An allocation with ``|x|_inf`` at most this certifies a feasible wrench."""
REJECT = 1.0 + TOL + BAND
"""A direction with ``y . r`` above this times the support certifies an infeasible wrench."""
_HUGE = 1e100  # rows of w / f_max beyond this go to the oracle (its reduction avoids overflow)
_OFF = 1.01  # off-range margin: residuals within this factor of the rule go to the oracle
DIRECTIONS = 16
"""Separating directions remembered per structure (tried before the simplex)."""


@njit(cache=True)
def _l1_support(y, G):  # pragma: no cover - compiled
    """sum_j |y . G[:, j]|: the box's support in direction y (a separation's right side)."""
    support = 0.0
    for j in range(G.shape[1]):
        acc = 0.0
        for i in range(G.shape[0]):
            acc += y[i] * G[i, j]
        support += abs(acc)
    return support


@njit(cache=True)
def _verdict(G, P, r, x, y, status):  # pragma: no cover - compiled
    """1 (feasible), 0 (infeasible) or -1 (undecided) for wrench r from the simplex's x or y,
    by the certificates of the module docstring (computed here from x or y alone)."""
    n, m = G.shape
    if status == 1:
        e = np.empty(n)  # the residual G x - r, then x - P e lies on G x = r
        for i in range(n):
            acc = -r[i]
            for j in range(m):
                acc += G[i, j] * x[j]
            e[i] = acc
        for j in range(m):
            acc = x[j]
            for i in range(n):
                acc -= P[j, i] * e[i]
            if abs(acc) > ACCEPT:
                return -1
        return 1
    if status == 0:
        proj = 0.0
        for i in range(n):
            proj += y[i] * r[i]
        if proj > REJECT * _l1_support(y, G):
            return 0
    return -1


@njit(cache=True)
def _decide_row(G, P, axes, r, memory, work):  # pragma: no cover - compiled
    """The verdict (1, 0, -1) of one centred reduced wrench r: the bounding box (supports
    ``axes``), the minimum-norm allocation (accepted as the oracle accepts it, G P = I up to
    round-off far below BAND), the remembered separating directions, then
    :func:`~.simplex.phase_one`; a new separating direction is remembered."""
    dirs, supports, added = memory
    Binv, value, basic, head, alpha, x, y = work
    n, m = G.shape
    for i in range(n):
        if abs(r[i]) > REJECT * axes[i]:  # beyond the bounding box: y = +-e_i separates
            return 0
    inside = True
    for j in range(m):
        acc = 0.0
        for i in range(n):
            acc += P[j, i] * r[i]
        x[j] = acc
        inside &= abs(acc) <= ACCEPT
    if inside:  # the minimum-norm allocation P r (G P = I) lies in the cube
        return 1
    for d in range(min(added[0], len(supports))):
        proj = 0.0
        for i in range(n):
            proj += dirs[d, i] * r[i]
        if proj > REJECT * supports[d]:
            return 0
    status = phase_one(G, r, x, y, Binv, value, basic, head, alpha)
    verdict = _verdict(G, P, r, x, y, status)
    if verdict == 0 and len(supports):  # remember its direction for later rows and calls
        slot = added[0] % len(supports)
        dirs[slot] = y
        supports[slot] = _l1_support(y, G)
        added[0] += 1
    return verdict


@njit(cache=True)
def _workspace(G):  # pragma: no cover - compiled
    """(box supports, work arrays of :func:`_decide_row`) for generators G."""
    n, m = G.shape
    axes = np.zeros(n)
    for i in range(n):
        for j in range(m):
            axes[i] += abs(G[i, j])
    work = (
        np.empty((n, n)),
        np.empty(m + n),
        np.empty(m + n, dtype=np.int64),
        np.empty(n, dtype=np.int64),
        np.empty(n),
        np.empty(m),
        np.zeros(n),
    )
    return axes, work


@njit(cache=True)
def _decide_rows(G, P, R, memory, out):  # pragma: no cover - compiled
    """Verdicts of the rows of R (centred reduced wrenches) into out."""
    axes, work = _workspace(G)
    for k in range(R.shape[0]):
        out[k] = _decide_row(G, P, axes, R[k], memory, work)


@njit(cache=True)
def _reduce_row(w, f_max, Q, c, r):  # pragma: no cover - compiled
    """Centred reduced coordinates r = (w / f_max) Q - c of one wrench (as
    :meth:`~modquad_gym.oracle.Zonotope.reduce`); returns 1 (in range(A)), 0 (certainly off
    range: residual beyond the oracle's RESIDUAL_TOL rule by a factor) or -1 (near that rule,
    or too large for these coordinates: the oracle decides)."""
    n = Q.shape[1]
    norm2 = 0.0
    for j in range(6):
        v = w[j] / f_max
        if abs(v) > _HUGE:
            return -1
        norm2 += v * v
    for i in range(n):
        acc = 0.0
        for j in range(6):
            acc += (w[j] / f_max) * Q[j, i]
        r[i] = acc
    if n < 6:  # range(A) is not all of R^6: the residual of the projection decides first
        resid2 = 0.0
        for j in range(6):
            e = w[j] / f_max
            for i in range(n):
                e -= r[i] * Q[j, i]
            resid2 += e * e
        bound = RESIDUAL_TOL * (1.0 + np.sqrt(norm2))
        if np.sqrt(resid2) > _OFF * bound:
            return 0
        if not np.sqrt(resid2) < bound / _OFF:
            return -1
    for i in range(n):
        r[i] -= c[i]
    return 1


@njit(cache=True)
def _decide_task(W, WD, h, slack, f_max, Q, c, G, P, memory, per_wrench, out, counts):
    """A structure against task wrenches W (t, 6): per_wrench (t,) = max_d (WD - h) (the
    support test of :meth:`~.evaluator.StructureEvaluator.against_plain`), and the verdict
    of each row into out: -2 where the support test rejects it (not tested), else 0 off
    range(A), else that of :func:`_decide_row` on its centred reduced coordinates (-1 where
    the oracle must decide). counts: (tested, feasible, undecided)."""
    axes, work = _workspace(G)
    r = np.empty(G.shape[0])
    counts[:] = 0
    for k in range(W.shape[0]):
        worst = -np.inf
        for d in range(WD.shape[1]):
            gap = WD[k, d] - h[d]
            if gap > worst:
                worst = gap
        per_wrench[k] = worst
        if not worst <= slack:
            out[k] = -2
            continue
        verdict = _reduce_row(W[k], f_max, Q, c, r)
        if verdict == 1:
            verdict = _decide_row(G, P, axes, r, memory, work)
        out[k] = verdict
        counts[0] += 1
        if verdict == 1:
            counts[1] += 1
        elif verdict == -1:
            counts[2] += 1


class FastDecider:
    """The decisions of ``oracle`` (method ``"auto"``), certified by the compiled tests first.

    Attributes:
        fallback: wrenches the oracle itself decided (neither certificate held).
    """

    def __init__(self, oracle: WrenchOracle) -> None:
        self.oracle = oracle
        self.fallback = 0
        self._memory: dict[Hashable, tuple] = {}
        self._counts = np.zeros(3, dtype=np.int64)

    def _prepared(self, A: np.ndarray, key: Hashable) -> tuple[Any, tuple]:
        """(the oracle's zonotope of A, the directions remembered for it)."""
        z = self.oracle.zonotope(A, key)
        memory = self._memory.get(key)
        if memory is None:
            if len(self._memory) >= self.oracle.cache_size:
                self._memory.clear()
            memory = self._memory[key] = (
                np.empty((DIRECTIONS, z.rank)),
                np.empty(DIRECTIONS),
                np.zeros(1, dtype=np.int64),
            )
        return z, memory

    def _settle(
        self, A: np.ndarray, W: np.ndarray, key: Hashable, verdict: np.ndarray
    ) -> np.ndarray:
        """The oracle's answers for the undecided rows (verdict -1), also written into
        verdict."""
        rest = np.flatnonzero(verdict == -1)
        if not len(rest):
            return np.zeros(0, dtype=bool)
        self.fallback += len(rest)
        answers = self.oracle.feasible(A, W[rest], key=key)
        verdict[rest] = answers
        return answers

    def feasible(self, A: np.ndarray, W: np.ndarray, key: Hashable) -> np.ndarray:
        """bool (t,): which finite wrenches W (t, 6) the structure of matrix A (key ``key``)
        can exert; the same answers as ``oracle.feasible(A, W, key=key)``."""
        z, memory = self._prepared(A, key)
        if not z.rank:
            return self.oracle.feasible(A, W, key=key)
        R, off = z.reduce(W)
        verdict = np.empty(len(W), dtype=np.int8)
        _decide_rows(z.G, z.P, np.ascontiguousarray(R), memory, verdict)
        verdict[off] = 0  # off range(A): infeasible (the oracle's first rule)
        self._settle(A, W, key, verdict)
        return verdict == 1

    def against(
        self, A: np.ndarray, key: Hashable, W: np.ndarray, WD: np.ndarray, h: np.ndarray,
        slack: float,
    ) -> tuple[np.ndarray, int, int]:  # fmt: skip
        """(per_wrench, wrenches tested, wrenches satisfied) of a structure against a task, as
        :meth:`~.evaluator.StructureEvaluator.against_plain` computes them."""
        z, memory = self._prepared(A, key)
        if not z.rank:  # no structure has rank 0; any other matrix: the plain path
            per_wrench = np.maximum.reduce(WD - h, axis=1)
            tested = np.flatnonzero(per_wrench <= slack)
            n_sat = int(np.count_nonzero(self.feasible(A, W[tested], key))) if len(tested) else 0
            return per_wrench, len(tested), n_sat
        per_wrench = np.empty(len(W))
        verdict = np.empty(len(W), dtype=np.int8)
        counts = self._counts
        _decide_task(W, WD, h, slack, self.oracle.f_max, z.Q, z.c, z.G, z.P, memory,
                     per_wrench, verdict, counts)  # fmt: skip
        n_sat = int(counts[1])
        if counts[2]:
            n_sat += int(np.count_nonzero(self._settle(A, W, key, verdict)))
        return per_wrench, int(counts[0]), n_sat
