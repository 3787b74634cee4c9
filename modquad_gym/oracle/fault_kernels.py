"""The compiled allocation certificate of :mod:`.faults`: every (wrench, failure) pair in one call.

Per wrench (centred reduced coordinates r of the intact zonotope) the least-norm allocation
x = P r is corrected for each failure S by ``x + C_S (1 + x_S)`` (C_S: the least-norm correction
of the other rotors with rows S set to -I, so the failed rotors read -1, i.e. zero thrust). The
pair is certified tolerated when every corrected entry lies within ACCEPT and the equations hold
to round-off: the residual of x plus the failure's own error ``|G C_S|`` times ``|1 + x_S|_1``
stays below ``tol``. Most pairs pass without a scan: the largest entry of x plus the largest
rise any correction row can cause (and the same downwards) already stays in the cube.

Where the first correction leaves the cube, an active set follows: the rotors out of the cube
are pinned just inside it (at +-SHRINK) beside the failed ones, and the least-norm move in the
null space of G that puts every pinned rotor on its target, ``(I - H)_{:,T} (I - H_TT)^-1 d_T``
(H the projection on the row space of G, d_T the pinned rotors' moves), is taken; rotors that
leave the cube on the way are pinned too, for a few steps. Its result is accepted only after
the failed rotors are set to exactly -1, every entry is checked against ACCEPT and the residual
|G y - r| is measured in float64. Where it fails (a pinned rotor would have to come free), a few
rounds of alternating projections follow (clip into the shrunk cube, then the least-norm move
of the working rotors back onto the equations), tested the same way; their last residual gives
a candidate separating direction, which certifies a pair not tolerated.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from modquad_gym.oracle.tolerance import ACCEPT, GUARD, REJECT

ROUNDS = 16
"""Rounds of alternating projections after the active set fails."""

STEPS = 4
"""Steps of the active set (each pins the rotors that left the cube)."""

PINNED = 12
"""Most rotors the active set pins (the failed ones included)."""

SURE = ACCEPT - GUARD
"""A pair's correction bounded through a single failure is accepted below this: the bound
holds to round-off (its rows are computed apart from C_S), kept clear by GUARD."""

_PIVOT = 1e-9  # a pivot of I - H_TT below this: the pinned set leaves too little freedom

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
def _solve(M, b, n):  # pragma: no cover - compiled
    """Solve M[:n, :n] z = b[:n] in place (z into b) for a symmetric M by its Cholesky
    factor (M = I - H_TT is positive semi-definite); False when a pivot falls below _PIVOT
    (the pinned rotors leave too little freedom)."""
    for c in range(n):
        d = M[c, c]
        for k in range(c):
            d -= M[c, k] * M[c, k]
        if d < _PIVOT:
            return False
        d = np.sqrt(d)
        M[c, c] = d
        for i in range(c + 1, n):
            v = M[i, c]
            for k in range(c):
                v -= M[i, k] * M[c, k]
            M[i, c] = v / d
    for c in range(n):  # L z' = b, then L^T z = z'
        v = b[c]
        for k in range(c):
            v -= M[c, k] * b[k]
        b[c] = v / M[c, c]
    for c in range(n - 1, -1, -1):
        v = b[c]
        for k in range(c + 1, n):
            v -= M[k, c] * b[k]
        b[c] = v / M[c, c]
    return True


@njit(cache=True, inline="always")
def _active_set(r, G, H, y, failed, limit, work):  # pragma: no cover - compiled
    """Move y (G y = r up to round-off, the ``failed`` rotors at -1) into the cube by the
    active set of the module docstring; True when the result is certified (every entry within
    ACCEPT, the failed rotors exactly -1, |G y - r|_inf <= limit, measured)."""
    pinned, target, M, b, mark = work
    stamp = mark[-1] + 1  # marks this call's pinned rotors without clearing the array
    mark[-1] = stamp
    m = len(y)
    n = 0
    for k in range(len(failed)):
        pinned[n] = failed[k]
        target[n] = -1.0
        mark[failed[k]] = stamp
        n += 1
    added = 0
    for j in range(m):
        if abs(y[j]) > ACCEPT and mark[j] != stamp:
            if n == PINNED:
                return False
            pinned[n] = j
            target[n] = SHRINK if y[j] > 0.0 else -SHRINK
            mark[j] = stamp
            n += 1
            added += 1
    for step in range(STEPS):
        if added == 0:
            break
        for i in range(n):
            b[i] = target[i] - y[pinned[i]]
            for c in range(n):
                M[i, c] = -H[pinned[i], pinned[c]]
            M[i, i] += 1.0
        if not _solve(M, b, n):
            return False
        for i in range(n):  # the move (I - H)_{:,T} b (H is symmetric: rows, contiguous)
            row = pinned[i]
            bi = b[i]
            for j in range(m):
                y[j] -= H[row, j] * bi
        for i in range(n):
            y[pinned[i]] += b[i]
        added = 0
        for j in range(m):  # rotors the move takes out of the cube are pinned too
            if abs(y[j]) > ACCEPT and mark[j] != stamp:
                if n == PINNED or step == STEPS - 1:
                    return False
                pinned[n] = j
                target[n] = SHRINK if y[j] > 0.0 else -SHRINK
                mark[j] = stamp
                n += 1
                added += 1
    if added:
        return False
    for k in range(len(failed)):
        y[failed[k]] = -1.0
    for i in range(n):
        if abs(y[pinned[i]]) > ACCEPT:
            return False
    for i in range(G.shape[0]):
        acc = -r[i]
        for j in range(m):
            acc += G[i, j] * y[j]
        if abs(acc) > limit:
            return False
    return True


def active_set_workspace(m: int):
    """The scratch arrays of :func:`_active_set` for m rotors."""
    mark = np.zeros(m + 1, dtype=np.int64)  # the last entry holds the stamp counter
    return (np.empty(PINNED, np.int64), np.empty(PINNED), np.empty((PINNED, PINNED)),
            np.empty(PINNED), mark)  # fmt: skip


@njit(cache=True, inline="always")
def _single_failures(x, single, Y1, hi1, lo1):  # pragma: no cover - compiled
    """Y1[i] = x + single[i] (1 + x_i): the least-norm allocation once rotor i alone has
    failed; hi1[i], lo1[i] its largest and smallest entry off rotor i."""
    m = len(x)
    for i in range(m):
        a = 1.0 + x[i]
        hi = -np.inf
        lo = np.inf
        for k in range(m):
            v = x[k] + single[i, k] * a
            Y1[i, k] = v
            if k != i:
                hi = max(hi, v)
                lo = min(lo, v)
        hi1[i] = hi
        lo1[i] = lo


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


@njit(cache=True)
def certify_rows(R, G, P, H, dual, C, columns, starts, errors, up, down, lift, tol, stop, work, out):  # pragma: no cover  # noqa: E501
    """out[t, i] = 1: the pair (row t of R, failure i) is certified tolerated; 0: certified
    not (a separating direction of the failed zonotope); -1: undecided. With ``stop`` it
    returns at the first pair certified not tolerated (the rows after it left unset); returns
    the number of rows done.

    C (k, m) holds the corrections of every failure one above the other: failure i owns rows
    starts[i]:starts[i + 1] of C, and ``columns`` the rotors they stand for. ``errors[i]`` is
    ``max |G C_i|`` (inf: never certify failure i); ``up[k]`` and ``down[k]`` the largest rise
    and fall row k of C causes off its failed rotors (per unit of ``a = 1 + x_S >= 0``: so
    ``max x + sum_k up_k a_k <= ACCEPT`` and ``sum_k down_k a_k - min x <= ACCEPT`` certify
    without a scan); ``tol`` the largest residual accepted, relative to 1 + |r|_inf; H the
    projection on the row space of G (the active set's); ``dual`` the dual metric (diagonal of
    (G G^T)^-1) that turns the last residual of the projections into a candidate separating
    direction; ``work`` the active set's scratch (:func:`active_set_workspace`). For pairs,
    ``lift`` = (the single failures' corrections (m, m), and per ordered pair (i, j) the
    largest rise and fall of the correction of j once i has failed, (m, m) each) certifies
    most pairs without a scan (:func:`_through`); empty arrays skip it."""
    t_rows, rank = R.shape
    m = P.shape[0]
    n_fail = len(starts) - 1
    x = np.empty(m)
    y = np.empty(m)
    pe = np.empty(m)
    e = np.empty(rank)
    a = np.empty(C.shape[0])  # one entry per row of C (per failed rotor of every failure)
    single, up2, down2 = lift
    Y1 = np.empty(single.shape)
    hi1 = np.empty(len(single))
    lo1 = np.empty(len(single))
    for t in range(t_rows):
        big = 0.0
        for i in range(rank):
            big = max(big, abs(R[t, i]))
        for j in range(m):
            acc = 0.0
            for i in range(rank):
                acc += P[j, i] * R[t, i]
            x[j] = acc
        xhi = -np.inf
        xlo = np.inf
        for j in range(m):
            xhi = max(xhi, x[j])
            xlo = min(xlo, x[j])
        resid = 0.0  # |G x - r|_inf: zero for r in the row space, up to round-off
        for i in range(rank):
            acc = -R[t, i]
            for j in range(m):
                acc += G[i, j] * x[j]
            resid = max(resid, abs(acc))
        limit = tol * (1.0 + big)
        lifted = False  # the single failures' corrections of this wrench not yet made
        for f in range(n_fail):
            out[t, f] = -1
            if errors[f] == np.inf:
                continue
            lo, hi = starts[f], starts[f + 1]
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
            if resid + errors[f] * weight > limit:
                continue  # (the last residual e is only set by the rounds below)
            if xhi + rise <= ACCEPT and fall - xlo <= ACCEPT:
                out[t, f] = 1
                continue
            if hi - lo == 2 and len(single):  # a pair: through each rotor's own failure
                if not lifted:
                    _single_failures(x, single, Y1, hi1, lo1)
                    lifted = True
                i, j = columns[lo], columns[lo + 1]
                b = 1.0 + Y1[i, j]  # through rotor i's failure (module docstring), then j's
                if b >= 0.0 and hi1[i] + up2[i, j] * b <= SURE and down2[i, j] * b - lo1[i] <= SURE:
                    out[t, f] = 1
                    continue
                b = 1.0 + Y1[j, i]
                if b >= 0.0 and hi1[j] + up2[j, i] * b <= SURE and down2[j, i] * b - lo1[j] <= SURE:
                    out[t, f] = 1
                    continue
            if _first_correction(x, C, lo, hi, a, y) <= ACCEPT:
                out[t, f] = 1
                continue
            if _active_set(R[t], G, H, y, columns[lo:hi], limit, work):
                out[t, f] = 1
                continue
            for j in range(m):  # the projections start again from the first correction
                v = x[j]
                for k in range(lo, hi):
                    v += C[k, j] * a[k]
                y[j] = v
            ok = False
            for _ in range(ROUNDS):
                # clip the working rotors into the shrunk cube, move back onto G y = r
                for j in range(m):
                    y[j] = min(max(y[j], -SHRINK), SHRINK)
                for k in range(lo, hi):
                    y[columns[k]] = -1.0
                for i in range(rank):
                    acc = R[t, i]
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
                if ok:  # round-off of this round: the residual of y, measured
                    worst = 0.0
                    for i in range(rank):
                        acc = -R[t, i]
                        for j in range(m):
                            acc += G[i, j] * y[j]
                        worst = max(worst, abs(acc))
                    ok = worst <= limit
                if ok:
                    break
            if ok:
                out[t, f] = 1
            elif ROUNDS and _separated(R[t], G, dual, e, columns[lo:hi], y):
                out[t, f] = 0
                if stop:
                    return t + 1
    return t_rows
