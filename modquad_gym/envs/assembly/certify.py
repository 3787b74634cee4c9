"""Fast exact feasibility decisions for the env: compiled certificates, the oracle for the rest.

The env decides every step's structure against up to hundreds of task wrenches, and the exact
oracle (:class:`~modquad_gym.oracle.WrenchOracle`, method ``"auto"``) spends most of its time in
vectorised iterations and DAQP calls whose Python overhead dwarfs the arithmetic. Here each
centred reduced wrench r (the oracle's own :meth:`~modquad_gym.oracle.Zonotope.reduce`) goes
through a small compiled phase-1 simplex: find x in the cube [-1, 1]^m with G x = r, minimising
the L1 residual. It ends with either

* an allocation x: after the correction x - P (G x - r) onto G x = r (P the pseudo-inverse of
  G), ``|x|_inf <= 1 + TOL - BAND`` certifies gamma(r) <= 1 + TOL: feasible; or
* a dual direction y: ``y . r > (1 + TOL + BAND) * sum_j |y . g_j|`` (the zonotope's support in
  direction y) certifies gamma(r) > 1 + TOL: infeasible.

Both tests are evaluated here in float64 from x or y alone, so they are exact whatever the
simplex did, and each keeps a clearance of :data:`~modquad_gym.oracle.BAND` from the threshold,
outside which every method of the oracle agrees. A wrench that neither certificate decides
(within BAND of the boundary, or a simplex stopped by its pivot limit) goes to the oracle itself:
the decisions are the oracle's, row for row. Off-range wrenches and wrenches outside the
zonotope's bounding box are rejected first, as the oracle does.
"""

from __future__ import annotations

from collections.abc import Hashable
from typing import Any

import numpy as np
from numba import njit

from ...oracle import BAND, RESIDUAL_TOL, TOL, WrenchOracle

ACCEPT = 1.0 + TOL - BAND
"""An allocation with ``|x|_inf`` at most this certifies a feasible wrench."""
REJECT = 1.0 + TOL + BAND
"""A direction with ``y . r`` above this times the support certifies an infeasible wrench."""
MAX_PIVOTS = 200
"""Simplex iterations per wrench before it is handed to the oracle."""

_EPS = 1e-11  # reduced-cost and residual tolerance (a heuristic: the results are checked)
_PIVOT = 1e-9  # smallest pivot element
_HUGE = 1e100  # rows of w / f_max beyond this go to the oracle (its reduction avoids overflow)
_OFF = 1.01  # off-range margin: residuals within this factor of the rule go to the oracle
DIRECTIONS = 16
"""Separating directions remembered per structure (tried before the simplex)."""


@njit(cache=True)
def _phase_one(G, r, x, y, Binv, value, basic, head, alpha):  # pragma: no cover - compiled
    """Bounded-variable phase-1 simplex for one wrench: min sum|G x - r| over x in [-1, 1]^m,
    started at the vertex nearest x (the minimum-norm allocation on entry).

    Writes the allocation into x and the final dual row into y; returns 1 (residual zero: x is
    a candidate allocation), 0 (positive residual: y is a candidate separating direction) or -1
    (pivot limit). Binv, value, basic, head and alpha are work arrays."""
    n, m = G.shape
    inside = True
    for j in range(m):
        if abs(x[j]) > 1.0:
            inside = False
    if inside:  # the minimum-norm allocation lies in the cube
        return 1
    for j in range(m):
        value[j] = 1.0 if x[j] > 0.0 else -1.0
        basic[j] = -1
    for i in range(n):
        res = r[i]
        for j in range(m):
            res -= G[i, j] * value[j]
        s = 1.0 if res >= 0.0 else -1.0
        for k in range(n):
            Binv[i, k] = 0.0
        Binv[i, i] = s
        head[i] = m + i
        basic[m + i] = i
        value[m + i] = abs(res)
    for _ in range(MAX_PIVOTS):
        objective = 0.0
        for k in range(n):
            y[k] = 0.0
        for i in range(n):
            if head[i] >= m:  # artificials cost 1, allocations 0
                objective += value[head[i]]
                for k in range(n):
                    y[k] += Binv[i, k]
        if objective <= _EPS:
            for j in range(m):
                x[j] = value[j]
            return 1
        q, direction = _entering(G, y, value, basic)
        if q < 0:
            for j in range(m):
                x[j] = value[j]
            return 0
        for i in range(n):
            acc = 0.0
            for k in range(n):
                acc += Binv[i, k] * G[k, q]
            alpha[i] = acc
        theta, leave, at = _ratio_test(alpha, direction, head, value, m)
        for i in range(n):
            value[head[i]] -= direction * theta * alpha[i]
        value[q] += direction * theta
        if leave < 0:  # a bound flip of the entering variable
            continue
        out = head[leave]
        value[out] = at
        basic[out] = -1
        head[leave] = q
        basic[q] = leave
        _pivot(Binv, alpha, leave)
    return -1


@njit(cache=True)
def _entering(G, y, value, basic):  # pragma: no cover - compiled
    """(q, direction): the nonbasic allocation with the most improving reduced cost -y . g_q
    (Dantzig's rule), +1 to raise it from its lower bound, -1 to lower it from its upper one;
    q = -1 when none improves (optimal). Artificials that left the basis never return."""
    n, m = G.shape
    q, best, direction = -1, _EPS, 0.0
    for j in range(m):
        if basic[j] >= 0:
            continue
        d = 0.0
        for i in range(n):
            d -= y[i] * G[i, j]
        if value[j] < 0.0 and -d > best:
            q, best, direction = j, -d, 1.0
        elif value[j] > 0.0 and d > best:
            q, best, direction = j, d, -1.0
    return q, direction


@njit(cache=True)
def _ratio_test(alpha, direction, head, value, m):  # pragma: no cover - compiled
    """(step, leaving row or -1 for a bound flip, the bound it leaves at): the longest step of
    the entering variable that keeps every basic variable within its bounds."""
    theta = 2.0  # the entering variable's own range [-1, 1]
    leave, at = -1, 0.0
    for i in range(len(alpha)):
        rate = -direction * alpha[i]  # d(value of basic i) / d(theta)
        j = head[i]
        if rate < -_PIVOT:
            low = -1.0 if j < m else 0.0
            t = (value[j] - low) / -rate
            if t < theta:
                theta, leave, at = t, i, low
        elif rate > _PIVOT and j < m:
            t = (1.0 - value[j]) / rate
            if t < theta:
                theta, leave, at = t, i, 1.0
    return theta, leave, at


@njit(cache=True)
def _pivot(Binv, alpha, leave):  # pragma: no cover - compiled
    """Update the basis inverse in place when row ``leave`` takes the column with
    B^-1-coordinates alpha."""
    n = len(alpha)
    pivot = alpha[leave]
    for k in range(n):
        Binv[leave, k] /= pivot
    for i in range(n):
        if i != leave and alpha[i] != 0.0:
            f = alpha[i]
            for k in range(n):
                Binv[i, k] -= f * Binv[leave, k]


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
        support = 0.0
        for j in range(m):
            acc = 0.0
            for i in range(n):
                acc += y[i] * G[i, j]
            support += abs(acc)
        if proj > REJECT * support:
            return 0
    return -1


@njit(cache=True)
def _decide_row(G, P, axes, r, memory, work):  # pragma: no cover - compiled
    """The verdict (1, 0, -1) of one centred reduced wrench r: the bounding box (supports
    ``axes``), the minimum-norm allocation (accepted as the oracle accepts it, G P = I up to
    round-off far below BAND), the remembered separating directions, then
    :func:`_phase_one`; a new separating direction is remembered."""
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
    status = _phase_one(G, r, x, y, Binv, value, basic, head, alpha)
    verdict = _verdict(G, P, r, x, y, status)
    if verdict == 0 and len(supports):  # remember its direction for later rows and calls
        slot = added[0] % len(supports)
        support = 0.0
        for j in range(m):
            acc = 0.0
            for i in range(n):
                acc += y[i] * G[i, j]
            support += abs(acc)
        dirs[slot] = y
        supports[slot] = support
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
