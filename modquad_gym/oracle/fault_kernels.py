"""The compiled allocation certificate of :mod:`.faults`: every (wrench, failure) pair in one call.

Per wrench (centred reduced coordinates r of the intact zonotope) the least-norm allocation
x = P r is corrected for each failure S by ``x + C_S (1 + x_S)`` (C_S: the least-norm correction
of the other rotors with rows S set to -I, so the failed rotors read -1, i.e. zero thrust). The
pair is certified tolerated when every corrected entry lies within ACCEPT and the equations hold
to round-off: the residual of x plus the failure's own error ``|G C_S|`` times ``|1 + x_S|_1``
stays below ``tol``. The same correction applies from any allocation y with G y = r (C_S is
linear in the deviation 1 + y_S), with y's own residual in place of x's. The tests, cheapest
first (:data:`PATHS`):

1. without a scan: the largest entry of x plus the largest rise the correction rows can cause
   (and the same downwards) stays in the cube;
2. for a pair {i, j}, through a single failure: the least-norm corrections compose (the pair's
   affine set lies in rotor i's), so the pair's correction is y_i + c_{j|i} (1 + (y_i)_j), with
   y_i = x + C_i (1 + x_i) rotor i's and c_{j|i} the correction of j once i has failed, whose
   largest rise and fall are made once per structure (:mod:`.fault_corrections`); bounded by
   y_i's extremes, or with i and j swapped;
3. the first correction itself, scanned;
4. from an allocation the active set found for an earlier pair of the wrench that has a
   failed rotor already off (kept in a pool of :data:`POOL`);
5. the active set (:mod:`.active_set`): the rotors the first correction took out of the cube are
   pinned at +-PIN and the least-norm move in the null space of G that puts them there is
   taken; its residual measured;
6. alternating projections (clip into the shrunk cube, then back onto the equations); their
   last residual gives a candidate separating direction, which certifies a pair not tolerated
   (7).

The certificate's arrays (:func:`~.fault_corrections.corrections`) that :func:`certify_rows`
takes: C (k, m), the corrections of every failure one above the other (failure i owns rows
starts[i]:starts[i + 1] of C, and ``columns`` the rotors they stand for); ``errors[i]``,
``max |G C_i|`` (inf: never certify failure i); ``up[k]`` and ``down[k]``, the largest rise and
fall row k of C causes off its failed rotors per unit of ``a = 1 + x_S >= 0`` (so ``max x +
sum_k up_k a_k <= ACCEPT`` and ``sum_k down_k a_k - min x <= ACCEPT`` certify without a scan);
``lift`` = (the single failures' corrections (m, m), and per ordered pair (i, j) the largest rise
and fall of the correction of j once i has failed, (m, m) each) for test 2 (empty arrays skip
it); H, the projection on the row space of G (the active set's); ``dual``, the dual metric
(diagonal of (G G^T)^-1) that turns the projections' last residual into a candidate separating
direction. Besides: ``tol``, the largest residual accepted, relative to 1 + |r|_inf; ``work``, the
active set's scratch (:func:`~.active_set.workspace`); ``paths`` (7,), the pairs settled by each
test, in :data:`PATHS` order; ``trace`` (t, F) int8, unless empty, which test settled each pair
(for the tests' cross-checks).
"""

from __future__ import annotations

import numpy as np

from modquad_gym.core.jit import njit
from modquad_gym.oracle.active_set import active_set
from modquad_gym.oracle.tolerance import ACCEPT, GUARD, REJECT

ROUNDS = 16
"""Rounds of alternating projections after the active set fails."""

PIN = 0.8
"""The active set pins a rotor that left the cube at +-PIN: well inside, so that the allocation
it finds leaves room for the corrections of the wrench's later pairs (it is kept in a pool)."""

POOL = 4
"""Allocations the active set found for a wrench, kept as starts for its later pairs."""

SURE = ACCEPT - GUARD
"""A pair's correction bounded through a single failure is accepted below this: the bound
holds to round-off (its rows are computed apart from C_S), kept clear by GUARD."""

PATHS = ("quick", "through a single failure", "first correction", "pool", "active set",
         "projections", "separated")  # fmt: skip
"""The tests of :func:`certify_rows` that settle a (wrench, failure) pair, in order."""

SHRINK = 1.0 - 1e-3
"""The projections clip into the cube shrunk by this factor (so that the move back onto the
equations can end strictly inside)."""


@njit(cache=True)
def _separated(r, G, dual, e, failed, work):  # pragma: no cover - compiled
    """Does d = dual * e (the projections' last residual in the dual metric) separate r from the
    zonotope with the ``failed`` rotors off? ``d . (r + G_S 1) > REJECT sum_{j not in S}
    |d . g_j|``: its gamma about its own centre exceeds 1 + TOL (``work``: scratch (m,))."""
    rank, m = G.shape
    for j in range(m):
        acc = 0.0
        for i in range(rank):
            acc += dual[i] * e[i] * G[i, j]
        work[j] = acc
    value = 0.0
    for i in range(rank):
        value += dual[i] * e[i] * r[i]
    support = 0.0
    for j in range(m):
        support += abs(work[j])
    for k in range(len(failed)):
        value += work[failed[k]]
        support -= abs(work[failed[k]])
    return value > REJECT * support


@njit(cache=True, inline="always")
def _single_failures(x, single, hi1, lo1):  # pragma: no cover - compiled
    """hi1[i], lo1[i]: the largest and smallest entry, off rotor i, of x + single[i] (1 + x_i),
    the least-norm allocation once rotor i alone has failed. Returns True (made)."""
    m = len(x)
    for i in range(m):
        a = 1.0 + x[i]
        hi = -np.inf
        lo = np.inf
        for k in range(i):
            v = x[k] + single[i, k] * a
            hi = max(hi, v)
            lo = min(lo, v)
        for k in range(i + 1, m):
            v = x[k] + single[i, k] * a
            hi = max(hi, v)
            lo = min(lo, v)
        hi1[i] = hi
        lo1[i] = lo
    return True


@njit(cache=True, inline="always")
def _first_correction(x, C, lo, hi, a, y):  # pragma: no cover - compiled
    """y = x + sum_k C[k] a[k] (k in lo:hi), the first correction; returns max_j |y_j|."""
    worst = 0.0
    if hi - lo == 2:  # a pair: one branch-free pass
        a0, a1 = a[lo], a[lo + 1]
        for j in range(len(x)):
            v = x[j] + C[lo, j] * a0 + C[lo + 1, j] * a1
            y[j] = v
            worst = max(worst, abs(v))
        return worst
    for j in range(len(x)):
        v = x[j]
        for k in range(lo, hi):
            v += C[k, j] * a[k]
        y[j] = v
        worst = max(worst, abs(v))
    return worst


@njit(cache=True, inline="always")
def _residual(r, G, y):  # pragma: no cover - compiled
    """|G y - r|_inf: how far the allocation y is off the equations (measured in float64)."""
    worst = 0.0
    for i in range(G.shape[0]):
        acc = -r[i]
        for j in range(G.shape[1]):
            acc += G[i, j] * y[j]
        worst = max(worst, abs(acc))
    return worst


@njit(cache=True)
def _row(r, G, P, x):  # pragma: no cover - compiled
    """x = P r, the least-norm allocation of the centred reduced wrench r; returns |r|_inf, the
    largest and smallest entry of x and its residual (zero up to round-off for r in the row
    space): what every failure of the wrench starts from."""
    rank, m = G.shape
    big = 0.0
    for i in range(rank):
        big = max(big, abs(r[i]))
    for j in range(m):
        acc = 0.0
        for i in range(rank):
            acc += P[j, i] * r[i]
        x[j] = acc
    xhi = -np.inf
    xlo = np.inf
    for j in range(m):
        xhi = max(xhi, x[j])
        xlo = min(xlo, x[j])
    return big, xhi, xlo, _residual(r, G, x)


@njit(cache=True, inline="always")
def _deviations(x, columns, lo, hi, up, down, a):  # pragma: no cover - compiled
    """a[k] = 1 + x_S (k in lo:hi), the deviations the failure's correction scales; returns
    their 1-norm and the largest rise and fall the correction can cause (test 1)."""
    if hi - lo == 2 and x[columns[lo]] >= -1.0 and x[columns[lo + 1]] >= -1.0:
        a0 = 1.0 + x[columns[lo]]  # a pair, both deviations >= 0: straight-line code
        a1 = 1.0 + x[columns[lo + 1]]
        a[lo] = a0
        a[lo + 1] = a1
        return a0 + a1, up[lo] * a0 + up[lo + 1] * a1, down[lo] * a0 + down[lo + 1] * a1
    weight = 0.0
    rise = 0.0
    fall = 0.0
    for k in range(lo, hi):
        a[k] = 1.0 + x[columns[k]]
        weight += abs(a[k])
        if a[k] >= 0.0:
            rise += up[k] * a[k]
            fall += down[k] * a[k]
        else:
            rise -= down[k] * a[k]
            fall -= up[k] * a[k]
    return weight, rise, fall


@njit(cache=True, inline="always")
def _from_pool(
    pool, pool_resid, found, C, columns, lo, hi, error, limit, a2, pe
):  # pragma: no cover - compiled
    """Test 4: the first correction from an allocation of the pool that has a failed rotor of
    this failure off already stays in the cube (newest first: its pair is the likeliest kin)."""
    for q in range(min(found, POOL)):
        p = (found - 1 - q) % POOL
        weight = 0.0
        shared = False
        for k in range(lo, hi):
            a2[k] = 1.0 + pool[p, columns[k]]
            weight += abs(a2[k])
            shared |= a2[k] == 0.0
        if shared and pool_resid[p] + error * weight <= limit:
            if _first_correction(pool[p], C, lo, hi, a2, pe) <= ACCEPT:
                return True
    return False


@njit(cache=True, inline="always")
def _projected(r, G, P, dual, C, columns, lo, hi, x, a, y, e, pe, limit):  # pragma: no cover
    """Tests 6 and 7, once the active set has failed: ROUNDS of alternating projections from
    the first correction (clip the working rotors into the shrunk cube, move back onto G y = r)
    certify the pair when a round ends in the cube with its residual measured within
    ``limit``; else their last move ``e`` may separate it. Returns the index in PATHS of the
    test that settles it, -1 when neither does (inlined: measured faster than a call)."""
    rank, m = G.shape
    for j in range(m):
        v = x[j]
        for k in range(lo, hi):
            v += C[k, j] * a[k]
        y[j] = v
    for _ in range(ROUNDS):
        for j in range(m):
            y[j] = min(max(y[j], -SHRINK), SHRINK)
        for k in range(lo, hi):
            y[columns[k]] = -1.0
        for i in range(rank):
            acc = r[i]
            for j in range(m):
                acc -= G[i, j] * y[j]
            e[i] = acc
        for j in range(m):
            acc = 0.0
            for i in range(rank):
                acc += P[j, i] * e[i]
            pe[j] = acc
        ok = True
        for j in range(m):
            v = y[j] + pe[j]
            for k in range(lo, hi):
                v += C[k, j] * pe[columns[k]]
            y[j] = v
            if abs(v) > ACCEPT:
                ok = False
        if ok and _residual(r, G, y) <= limit:  # this round's round-off, measured
            return 5
    if ROUNDS and _separated(r, G, dual, e, columns[lo:hi], y):
        return 6
    return -1


@njit(cache=True)
def certify_rows(
    R, G, P, H, dual, C, columns, starts, errors, up, down, lift, tol, stop, work, out, paths, trace
):  # pragma: no cover
    """out[t, i] = 1: the pair (row t of R, failure i) is certified tolerated; 0: certified
    not (a separating direction of the failed zonotope); -1: undecided. With ``stop`` 1 it
    returns at the first pair certified not tolerated, with 2 also after the first row with
    a pair left undecided (the rows after it left unset); returns the number of rows done.
    The arguments are described in the module docstring. The tests that most pairs reach stay
    in this loop rather than in helpers: measured, a call that passes arrays (even inlined)
    costs more than they do."""
    single, up2, down2 = lift
    m, k, n = G.shape[1], C.shape[0], len(single)
    x, y, pe, e = np.empty(m), np.empty(m), np.empty(m), np.empty(G.shape[0])
    a, a2, hi1, lo1 = np.empty(k), np.empty(k), np.empty(n), np.empty(n)  # a: per row of C
    pool, pool_resid = np.empty((POOL, m)), np.empty(POOL)  # allocations found for the wrench
    for t in range(R.shape[0]):
        big, xhi, xlo, resid = _row(R[t], G, P, x)
        limit = tol * (1.0 + big)
        found = 0  # allocations in the pool for this wrench
        lifted = False  # the single failures' corrections of this wrench not yet made
        for f in range(len(starts) - 1):
            out[t, f] = -1
            if errors[f] == np.inf:
                continue
            lo, hi = starts[f], starts[f + 1]
            weight, rise, fall = _deviations(x, columns, lo, hi, up, down, a)
            if resid + errors[f] * weight > limit:
                continue  # (the last residual e is only set by the projections)
            if xhi + rise <= ACCEPT and fall - xlo <= ACCEPT:
                out[t, f] = 1
                paths[0] += 1
                if len(trace):
                    trace[t, f] = 0
                continue
            if hi - lo == 2 and len(single):  # a pair: through each rotor's own failure
                lifted = lifted or _single_failures(x, single, hi1, lo1)  # made on first need
                i, j = columns[lo], columns[lo + 1]
                # through rotor i's failure (module docstring), then j's: 1 + (y_i)_j; or j's, i's
                b = 1.0 + (x[j] + single[i, j] * (1.0 + x[i]))
                ok = (
                    b >= 0.0 and hi1[i] + up2[i, j] * b <= SURE and down2[i, j] * b - lo1[i] <= SURE
                )
                c = 1.0 + (x[i] + single[j, i] * (1.0 + x[j]))
                if ok or (
                    c >= 0.0 and hi1[j] + up2[j, i] * c <= SURE and down2[j, i] * c - lo1[j] <= SURE
                ):
                    out[t, f] = 1
                    paths[1] += 1
                    if len(trace):
                        trace[t, f] = 1
                    continue
            if _first_correction(x, C, lo, hi, a, y) <= ACCEPT:
                path = 2
            elif _from_pool(pool, pool_resid, found, C, columns, lo, hi, errors[f], limit, a2, pe):
                path = 3
            else:
                worst = active_set(R[t], G, H, y, columns[lo:hi], limit, PIN, work)
                if worst < 0.0:  # again, pinning just inside the cube
                    _first_correction(x, C, lo, hi, a, y)
                    worst = active_set(R[t], G, H, y, columns[lo:hi], limit, SHRINK, work)
                if worst >= 0.0:
                    pool[found % POOL] = y
                    pool_resid[found % POOL] = worst
                    found += 1
                    path = 4
                else:
                    path = _projected(R[t], G, P, dual, C, columns, lo, hi, x, a, y, e, pe, limit)
                    if path < 0:
                        continue
            out[t, f] = 0 if path == 6 else 1
            paths[path] += 1
            if len(trace):
                trace[t, f] = path
            if path == 6 and stop:
                return t + 1
        if stop == 2:  # the row is done: stop when a pair of it is left undecided
            for f in range(len(starts) - 1):
                if out[t, f] != 1:
                    return t + 1
    return R.shape[0]
