"""The compiled certificates behind the ``"compiled"`` method (and ``"auto"``'s decisions).

One compiled call per structure and batch of wrenches does, per wrench in the oracle's centred
reduced coordinates r (those of :meth:`~modquad_gym.oracle.Zonotope.reduce`): the off-range rule
(when called with raw wrenches), the bounding box, the minimum-norm allocation, the directions
that separated earlier wrenches of the structure, then the phase-1 simplex of :mod:`.simplex`,
which ends with

* an allocation x: after the correction x - P (G x - r) onto G x = r (P the pseudo-inverse of
  G), ``|x|_inf <= ACCEPT`` certifies gamma(r) <= 1 + TOL: feasible; or
* a dual direction y: ``y . r > REJECT * sum_j |y . g_j|`` (the zonotope's support in direction
  y) certifies gamma(r) > 1 + TOL: infeasible.

ACCEPT and REJECT are the tolerance rule's (:mod:`~modquad_gym.oracle.tolerance`). Both tests are
evaluated here in float64 from x or y alone, so they are exact whatever the simplex did. A
wrench that no certificate decides (within GUARD of the threshold, within 1 % of the off-range
rule, too large, or a simplex stopped by its pivot limit) is marked undecided (-1) for the exact
LP (:mod:`.compiled`).
"""

from __future__ import annotations

import numpy as np
from numba import njit

from modquad_gym.oracle.simplex import phase_one
from modquad_gym.oracle.tolerance import ACCEPT, REJECT, RESIDUAL_TOL

_HUGE = 1e100  # rows of w / f_max beyond this are left undecided (reduce() avoids overflow)
_OFF = 1.01  # off-range margin: residuals within this factor of the rule are left undecided


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
    ``axes``), the minimum-norm allocation (accepted by the rule's ACCEPT, G P = I up to
    round-off far below GUARD), the remembered separating directions, then
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
def decide_rows(G, P, R, memory, out):  # pragma: no cover - compiled
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


@njit(cache=True)  # pragma: no cover - compiled
def decide_screened(W, WD, h, slack, f_max, Q, c, G, P, memory, per_wrench, out, counts):
    """A structure against wrenches W (t, 6) after a support screen: per_wrench (t,) =
    max_d (WD - h) (see :meth:`~modquad_gym.oracle.WrenchOracle.screened`), and the verdict of
    each row into out: -2 where the screen rejects it (not tested), else 0 off range(A), else
    that of :func:`_decide_row` on its centred reduced coordinates (-1: undecided).
    counts: (tested, feasible, undecided)."""
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
