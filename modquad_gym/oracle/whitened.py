"""A zonotope prepared for gammas only, in whitened coordinates, without an SVD.

gamma (the least ``||x||_inf`` with ``G x = r``) does not depend on the coordinates the wrenches
are written in, only on the set. :class:`~modquad_gym.oracle.zonotope.Zonotope` takes them from
an SVD of A (an orthonormal basis ``Q`` the certificates and margins rely on); for a child of
the exact lookahead, walked once and mostly never docked, that SVD and its bookkeeping cost more
than the child's walks at 64 modules. Here ``L L^T = A A^T`` (Cholesky) and the coordinates are
``L^-1 w``: ``G = L^-1 A / 2`` has ``G G^T = I / 4`` (orthogonal rows, as the SVD's, so the
compiled walk's dual metric and pseudo-inverse ``P = 4 G^T`` hold), all in one compiled call.

Only a full-rank A whose Cholesky factor has condition number below :data:`MAX_CONDITION` is
prepared this way (:func:`whitened` returns None otherwise: the SVD decides rank and
conditioning); the squared matrix's round-off then stays far below the walk's tolerances, and
the gammas equal the SVD zonotope's up to round-off (``tests/test_oracle_compiled.py``).
"""

from __future__ import annotations

import numpy as np

from modquad_gym.core.jit import njit

MAX_CONDITION = 1e5
"""Largest ``|L|_F |L^-1|_F`` (about A's condition number) prepared by Cholesky."""

MIN_COLUMNS = 64
"""Fewest columns (16 four-rotor modules) prepared this way: below, the SVD costs about as much,
and a small structure recurs (its full zonotope is soon wanted anyway)."""


class WhitenedZonotope:
    """The fields of a :class:`~modquad_gym.oracle.zonotope.Zonotope` that its gammas need
    (``reduce``, ``G``, ``P``, ``c``, ``box``, ``rank``, ``m``, ``V`` and ``sigma`` (here G and
    ones), the ``kernel`` and ``lp`` slots and :meth:`gamma_of_allocation`), in the whitened
    coordinates ``L^-1 w / f_max``: for
    :func:`~modquad_gym.oracle.backends.gamma_capped_from` and the DAQP fallback, not for
    decisions, directions or margins of the API (which need the orthonormal basis)."""

    rank = 6
    scale = 0.5  # the singular values of G (all equal: G G^T = I / 4)
    sigma = np.ones(6)  # G's rows are already of equal norms: the LPs take them as they are

    def __init__(self, A: np.ndarray, f_max: float, Linv, G, P, c, box) -> None:
        self.A, self.f_max, self.m = A, f_max, A.shape[1]
        self.Linv, self.G, self.P, self.c, self.box = Linv, G, P, c, box
        self.V = G  # the LPs' equilibrated rows V x = r / sigma (daqp_lp, highs_lp)
        self.kernel: tuple | None = None
        self.lp: dict[str, np.ndarray] | None = None

    def reduce(self, W: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(r, off_range) as :meth:`Zonotope.reduce <modquad_gym.oracle.zonotope.Zonotope.reduce>`
        gives them for finite wrenches: nothing is off the range of a full-rank A."""
        if self.f_max != 1.0:
            W = W / self.f_max
        return W @ self.Linv.T - self.c, np.zeros(len(W), dtype=bool)

    def gamma_of_allocation(self, x: np.ndarray, r: np.ndarray) -> float:
        """As :meth:`Zonotope.gamma_of_allocation
        <modquad_gym.oracle.zonotope.Zonotope.gamma_of_allocation>`: x corrected onto G x = r,
        then measured."""
        x = x - self.P @ (self.G @ x - r)
        return float(np.abs(x).max())


def whitened(A: np.ndarray, f_max: float = 1.0) -> WhitenedZonotope | None:
    """The :class:`WhitenedZonotope` of the finite float (6, m) matrix A, or None where A has
    fewer than :data:`MIN_COLUMNS` columns, is rank-deficient or too ill-conditioned for it
    (take the SVD's Zonotope there)."""
    if A.shape[1] < MIN_COLUMNS:
        return None
    ok, Linv, G, P, c, box = _whiten(np.ascontiguousarray(A, dtype=np.float64))
    return WhitenedZonotope(A, f_max, Linv, G, P, c, box) if ok else None


@njit(cache=True)
def _whiten(A):  # pragma: no cover - compiled
    """(ok, L^-1, G = L^-1 A / 2, P = 4 G^T, c = G 1, box = |G| 1) with L L^T = A A^T; ok False
    (the rest empty) when a pivot is not positive or the condition exceeds MAX_CONDITION."""
    n, m = A.shape
    none, empty = np.empty((0, 0)), np.empty(0)
    M = A @ A.T
    L = np.zeros((n, n))
    for j in range(n):
        s = M[j, j]
        for k in range(j):
            s -= L[j, k] * L[j, k]
        if not s > 0.0:
            return False, none, none, none, empty, empty
        L[j, j] = np.sqrt(s)
        for i in range(j + 1, n):
            t = M[i, j]
            for k in range(j):
                t -= L[i, k] * L[j, k]
            L[i, j] = t / L[j, j]
    Linv = np.zeros((n, n))  # lower triangular, by forward substitution
    for i in range(n):
        Linv[i, i] = 1.0 / L[i, i]
        for j in range(i):
            t = 0.0
            for k in range(j, i):
                t += L[i, k] * Linv[k, j]
            Linv[i, j] = -t / L[i, i]
    if np.sqrt(np.sum(L * L) * np.sum(Linv * Linv)) > MAX_CONDITION:
        return False, none, none, none, empty, empty
    G = np.empty((n, m))
    P = np.empty((m, n))
    c = np.zeros(n)
    box = np.zeros(n)
    for i in range(n):
        for j in range(m):
            t = 0.0
            for k in range(i + 1):
                t += Linv[i, k] * A[k, j]
            G[i, j] = 0.5 * t
            P[j, i] = 2.0 * t
            c[i] += G[i, j]
            box[i] += abs(G[i, j])
    return True, Linv, G, P, c, box
