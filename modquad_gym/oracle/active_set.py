"""Moving an allocation into the cube with some rotors pinned: an active set in the null space.

Given y with G y = r (up to round-off) and some rotors that must keep a value (the failed ones at
-1), the rotors outside the cube [-1, 1] are pinned at +-pin and the least-norm move that keeps
G y = r and puts every pinned rotor on its target is taken,

    delta = (I - H)_{:,T} (I - H_TT)^-1 d_T,

H = V^T V the projection on the row space of G (so G (I - H) = 0), T the pinned rotors, d_T their
moves; rotors the move takes out of the cube are pinned too, for at most :data:`STEPS` steps.
The result is certified only after the failed rotors are set to exactly -1, every entry is
checked against ACCEPT and the residual |G y - r| is measured in float64: a wrong pinning can
fail (a pinned rotor would have to come free), never accept wrongly.
"""

from __future__ import annotations

import numpy as np

from modquad_gym.core.jit import njit
from modquad_gym.oracle.tolerance import ACCEPT

STEPS = 4
"""Steps of the active set (each pins the rotors that left the cube)."""

PINNED = 12
"""Most rotors the active set pins (the failed ones included)."""

_PIVOT = 1e-9  # a pivot of I - H_TT below this: the pinned set leaves too little freedom


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
def active_set(r, G, H, y, failed, limit, pin, work):  # pragma: no cover - compiled
    """Move y (G y = r up to round-off, the ``failed`` rotors at -1) into the cube by the
    active set of the module docstring, pinning rotors at +-``pin``. Returns |G y - r|_inf
    (measured) when the result is certified (every entry within ACCEPT, the failed rotors
    exactly -1, that residual <= limit), else -1."""
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
    added = 0  # written out here and after each step: an inlined helper was slower
    for j in range(m):
        if abs(y[j]) > ACCEPT and mark[j] != stamp:
            if n == PINNED:
                return -1.0
            pinned[n] = j
            target[n] = pin if y[j] > 0.0 else -pin
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
            return -1.0
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
                    return -1.0
                pinned[n] = j
                target[n] = pin if y[j] > 0.0 else -pin
                mark[j] = stamp
                n += 1
                added += 1
    if added:
        return -1.0
    for k in range(len(failed)):
        y[failed[k]] = -1.0
    for i in range(n):
        if abs(y[pinned[i]]) > ACCEPT:
            return -1.0
    worst = 0.0
    for i in range(G.shape[0]):
        acc = -r[i]
        for j in range(m):
            acc += G[i, j] * y[j]
        worst = max(worst, abs(acc))
    return worst if worst <= limit else -1.0


def workspace(m: int):
    """The scratch arrays of :func:`active_set` for m rotors."""
    mark = np.zeros(m + 1, dtype=np.int64)  # the last entry holds the stamp counter
    return (np.empty(PINNED, np.int64), np.empty(PINNED), np.empty((PINNED, PINNED)),
            np.empty(PINNED), mark)  # fmt: skip
