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

import numpy as np
from numba import njit

from ...oracle import BAND, TOL, WrenchOracle

ACCEPT = 1.0 + TOL - BAND
"""An allocation with ``|x|_inf`` at most this certifies a feasible wrench."""
REJECT = 1.0 + TOL + BAND
"""A direction with ``y . r`` above this times the support certifies an infeasible wrench."""
MAX_PIVOTS = 200
"""Simplex iterations per wrench before it is handed to the oracle."""

_EPS = 1e-11  # reduced-cost and residual tolerance (a heuristic: the results are checked)
_PIVOT = 1e-9  # smallest pivot element


@njit(cache=True)
def _phase_one(G, r, x, y, M, Binv, value, basic, head, alpha):  # pragma: no cover - compiled
    """Bounded-variable phase-1 simplex for one wrench: min sum|G x - r| over x in [-1, 1]^m,
    started at the vertex nearest x (the minimum-norm allocation on entry).

    Writes the allocation into x and the final dual row into y; returns 1 (residual zero: x is
    a candidate allocation), 0 (positive residual: y is a candidate separating direction) or -1
    (pivot limit). M, Binv, value, basic, head and alpha are work arrays."""
    n, m = G.shape
    inside = True
    for j in range(m):
        if abs(x[j]) > 1.0:
            inside = False
    if inside:  # the minimum-norm allocation lies in the cube
        return 1
    total = m + n
    for j in range(m):
        value[j] = 1.0 if x[j] > 0.0 else -1.0
        basic[j] = -1
    for i in range(n):
        res = r[i]
        for j in range(m):
            res -= G[i, j] * value[j]
        s = 1.0 if res >= 0.0 else -1.0
        for k in range(n):
            M[i, m + k] = 0.0
            Binv[i, k] = 0.0
        M[i, m + i] = s
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
        # entering variable: the most improving reduced cost (Dantzig)
        q, best, direction = -1, _EPS, 0.0
        for j in range(total):
            if basic[j] >= 0:
                continue
            d = 1.0 if j >= m else 0.0
            for i in range(n):
                d -= y[i] * M[i, j]
            if j < m:
                if value[j] < 0.0 and -d > best:  # at its lower bound: increase
                    q, best, direction = j, -d, 1.0
                elif value[j] > 0.0 and d > best:  # at its upper bound: decrease
                    q, best, direction = j, d, -1.0
            elif -d > best:  # an artificial that left the basis (at 0) may only increase
                q, best, direction = j, -d, 1.0
        if q < 0:
            for j in range(m):
                x[j] = value[j]
            return 0
        for i in range(n):
            acc = 0.0
            for k in range(n):
                acc += Binv[i, k] * M[k, q]
            alpha[i] = acc
        theta = 2.0 if q < m else np.inf  # the entering variable's own range
        leave, at = -1, 0.0
        for i in range(n):
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
        if not np.isfinite(theta):
            return -1
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
        pivot = alpha[leave]
        for k in range(n):
            Binv[leave, k] /= pivot
        for i in range(n):
            if i != leave and alpha[i] != 0.0:
                f = alpha[i]
                for k in range(n):
                    Binv[i, k] -= f * Binv[leave, k]
    return -1


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
def _decide_rows(G, P, R, out):  # pragma: no cover - compiled
    """Verdicts (1, 0, -1) of the rows of R into out: the bounding box first (its supports
    sum_j |G_ij|), then the minimum-norm allocation, then :func:`_phase_one`."""
    t, n = R.shape
    m = G.shape[1]
    axes = np.zeros(n)
    for i in range(n):
        for j in range(m):
            axes[i] += abs(G[i, j])
    M = np.zeros((n, m + n))
    M[:, :m] = G
    Binv = np.empty((n, n))
    value = np.empty(m + n)
    basic = np.empty(m + n, dtype=np.int64)
    head = np.empty(n, dtype=np.int64)
    alpha = np.empty(n)
    x = np.empty(m)
    y = np.zeros(n)
    for k in range(t):
        r = R[k]
        outside = False
        for i in range(n):
            if abs(r[i]) > REJECT * axes[i]:  # beyond the bounding box: y = +-e_i separates
                outside = True
        if outside:
            out[k] = 0
            continue
        for j in range(m):
            acc = 0.0
            for i in range(n):
                acc += P[j, i] * r[i]
            x[j] = acc
        status = _phase_one(G, r, x, y, M, Binv, value, basic, head, alpha)
        out[k] = _verdict(G, P, r, x, y, status)


def certify(G: np.ndarray, P: np.ndarray, R: np.ndarray) -> np.ndarray:
    """int8 verdicts (t,) for centred reduced wrenches R (t, n) of the zonotope with
    generators G (n, m) and pseudo-inverse P (m, n): 1 where gamma <= 1 + TOL is certified,
    0 where gamma > 1 + TOL is, -1 where neither is (module docstring)."""
    out = np.empty(len(R), dtype=np.int8)
    _decide_rows(G, P, np.ascontiguousarray(R, dtype=float), out)
    return out


class FastDecider:
    """The decisions of ``oracle`` (method ``"auto"``), certified by :func:`certify` first.

    Attributes:
        fallback: wrenches the oracle itself decided (neither certificate held).
    """

    def __init__(self, oracle: WrenchOracle) -> None:
        self.oracle = oracle
        self.fallback = 0

    def feasible(self, A: np.ndarray, W: np.ndarray, key: Hashable) -> np.ndarray:
        """bool (t,): which wrenches W (t, 6) the structure of matrix A (key ``key``) can exert;
        the same answers as ``oracle.feasible(A, W, key=key)``."""
        z = self.oracle.zonotope(A, key)
        if not z.rank:
            return self.oracle.feasible(A, W, key=key)
        R, off = z.reduce(W)
        verdict = certify(z.G, z.P, R)
        out = verdict == 1
        if off.any():  # off range(A): infeasible (the oracle's first rule)
            out[off] = False
            verdict[off] = 0
        rest = np.flatnonzero(verdict < 0)
        if len(rest):
            self.fallback += len(rest)
            out[rest] = self.oracle.feasible(A, W[rest], key=key)
        return out
