"""The walk's basis M = [r; g_T] (rank x rank, at most 6 x 6) and its inverse: a fresh
Gauss-Jordan inversion where a walk starts, a rank-one update where a pivot replaces one row.

A pivot of :mod:`.walk` swaps one tight column, so its basis changes in one row: the
Sherman-Morrison update costs O(n^2) against the inversion's O(n^3).
"""

from __future__ import annotations

import numpy as np

from modquad_gym.core.jit import njit

REFACTOR = 8
"""Replacements between fresh inversions (rank-one updates in between)."""

_TINY = 1e-13  # relative size below which an inversion's pivot counts as zero
_UPDATE = 1e-8  # relative size of an update's pivot below which the inverse is computed afresh


@njit(cache=True)
def invert(M, Minv, n):  # pragma: no cover - compiled
    """Minv = M^-1 (n x n) by Gauss-Jordan with partial pivoting; False when M is singular to
    working accuracy (the walk then gives up on the wrench)."""
    A = M[:n, :n].copy()
    scale = 0.0
    for i in range(n):
        for k in range(n):
            Minv[i, k] = 1.0 if i == k else 0.0
            scale = max(scale, abs(A[i, k]))
    for col in range(n):
        p = col
        for i in range(col + 1, n):
            if abs(A[i, col]) > abs(A[p, col]):
                p = i
        if abs(A[p, col]) <= _TINY * scale:
            return False
        if p != col:
            for k in range(n):
                A[p, k], A[col, k] = A[col, k], A[p, k]
                Minv[p, k], Minv[col, k] = Minv[col, k], Minv[p, k]
        inv = 1.0 / A[col, col]
        for k in range(n):
            A[col, k] *= inv
            Minv[col, k] *= inv
        for i in range(n):
            if i != col and A[i, col] != 0.0:
                f = A[i, col]
                for k in range(n):
                    A[i, k] -= f * A[col, k]
                    Minv[i, k] -= f * Minv[col, k]
    return True


@njit(cache=True)
def replace_row(M, Minv, n, q, pivots):  # pragma: no cover - compiled
    """Minv = M^-1 after row q of M was replaced (the ``pivots``-th replacement of a walk): the
    rank-one (Sherman-Morrison) update of the old inverse, O(n^2); a fresh inversion every
    :data:`REFACTOR` replacements and where the update's pivot is small, so the round-off
    stays that of a few updates. False when M is singular to working accuracy."""
    if pivots % REFACTOR == REFACTOR - 1:
        return invert(M, Minv, n)
    w = np.empty(n)
    scale = 0.0
    for k in range(n):
        acc = 0.0
        for i in range(n):
            acc += M[q, i] * Minv[i, k]
        w[k] = acc
        scale = max(scale, abs(acc))
    if abs(w[q]) <= _UPDATE * scale:
        return invert(M, Minv, n)
    w[q] -= 1.0
    inv = 1.0 / (w[q] + 1.0)
    for i in range(n):
        f = Minv[i, q] * inv
        if f != 0.0:
            for k in range(n):
                Minv[i, k] -= f * w[k]
    return True
