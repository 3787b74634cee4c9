"""A compiled dual simplex on the zonotope's support function: gamma(r) in a few pivots at any m.

LP duality gives gamma(r) = max_y (r . y) / h(y), with h(y) = sum_j |g_j . y| the support of the
centred zonotope, so ``1 / gamma = min { h(y) : r . y = 1 }``: a least-absolute-deviations
problem in rank (<= 6) unknowns with m terms, whose LP dual is ``max mu s.t. G x = mu r,
|x| <= 1`` (mu = 1 / gamma). This module walks its vertices, the y with r . y = 1 and
g_j . y = 0 for a tight set T of rank - 1 independent columns, as a bounded dual simplex with
the long-step ratio test: each pivot releases the tight column whose x is most out of bounds and
moves, by an exact line search over the breakpoints of h (any number of sign changes at once),
to the next vertex; so the pivots grow with the rank, hardly with m. Every column off T has a
bound b_j = sign(g_j . y) (kept through a degenerate pivot while g_j . y = 0: the lattice's
facets hold many columns). At a vertex, with s = sum_j b_j g_j off T and v_k = s . d_k (d_k the
edge that releases the k-th tight column):

* ``y`` is a separating direction when ``r . y > REJECT h(y)`` (gamma > 1 + TOL);
* ``x_j = b_j / h(y)`` off T and ``x_k = -v_k / h(y)`` on T solve G x = r, with
  ``|x|_inf = max(1, |v|_inf) / h(y)``: an allocation, which accepts when at most ACCEPT;
* ``|v|_inf <= 1`` is optimality (to round-off, 1e-13): both bounds meet at gamma = 1 / h(y).

The walk starts from a direction (the caller's: the dual-metric direction of the minimum-norm
allocation), reaching a first vertex by exact line searches along the projected gradient of h.
Its answers are *candidates*: :mod:`.kernels` checks each one in float64, so round-off or the
pivot limit here can only leave a wrench to the exact LP, never change a decision (nor a gamma:
one is taken only where the bounds of x and y agree, :data:`~.kernels.GAP`). A column along the
edge to working accuracy never enters the tight set (its basis would be singular).
"""

from __future__ import annotations

import numpy as np

from modquad_gym.core.jit import njit
from modquad_gym.oracle.basis import invert, replace_row

MAX_PIVOTS = 64
"""Pivots per wrench before the walk gives up (-1)."""

_TINY = 1e-13  # relative size below which a projected gradient or a pivot counts as zero
_ZERO = 1e-12  # relative size of g_j . y below which column j lies on y's hyperplane
_PIVOT = 1e-9  # relative size of g_j . d below which column j cannot enter along d
_PERTURB = 1e-30  # the perturbed distance to a hyperplane that y lies on (anti-cycling)


@njit(cache=True)
def _along(G, y, out):  # pragma: no cover - compiled
    """out_j = g_j . y for every column (row-wise axpys over G (rank, m): vectorised)."""
    n, m = G.shape
    for j in range(m):
        out[j] = 0.0
    for i in range(n):
        yi = y[i]
        for j in range(m):
            out[j] += G[i, j] * yi


@njit(cache=True, fastmath=True)
def _combine(G, w, out):  # pragma: no cover - compiled
    """out = G w (sums reordered for speed: the walk's candidates are checked in float64)."""
    n, m = G.shape
    for i in range(n):
        acc = 0.0
        for j in range(m):
            acc += G[i, j] * w[j]
        out[i] = acc


@njit(cache=True)
def _pass(G, norms, y, tight, bound, a, s, b):  # pragma: no cover - compiled
    """a_j = g_j . y off the tight set (0 on it, and where it is round-off: below 1e-12 of
    |g_j|_1 |y|_inf), bound_j = sign(a_j) where a_j != 0, s = sum of bound_j g_j off the
    tight set (b: the bounds with 0 on it); returns h(y) (with the round-off terms: never below
    the true support)."""
    m = G.shape[1]
    ymax = 0.0
    for i in range(len(y)):
        ymax = max(ymax, abs(y[i]))
    _along(G, y, a)
    h = 0.0
    for j in range(m):
        if tight[j]:
            a[j] = 0.0
            b[j] = 0.0
            continue
        acc = a[j]
        h += abs(acc)
        if abs(acc) <= _ZERO * norms[j] * ymax:
            a[j] = 0.0
        else:
            bound[j] = 1.0 if acc > 0.0 else -1.0
        b[j] = bound[j]
    _combine(G, b, s)
    return h


@njit(cache=True)
def _line_search(G, norms, tight, bound, a, d, slope, c, alpha, order):  # pragma: no cover
    """The long-step ratio test along d from a slope < 0 of h: the column whose breakpoint turns
    the slope >= 0 (it enters the tight set) and the step; the bounds of the columns passed on
    the way are flipped. (-1, 0) when the slope never turns (round-off). A column with
    |g_j . d| within _PIVOT of |g_j|_1 |d|_inf lies along d to working accuracy: it never
    enters (its basis would be singular to working accuracy, its inverse noise)."""
    m = G.shape[1]
    dmax = 0.0
    for i in range(len(d)):
        dmax = max(dmax, abs(d[i]))
    _along(G, d, c)
    k = 0
    for j in range(m):
        acc = c[j]
        if tight[j] or abs(acc) <= _PIVOT * norms[j] * dmax:
            continue
        if a[j] == 0.0:  # leaves its bound at once; ties broken by a fixed perturbation
            ahead = (acc > 0.0) != (bound[j] > 0.0)
            step = _PERTURB * (1.0 + ((j * 0.6180339887498949) % 1.0)) / abs(acc)
        else:
            ahead = (a[j] > 0.0) != (acc > 0.0)  # crosses its hyperplane ahead
            step = -a[j] / acc
        if ahead:
            alpha[k] = step
            order[k] = j
            k += 1
    t = _first_crossing(alpha, order, c, k, -slope)
    if t < 0:
        return -1, 0.0
    for q in range(t):  # every breakpoint before t was passed (partitioned below t)
        bound[order[q]] = -bound[order[q]]
    return order[t], alpha[t]


@njit(cache=True)
def _first_crossing(alpha, order, c, k, need):  # pragma: no cover - compiled
    """The position t of the breakpoint at which the weights 2 |c_j| (j = order[t]), taken in
    increasing alpha, first reach ``need``, after permuting the first k breakpoints (alpha and
    order together) so that those before t are the ones passed (-1 when they never reach it).
    A weighted quickselect: expected O(k)."""
    lo, hi = 0, k
    while lo < hi:
        mid = (lo + hi) // 2  # median of three as the pivot
        p = alpha[mid]
        p = max(min(alpha[lo], p), min(max(alpha[lo], p), alpha[hi - 1]))
        lt, i, gt = lo, lo, hi  # three-way partition of [lo, hi): < p, == p, > p
        below = 0.0
        while i < gt:
            if alpha[i] < p:
                below += 2.0 * abs(c[order[i]])
                alpha[i], alpha[lt] = alpha[lt], alpha[i]
                order[i], order[lt] = order[lt], order[i]
                lt += 1
                i += 1
            elif alpha[i] > p:
                gt -= 1
                alpha[i], alpha[gt] = alpha[gt], alpha[i]
                order[i], order[gt] = order[gt], order[i]
            else:
                i += 1
        if below >= need:
            hi = lt
            continue
        need -= below
        for t in range(lt, gt):
            need -= 2.0 * abs(c[order[t]])
            if need <= 0.0:
                return t
        lo = gt
    return -1


@njit(cache=True)
def _project_off(basis, rows, d, n):  # pragma: no cover - compiled
    """d minus its components along the first ``rows`` orthonormal rows of basis; |d|^2."""
    for q in range(rows):
        dot = 0.0
        for i in range(n):
            dot += basis[q, i] * d[i]
        for i in range(n):
            d[i] -= dot * basis[q, i]
    norm2 = 0.0
    for i in range(n):
        norm2 += d[i] * d[i]
    return norm2


@njit(cache=True)
def _crash(G, norms, r, y, T, reject, work):  # pragma: no cover - compiled
    """From y (r . y = 1) to a vertex: rank - 1 exact line searches along the projected negative
    gradient of h (never increasing h); T receives the tight columns. Returns 1 at the vertex,
    0 as soon as y separates (1 > reject h(y)), -1 when it gets stuck (degenerate data: the
    caller gives up)."""
    tight, bound, _, _, basis, a, s, d, c, alpha, order, _, _ = work
    n, m = G.shape
    for j in range(m):
        tight[j] = False
    norm = 0.0
    for i in range(n):
        norm += r[i] * r[i]
    for i in range(n):
        basis[0, i] = r[i] / np.sqrt(norm)
    for k in range(n - 1):
        if reject * _pass(G, norms, y, tight, bound, a, s, c) < 1.0:
            return 0
        for i in range(n):
            d[i] = -s[i]
        slope = -_project_off(basis, k + 1, d, n)
        if slope >= -_TINY:  # flat: to the nearest hyperplane along the first axis left free
            slope = 0.0
            for trial in range(n):
                for i in range(n):
                    d[i] = 1.0 if i == trial else 0.0
                if _project_off(basis, k + 1, d, n) > _TINY:
                    slope = -1e-300
                    break
        if slope == 0.0:
            return -1
        j, step = _line_search(G, norms, tight, bound, a, d, slope, c, alpha, order)
        if j < 0 and slope == -1e-300:
            for i in range(n):
                d[i] = -d[i]
            j, step = _line_search(G, norms, tight, bound, a, d, slope, c, alpha, order)
        if j < 0:
            return -1
        for i in range(n):
            y[i] += step * d[i]
            basis[k + 1, i] = G[i, j]
        tight[j] = True
        T[k] = j
        norm2 = _project_off(basis, k + 1, basis[k + 1], n)
        if norm2 <= _TINY:
            return -1
        for i in range(n):
            basis[k + 1, i] /= np.sqrt(norm2)
    return 1


@njit(cache=True)
def vertex_basis(G, r, T, tight, M, Minv):  # pragma: no cover - compiled
    """Rows [r; g_T] of M, the tight flags of T and Minv = M^-1; False when M is singular."""
    n, m = G.shape
    for j in range(m):
        tight[j] = False
    for i in range(n):
        M[0, i] = r[i]
    for k in range(n - 1):
        tight[T[k]] = True
        for i in range(n):
            M[k + 1, i] = G[i, T[k]]
    return invert(M, Minv, n)


@njit(cache=True)
def vertex_walk(G, norms, r, y, x, accept, reject, work):  # pragma: no cover - compiled
    """Walk from the direction y (r . y > 0) to a first vertex, then towards gamma(r)'s
    optimal vertex, stopping at the first certificate: returns 1 with an allocation in x
    (G x = r up to round-off, |x|_inf <= accept), 0 with a direction in y
    (r . y > reject h(y)), 2 at the optimum with neither (x and y both written:
    |x|_inf = gamma = r . y / h(y) up to round-off), -1 when the walk gives up (a singular
    basis, or MAX_PIVOTS). ``G`` holds the generators (rank, m), ``norms`` their 1-norms,
    ``work`` the work arrays of :func:`walk_workspace`. With accept = 0 and reject = inf it
    computes gamma."""
    tight, bound, M, Minv, _, a, s, d, c, alpha, order, v, T = work
    n, m = G.shape
    for j in range(m):
        bound[j] = 1.0
    ry = 0.0
    for i in range(n):
        ry += r[i] * y[i]
    for i in range(n):
        y[i] /= ry
    crash = _crash(G, norms, r, y, T, reject, work)
    if crash <= 0:
        return crash
    if not vertex_basis(G, r, T, tight, M, Minv):
        return -1
    return _pivots(G, norms, r, y, x, accept, reject, work)


@njit(cache=True)
def walk_from(G, norms, r, y, x, accept, reject, work, start, signs):  # pragma: no cover
    """:func:`vertex_walk` from the vertex of the tight columns ``start`` (rank - 1 column
    indices: say the optimal vertex of a similar zonotope for the same wrench), skipping the
    crash, with the bounds ``signs`` (m,) (+-1; 0: unknown) on the columns that lie on its
    hyperplane (a facet holds many: their bounds are what the degenerate pivots would find);
    from the direction y as :func:`vertex_walk` when ``start`` holds a negative index, an
    index off G or a singular basis. Any vertex is a valid start: the optimum, hence gamma, is
    the same up to round-off; only a walk stopped early (a certificate) may end elsewhere."""
    tight, bound, M, Minv, T = work[0], work[1], work[2], work[3], work[12]
    n, m = G.shape
    usable = n > 1 and len(start) >= n - 1
    for k in range(n - 1):
        usable = usable and 0 <= start[k] < m
    if usable:
        for j in range(m):
            bound[j] = -1.0 if signs[j] < 0 else 1.0
        for k in range(n - 1):
            T[k] = start[k]
        if vertex_basis(G, r, T, tight, M, Minv):
            return _pivots(G, norms, r, y, x, accept, reject, work)
    return vertex_walk(G, norms, r, y, x, accept, reject, work)


@njit(cache=True)
def _pivots(G, norms, r, y, x, accept, reject, work):  # pragma: no cover - compiled
    """The pivots of :func:`vertex_walk` from the vertex of its basis (``T``, ``M^-1`` in
    ``work``); its return values."""
    tight, bound, M, Minv, _, a, s, d, c, alpha, order, v, T = work
    n, m = G.shape
    for pivots in range(MAX_PIVOTS):
        for i in range(n):
            y[i] = Minv[i, 0]  # the vertex: r . y = 1, g_T . y = 0
        h = _pass(G, norms, y, tight, bound, a, s, c)
        ry = 0.0
        for i in range(n):
            ry += r[i] * y[i]
        if ry > reject * h:
            return 0
        # the leaving column: out of bounds beyond round-off (_TINY), the most per length of its
        # edge (steepest edge)
        worst, kq, best = 1.0, -1, 0.0
        for k in range(n - 1):
            acc, norm2 = 0.0, 0.0
            for i in range(n):
                acc += s[i] * Minv[i, k + 1]
                norm2 += Minv[i, k + 1] ** 2
            v[k] = acc
            worst = max(worst, abs(acc))
            if abs(acc) > 1.0 + _TINY and (abs(acc) - 1.0) ** 2 > best * norm2:
                kq, best = k, (abs(acc) - 1.0) ** 2 / norm2
        if worst < accept * h or kq < 0:  # the allocation of this vertex: |x| = worst / h
            for j in range(m):
                x[j] = bound[j] / h
            for k in range(n - 1):
                x[T[k]] = -v[k] / h
            return 1 if worst < accept * h else 2  # else optimal: gamma = 1 / h
        sign = -1.0 if v[kq] > 0.0 else 1.0
        for i in range(n):
            d[i] = sign * Minv[i, kq + 1]
        # the released column adds 1 to the slope and leaves at the bound it moves towards
        j, _ = _line_search(G, norms, tight, bound, a, d, 1.0 - abs(v[kq]), c, alpha, order)
        if j < 0:
            return -1
        tight[T[kq]] = False
        bound[T[kq]] = sign
        tight[j] = True
        T[kq] = j
        for i in range(n):
            M[kq + 1, i] = G[i, j]
        if not replace_row(M, Minv, n, kq + 1, pivots):
            return -1
    return -1


@njit(cache=True)
def walk_workspace(m, n):  # pragma: no cover - compiled
    """The work arrays of :func:`vertex_walk` for m columns and rank n."""
    return (
        np.zeros(m, dtype=np.bool_),  # tight
        np.ones(m),  # bound
        np.zeros((n, n)),  # M
        np.zeros((n, n)),  # M^-1
        np.zeros((n, n)),  # orthonormal basis (crash)
        np.zeros(m),  # a
        np.zeros(n),  # s
        np.zeros(n),  # d
        np.zeros(m),  # c
        np.zeros(m),  # breakpoints
        np.zeros(m, dtype=np.int64),  # their columns
        np.zeros(max(n - 1, 1)),  # v
        np.zeros(max(n - 1, 1), dtype=np.int64),  # T
    )
