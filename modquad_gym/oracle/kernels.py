"""The compiled certificates behind the ``"compiled"`` method (and ``"auto"``'s decisions).

One compiled call per structure and batch of wrenches does, per wrench in the oracle's centred
reduced coordinates r (those of :meth:`~modquad_gym.oracle.Zonotope.reduce`): the off-range rule
(when called with raw wrenches), the bounding box, the minimum-norm allocation, the directions
where earlier wrenches of the structure were decided, then the dual simplex on the support
function of :mod:`.walk` (a few pivots of O(m) each, at any m), which ends with

* an allocation x: after the correction x - P (G x - r) onto G x = r (P the pseudo-inverse of
  G), ``|x|_inf <= ACCEPT`` certifies gamma(r) <= 1 + TOL: feasible; or
* a dual direction y: ``y . r > REJECT * sum_j |y . g_j|`` (the zonotope's support in direction
  y) certifies gamma(r) > 1 + TOL: infeasible.

ACCEPT and REJECT are the tolerance rule's (:mod:`~modquad_gym.oracle.tolerance`). Both tests are
evaluated here in float64 from x or y alone, so they are exact whatever the walk did. A
wrench that no certificate decides (within GUARD of the threshold, within 1 % of the off-range
rule, too large, or a walk stopped by its pivot limit) is marked undecided (-1) for the exact
LP (:mod:`.compiled`). :func:`gamma_rows` runs the walk to the optimum for margins, its gamma
taken only where the allocation's and the direction's bounds agree (:data:`GAP`).
"""

from __future__ import annotations

import math

import numpy as np

from modquad_gym.core.jit import njit
from modquad_gym.oracle.tolerance import ACCEPT, REJECT, RESIDUAL_TOL
from modquad_gym.oracle.walk import vertex_walk, walk_from, walk_workspace

_HUGE = 1e100  # rows of w / f_max beyond this are left undecided (reduce() avoids overflow)
_OFF = 1.01  # off-range margin: residuals within this factor of the rule are left undecided

GAP = 1e-9
"""Largest relative gap between the two bounds on gamma that a walk's optimum leaves (its
corrected allocation's |x|_inf above, r . y / h(y) below) for its gamma to be taken: the walk's
documented accuracy. At a true optimum the gap is round-off (below 1e-12 on the stock
structures); a wider one means the walk's basis lost accuracy, and the exact LP decides."""

WALKED_AS_IS = (0.5, 2.0**64)
"""Largest singular values of G that the kernels walk as they are: the walk's thresholds are
calibrated for G of order one (every physical A has one of at least 1/2: unit thrust
directions); a zonotope outside is walked in coordinates scaled by a power of two
(:func:`walk_view`)."""


def walk_view(z) -> tuple[np.ndarray, np.ndarray, float]:
    """(G k, P / k, k): the generators and pseudo-inverse the kernels walk for zonotope z, k a
    power of two (scaling is exact) that brings G's largest singular value ``z.scale`` into
    [1/2, 1) when it lies outside :data:`WALKED_AS_IS`, else 1 (z's own arrays). The kernels
    then take the rows ``R k`` (gamma and every decision are the same in these coordinates;
    a direction y becomes y / k)."""
    low, high = WALKED_AS_IS
    if not z.scale or low <= z.scale < high:
        return z.G, z.P, 1.0
    k = math.ldexp(1.0, max(-1000, min(1000, -math.frexp(z.scale)[1])))
    return np.ascontiguousarray(z.G * k), np.ascontiguousarray(z.P / k), k


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
def _corrected_max(G, P, r, x):  # pragma: no cover - compiled
    """|x - P (G x - r)|_inf: the allocation x corrected onto G x = r (up to round-off), the
    number the accept certificate and gamma read."""
    n, m = G.shape
    e = np.empty(n)
    for i in range(n):
        acc = -r[i]
        for j in range(m):
            acc += G[i, j] * x[j]
        e[i] = acc
    worst = 0.0
    for j in range(m):
        acc = x[j]
        for i in range(n):
            acc -= P[j, i] * e[i]
        worst = max(worst, abs(acc))
    return worst


@njit(cache=True)
def _verdict(G, P, r, x, y, status):  # pragma: no cover - compiled
    """1 (feasible), 0 (infeasible) or -1 (undecided) for wrench r from the walk's x or y, by
    the certificates of the module docstring (computed here from x or y alone)."""
    n = G.shape[0]
    if (status == 1 or status == 2) and _corrected_max(G, P, r, x) <= ACCEPT:
        return 1
    if status == 0 or status == 2:
        proj = 0.0
        for i in range(n):
            proj += y[i] * r[i]
        if proj > REJECT * _l1_support(y, G):
            return 0
    return -1


@njit(cache=True)
def _separated(r, memory):  # pragma: no cover - compiled
    """Whether a remembered direction separates r (its support is remembered with it)."""
    dirs, supports, added = memory
    for d in range(min(added[0], len(supports))):
        proj = 0.0
        for i in range(len(r)):
            proj += dirs[d, i] * r[i]
        if proj > REJECT * supports[d]:
            return True
    return False


@njit(cache=True)
def _decide_row(G, P, prep, r, memory, work):  # pragma: no cover - compiled
    """The verdict (1, 0, -1) of one centred reduced wrench r: the bounding box, the
    minimum-norm allocation (accepted by the rule's ACCEPT, G P = I up to round-off far below
    GUARD), the remembered directions, then :func:`~.walk.vertex_walk` from the dual-metric
    direction r / sigma^2; the vertex where the walk decided is remembered for later rows and
    calls."""
    PT, norms, axes, dual = prep
    dirs, supports, added = memory
    walk, x, y = work
    n, m = G.shape
    for i in range(n):
        if abs(r[i]) > REJECT * axes[i]:  # beyond the bounding box: y = +-e_i separates
            return 0
    for j in range(m):
        x[j] = 0.0
    for i in range(n):  # the minimum-norm allocation P r (G P = I), row-wise
        for j in range(m):
            x[j] += PT[i, j] * r[i]
    inside = True
    for j in range(m):
        inside &= abs(x[j]) <= ACCEPT
    if inside:  # it lies in the cube
        return 1
    if _separated(r, memory):
        return 0
    ry, l1 = 0.0, 0.0  # the dual-metric direction y = r / sigma^2 has h(y) = |P r|_1
    for i in range(n):
        y[i] = r[i] * dual[i]
        ry += r[i] * y[i]
    for j in range(m):
        l1 += abs(x[j])
    if ry > REJECT * l1:
        return 0
    status = vertex_walk(G, norms, r, y, x, ACCEPT, REJECT, walk)
    verdict = _verdict(G, P, r, x, y, status)
    if verdict >= 0 and len(supports):
        slot = added[0] % len(supports)
        dirs[slot] = y
        supports[slot] = _l1_support(y, G)
        added[0] += 1
    return verdict


@njit(cache=True)
def _workspace(G):  # pragma: no cover - compiled
    """(the walk's work arrays, x, y) for generators G."""
    n, m = G.shape
    return walk_workspace(m, n), np.empty(m), np.empty(n)


@njit(cache=True)
def prepare(G, P):  # pragma: no cover - compiled
    """What the kernels keep per zonotope: (P^T contiguous, the columns' 1-norms, the bounding
    box (supports of the coordinate axes), the dual metric 1 / sigma^2 (G G^T is diagonal))."""
    n, m = G.shape
    PT = np.ascontiguousarray(P.T)
    norms = np.zeros(m)
    axes = np.zeros(n)
    dual = np.zeros(n)
    for j in range(m):
        for i in range(n):
            norms[j] += abs(G[i, j])
            axes[i] += abs(G[i, j])
            dual[i] += G[i, j] * G[i, j]
    for i in range(n):
        dual[i] = 1.0 / dual[i]
    return PT, norms, axes, dual


@njit(cache=True)
def decide_rows(G, P, prep, R, memory, out):  # pragma: no cover - compiled
    """Verdicts of the rows of R (centred reduced wrenches) into out."""
    work = _workspace(G)
    for k in range(R.shape[0]):
        out[k] = _decide_row(G, P, prep, R[k], memory, work)


@njit(cache=True)
def gamma_rows(G, P, prep, R, cap, out, dirs):  # pragma: no cover - compiled
    """gamma of the rows of R (centred reduced wrenches) into out: the walk to the optimum from
    the dual-metric direction, measured by the allocation corrected onto G x = r (never below
    the true gamma); nan where the walk gives up. A row whose gamma is certified above ``cap``
    (the bounding box, or a direction y of the walk with r . y > cap h(y)) gets that certified
    lower bound instead (> cap; the walk stops there): ``cap = inf`` computes every gamma.
    With rows in ``dirs`` (else shape (0, n)), each row's last direction y goes there."""
    starts = np.full((R.shape[0], max(G.shape[0] - 1, 1)), -1, dtype=np.int64)
    signs = np.zeros((R.shape[0], G.shape[1]), dtype=np.int8)
    out[:] = np.nan
    gamma_rows_from(G, P, prep, R, cap, out, dirs, starts, signs)


@njit(cache=True)
def _lower_bound(G, r, y):  # pragma: no cover - compiled
    """r . y / h(y), h the zonotope's full support sum_j |g_j . y| (every column, the walk's
    tight ones too): a lower bound on gamma(r) from any direction y (weak duality); nan where
    h(y) = 0."""
    ry = 0.0
    for i in range(len(r)):
        ry += r[i] * y[i]
    support = _l1_support(y, G)
    return ry / support if support > 0.0 else np.nan


@njit(cache=True)
def _certified_walk(G, P, norms, dual, r, y, x, cap, walk, start, sign):  # pragma: no cover
    """(gamma, status) of one row by :func:`~.walk.walk_from` (y: the dual-metric direction),
    read only from what the walk's x and y prove: at the optimum (status 2) the corrected
    allocation's |x|_inf (>= gamma) where the lower bound of y (<= gamma,
    :func:`_lower_bound`) agrees with it within :data:`GAP`; past ``cap`` (status 0) that lower
    bound where it exceeds ``cap``. Otherwise the walk is repeated once from y when it started
    at a given vertex (from y = r * dual, as the caller set it), and nan (status -1) when that
    fails too: the caller's exact LP decides."""
    status = walk_from(G, norms, r, y, x, 0.0, cap, walk, start, sign)
    for attempt in range(2):
        if status == 2:
            upper = _corrected_max(G, P, r, x)
            if abs(upper - _lower_bound(G, r, y)) <= GAP * upper:
                return upper, 2
        elif status == 0:
            lower = _lower_bound(G, r, y)
            if lower > cap:
                return lower, 0
        if attempt == 1 or start.min() < 0:
            break
        for i in range(len(r)):  # a walk that started at a given vertex: once more from y
            y[i] = r[i] * dual[i]
        status = vertex_walk(G, norms, r, y, x, 0.0, cap, walk)
    return np.nan, -1


@njit(cache=True)
def gamma_rows_from(G, P, prep, R, cap, out, dirs, starts, signs):  # pragma: no cover
    """:func:`gamma_rows` with row k's walk started at the vertex of the tight columns
    ``starts[k]`` (-1: from the dual-metric direction) with the column bounds ``signs[k]``
    (see :func:`~.walk.walk_from`); each row's optimal vertex replaces them: its tight columns
    and every other column's bound (-1 and 0 where the walk stopped elsewhere: a certificate
    above ``cap``, the box, or no answer). Only rows whose ``out`` is nan on entry are walked:
    the others keep their value (the caller's: say a bound it proved), with no vertex. Every
    walked gamma is certified by both of its bounds (:func:`_certified_walk`), else nan."""
    walk, x, y = _workspace(G)
    tight, bound, T = walk[0], walk[1], walk[12]
    _, norms, axes, dual = prep
    n, m = G.shape
    for k in range(R.shape[0]):
        if not np.isnan(out[k]):  # known to the caller: not walked
            starts[k, :] = -1
            signs[k, :] = 0
            continue
        r = R[k]
        norm = 0.0
        box = 0.0
        for i in range(n):
            norm += abs(r[i])
            y[i] = r[i] * dual[i]
            box = max(box, abs(r[i]) / axes[i])
        status = -2
        if norm == 0.0:
            out[k] = 0.0
        elif box > cap:  # beyond the box scaled by cap: y = +-e_i proves gamma >= box
            out[k] = box
        else:
            out[k], status = _certified_walk(
                G, P, norms, dual, r, y, x, cap, walk, starts[k], signs[k]
            )
        if dirs.shape[0]:
            dirs[k] = y
        for q in range(starts.shape[1]):
            starts[k, q] = T[q] if status == 2 and q < n - 1 else -1
        for j in range(m):
            signs[k, j] = 0 if status != 2 or tight[j] else (1 if bound[j] > 0 else -1)


@njit(cache=True)
def _reduce_row(w, f_max, one, Q, c, r):  # pragma: no cover - compiled
    """Centred reduced coordinates r = (w / f_max) Q - c of one wrench (as
    :meth:`~modquad_gym.oracle.Zonotope.reduce`); returns 1 (in range(A)), 0 (certainly off
    range: residual beyond the oracle's RESIDUAL_TOL rule by a factor) or -1 (near that rule,
    or too large for these coordinates: the oracle decides). ``one`` is the rule's f_max in
    these units (1; k in the coordinates of :func:`walk_view`, where f_max is divided by k)."""
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
        bound = RESIDUAL_TOL * (one + np.sqrt(norm2))
        if np.sqrt(resid2) > _OFF * bound:
            return 0
        if not np.sqrt(resid2) < bound / _OFF:
            return -1
    for i in range(n):
        r[i] -= c[i]
    return 1


@njit(cache=True)  # pragma: no cover - compiled
def decide_screened(W, WD, h, slack, f_max, one, Q, c, G, P, prep, memory, per_wrench, out, counts):
    """A structure against wrenches W (t, 6) after a support screen: per_wrench (t,) =
    max_d (WD - h) (see :meth:`~modquad_gym.oracle.WrenchOracle.screened`), and the verdict of
    each row into out: -2 where the screen rejects it (not tested), else 0 off range(A), else
    that of :func:`_decide_row` on its centred reduced coordinates (-1: undecided).
    counts: (tested, feasible, undecided)."""
    work = _workspace(G)
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
        verdict = _reduce_row(W[k], f_max, one, Q, c, r)
        if verdict == 1:
            verdict = _decide_row(G, P, prep, r, memory, work)
        out[k] = verdict
        counts[0] += 1
        if verdict == 1:
            counts[1] += 1
        elif verdict == -1:
            counts[2] += 1
