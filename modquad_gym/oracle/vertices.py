"""Reading a walk's stored optimal vertex without walking: its direction, where it is gamma's
unique optimum (the exact lookahead's shortlist directions, :mod:`modquad_gym.envs.assembly`).

:func:`~.kernels.gamma_rows_from` leaves each row's optimal vertex (tight columns, the other
columns' bounds); on the same zonotope in a later call one fresh inversion of its basis gives
the direction every walk to that optimum ends at, for one pass over G.
"""

from __future__ import annotations

import numpy as np

from modquad_gym.core.jit import njit
from modquad_gym.oracle.walk import vertex_basis

_SIGN = 1e-12  # relative size of g_j . y within which a stored bound's sign is not checked


@njit(cache=True)
def vertex_directions(G, R, starts, signs, cap, dirs, found):  # pragma: no cover - compiled
    """Per row k of R (centred reduced wrenches): where its stored vertex (tight columns
    ``starts[k]`` and the other columns' bounds ``signs[k]``, as :func:`~.kernels.gamma_rows_from`
    leaves them: say a walk's on this zonotope in an earlier call) is gamma's unique optimum
    below ``cap``, its direction y goes to ``dirs[k]`` and ``found[k]`` is True: the
    direction every walk to the optimum ends at (:func:`~.kernels.gamma_rows`' from the dual-metric
    direction too, up to round-off), for one pass over G. Unique: every edge of the vertex
    raises h strictly (|v|_inf < 1 - 1e-9 in :func:`~.walk.vertex_walk`'s terms, so no
    other vertex ties); below cap: gamma = 1 / h(y) < (1 - 1e-9) cap, so no walk stops
    earlier at a proof past cap. False elsewhere (no vertex, a singular basis, a tie, near
    cap, a bound whose sign g_j . y contradicts beyond round-off: such rows need a walk)."""
    n, m = G.shape
    M, Minv = np.zeros((n, n)), np.zeros((n, n))
    tight = np.zeros(m, dtype=np.bool_)
    T = np.zeros(max(n - 1, 1), dtype=np.int64)
    s = np.zeros(n)
    for k in range(R.shape[0]):
        found[k] = False
        usable = n > 1
        for q in range(n - 1):
            T[q] = starts[k, q]
            usable = usable and 0 <= T[q] < m
        if not usable or not vertex_basis(G, R[k], T, tight, M, Minv):
            continue
        h = 0.0
        s[:] = 0.0
        ymax = np.abs(Minv[:, 0]).max()
        for j in range(m):
            if tight[j]:
                continue
            acc, norm = 0.0, 0.0
            for i in range(n):
                acc += G[i, j] * Minv[i, 0]
                norm += abs(G[i, j])
            h += abs(acc)
            usable = usable and signs[k, j] != 0 and signs[k, j] * acc >= -_SIGN * norm * ymax
            for i in range(n):
                s[i] += signs[k, j] * G[i, j]
        worst = 0.0
        for q in range(n - 1):
            acc = 0.0
            for i in range(n):
                acc += s[i] * Minv[i, q + 1]
            worst = max(worst, abs(acc))
        if usable and worst < 1.0 - 1e-9 and 1.0 < (1.0 - 1e-9) * cap * h:  # r . y = 1
            dirs[k] = Minv[:, 0]
            found[k] = True
