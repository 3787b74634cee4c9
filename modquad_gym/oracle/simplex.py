"""A small compiled phase-1 simplex: an allocation x in the cube [-1, 1]^m with G x = r, or a
dual direction showing there is none.

Bounded-variable primal simplex on ``min sum_i |G x - r|_i`` with one artificial variable per
row, started at the vertex nearest the minimum-norm allocation, Dantzig's pricing, an explicit
basis inverse (G has at most 6 rows). Its answers are *candidates*: :mod:`.kernels` checks
each one in float64 before it decides anything, so round-off or a pivot limit here can only
leave a wrench to the exact LP, never change a decision.
"""

from __future__ import annotations

from numba import njit

MAX_PIVOTS = 200
"""Simplex iterations per wrench before it gives up (-1)."""

_EPS = 1e-11  # reduced-cost and residual tolerance
_PIVOT = 1e-9  # smallest pivot element


@njit(cache=True)
def phase_one(G, r, x, y, Binv, value, basic, head, alpha):  # pragma: no cover - compiled
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
