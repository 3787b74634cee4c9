"""The compiled allocation certificate of :mod:`.faults`: every (wrench, failure) pair in one call.

Per wrench (centred reduced coordinates r of the intact zonotope) the least-norm allocation
x = P r is corrected for each failure S by ``x + C_S (1 + x_S)`` (C_S: the least-norm correction
of the other rotors with rows S set to -I, so the failed rotors read -1, i.e. zero thrust). The
pair is certified tolerated when every corrected entry lies within ACCEPT and the equations hold
to round-off: the residual of x plus the failure's own error ``|G C_S|`` times ``|1 + x_S|_1``
stays below ``tol``. Where the first correction leaves the cube, a few rounds of alternating
projections follow (clip into a slightly shrunk cube, then the least-norm move of the working
rotors back onto the equations: ``P e + C_S (P e)_S`` for the residual e), each tested the same
way; the round-off of every round is bounded like the first one's and checked in float64.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from modquad_gym.oracle.tolerance import ACCEPT, REJECT

ROUNDS = 16
"""Rounds of alternating projections after a first correction that leaves the cube."""

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


@njit(cache=True)
def certify_rows(R, G, P, dual, C, columns, starts, errors, reach, tol, out):  # pragma: no cover
    """out[t, i] = 1: the pair (row t of R, failure i) is certified tolerated; 0: certified
    not (a separating direction of the failed zonotope); -1: undecided.

    C (k, m) holds the corrections of every failure one above the other: failure i owns rows
    starts[i]:starts[i + 1] of C, and ``columns`` the rotors they stand for. ``errors[i]`` is
    ``max |G C_i|`` (inf: never certify failure i); ``reach[k]`` the largest entry of row k
    of C off its own rotor (a quick sufficient test: ``|x|_inf + sum_k reach_k |1 + x_k| <=
    ACCEPT`` needs no scan); ``tol`` the largest residual accepted, relative to 1 + |r|_inf;
    ``dual`` the dual metric (diagonal of (G G^T)^-1) that turns the last residual of the
    projections into a candidate separating direction."""
    t_rows, rank = R.shape
    m = P.shape[0]
    n_fail = len(starts) - 1
    x = np.empty(m)
    y = np.empty(m)
    pe = np.empty(m)
    e = np.empty(rank)
    a = np.empty(C.shape[0])  # one entry per row of C (per failed rotor of every failure)
    for t in range(t_rows):
        big = 0.0
        for i in range(rank):
            big = max(big, abs(R[t, i]))
        for j in range(m):
            acc = 0.0
            for i in range(rank):
                acc += P[j, i] * R[t, i]
            x[j] = acc
        xmax = 0.0
        for j in range(m):
            xmax = max(xmax, abs(x[j]))
        resid = 0.0  # |G x - r|_inf: zero for r in the row space, up to round-off
        for i in range(rank):
            acc = -R[t, i]
            for j in range(m):
                acc += G[i, j] * x[j]
            resid = max(resid, abs(acc))
        limit = tol * (1.0 + big)
        for f in range(n_fail):
            out[t, f] = -1
            if errors[f] == np.inf:
                continue
            lo, hi = starts[f], starts[f + 1]
            weight = 0.0
            spread = 0.0
            for k in range(lo, hi):
                a[k] = 1.0 + x[columns[k]]
                weight += abs(a[k])
                spread += reach[k] * abs(a[k])
            if resid + errors[f] * weight > limit:
                continue  # (the last residual e is only set by the rounds below)
            if xmax + spread <= ACCEPT:
                out[t, f] = 1
                continue
            ok = True
            if hi - lo == 2:  # a pair (rotor2): one branch-free pass the compiler vectorises
                a0, a1 = a[lo], a[lo + 1]
                worst = 0.0
                for j in range(m):
                    worst = max(worst, abs(x[j] + C[lo, j] * a0 + C[lo + 1, j] * a1))
                ok = worst <= ACCEPT
            else:
                for j in range(m):  # the first correction, stopping at an entry out of the cube
                    v = x[j]
                    for k in range(lo, hi):
                        v += C[k, j] * a[k]
                    if abs(v) > ACCEPT:
                        ok = False
                        break
            if not ok and ROUNDS:
                for j in range(m):
                    v = x[j]
                    for k in range(lo, hi):
                        v += C[k, j] * a[k]
                    y[j] = v
            for _ in range(ROUNDS):
                if ok:
                    break
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
                out[t, f] = 1
            elif ROUNDS and _separated(R[t], G, dual, e, columns[lo:hi], y):
                out[t, f] = 0
