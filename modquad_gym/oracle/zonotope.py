"""The feasible-wrench zonotope of one configuration matrix, in centred reduced coordinates.

With Q an orthonormal basis of range(A) (rank r <= 6), a wrench w is feasible exactly when its
off-range residual ``w - Q Q^T w`` is zero (rank-deficient A: one module has r = 4, a straight
line of modules r = 5) and ``Q^T w / f_max = c + G x`` for some x in the cube [-1, 1]^m, where
``c = Q^T A 1 / 2`` is the hover-at-half-thrust centre and ``G = Q^T A / 2`` (reduced coordinates
are in units of f_max). The methods (:mod:`modquad_gym.oracle.backends`) work on ``r = Q^T w /
f_max - c`` as :meth:`Zonotope.reduce` returns it.

The rank r counts A's singular values above ``1e-9`` times the largest (relative to A's own
scale, so that (s A, f_max / s), the same wrench set, has the same zonotope; all zero: rank 0,
only w = 0 reachable). A direction cut this way carries at most ``1e-9 |A|`` per unit thrust,
which the off-range rule (relative to f_max + |w|, not to |A|) need not forgive: see
:mod:`~modquad_gym.oracle.tolerance` for what that and A's condition number mean for accuracy.
"""

from __future__ import annotations

import numpy as np

from modquad_gym.core.validation import check_f_max, check_matrix, check_wrenches
from modquad_gym.oracle.backends import decide_with
from modquad_gym.oracle.daqp_lp import gamma_and_direction
from modquad_gym.oracle.scale import row_norms
from modquad_gym.oracle.tolerance import RESIDUAL_TOL

_RANK_TOL = 1e-9
_BIG = 1e150  # rows of w / f_max beyond this are handled without squaring (no overflow)


class Zonotope:
    """The feasible wrenches of one configuration matrix, prepared for many membership tests.

    Holds the range basis ``Q``, centre ``c``, generators ``G`` (r, m) with their orthonormal
    rows ``V`` and singular values ``sigma``, the pseudo-inverse ``P`` of G, the dual metric
    ``dual`` (the diagonal of (G G^T)^-1) and the bounding box ``box`` (the supports of the
    coordinate axes), all from one SVD. Two fields are filled on first use, once per zonotope:
    ``kernel`` (the compiled certificates' arrays and the directions where earlier wrenches
    were decided, :mod:`.compiled`) and ``lp`` (the DAQP LP's work arrays, :mod:`.daqp_lp`).
    Build it once per structure and reuse it across wrenches, tasks and episodes (see
    :class:`~modquad_gym.oracle.WrenchOracle`).
    """

    def __init__(self, A: np.ndarray, f_max: float = 1.0) -> None:
        A = check_matrix(A)
        self.f_max = check_f_max(f_max)
        self.A = A
        self.m = A.shape[1]
        U, S, Vt = np.linalg.svd(A, full_matrices=False)
        self.rank = r = int(np.count_nonzero(S > _RANK_TOL * S[0]))  # scale-free; A = 0: 0
        self.Q = U[:, :r]  # (6, r) orthonormal basis of range(A)
        self.V = V = Vt[:r]  # (r, m) orthonormal rows
        # Reduced coordinates are in units of f_max (the task is normalised at the entry,
        # ``reduce``), so every decision is invariant to scaling the wrenches and f_max together.
        self.sigma = S[:r] / 2.0  # singular values of G
        self.scale = float(self.sigma[0]) if r else 0.0
        self.dual = 1.0 / self.sigma**2  # the dual metric: (G G^T)^-1 is diagonal here
        self.G = self.sigma[:, None] * V  # generators of the centred zonotope, Q^T A / 2
        self.c = self.G.sum(axis=1)  # centre (hover at half thrust), reduced coordinates
        self.box = np.abs(self.G).sum(axis=1)  # supports of +-e_i: the bounding box
        self.P = V.T / self.sigma  # (m, r) pseudo-inverse of G
        self.kernel: tuple | None = None
        self.lp: dict[str, np.ndarray] | None = None

    def reduce(self, W: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(r, off_range): centred reduced coordinates r = Q^T w / f_max - c (t, rank), in units
        of f_max, and a bool (t,) that is True where w has a component outside range(A).

        This is the oracle's entry: wrenches are divided by f_max here, so every decision and
        margin is the same for (s W, s f_max) at any scale s. A row whose w / f_max leaves the
        float range counts as off range (infeasible, gamma = inf)."""
        if self.f_max != 1.0:
            with np.errstate(over="ignore"):
                W = W / self.f_max
        if not len(W) or -_BIG <= W.min() and W.max() <= _BIG:  # common: nothing can overflow
            b = W @ self.Q
            if self.rank == 6:  # range(A) is all of R^6: nothing is off range
                return b - self.c, np.zeros(len(W), dtype=bool)
            E = W - b @ self.Q.T
            resid = np.sqrt(np.einsum("ij,ij->i", E, E))
            off = resid > RESIDUAL_TOL * (1.0 + np.sqrt(np.einsum("ij,ij->i", W, W)))
            return b - self.c, off
        # huge rows: work on w / t (t = max |w_i|, so entries of order one), then scale back
        t = np.abs(W).max(axis=1)
        lost = ~np.isfinite(t)
        scale = np.where((t > 1.0) & ~lost, t, 1.0)
        Wh = np.where(lost[:, None], 0.0, W) / scale[:, None]
        bh = Wh @ self.Q
        with np.errstate(over="ignore"):
            b = bh * scale[:, None]
        lost |= ~np.isfinite(b).all(axis=1)
        b[lost] = 0.0
        if self.rank == 6:
            return b - self.c, lost
        resid = row_norms(Wh - bh @ self.Q.T)
        off = lost | (resid > RESIDUAL_TOL * (1.0 / scale + row_norms(Wh)))
        return b - self.c, off

    def gamma_of_allocation(self, x: np.ndarray, r: np.ndarray) -> float:
        """gamma bound from an allocation x with G x ~ r: corrected onto G x = r exactly (up to
        round-off) and measured, so it never undercuts the true gamma."""
        x = x - self.P @ (self.G @ x - r)
        return float(np.abs(x).max())

    def decide_certified(self, W: np.ndarray) -> np.ndarray:
        """Exact decisions (t,) for wrenches W (t, 6) by certificates, with the DAQP LP for the
        undecided rest (the ``"auto"`` method, :mod:`modquad_gym.oracle.compiled`). W is
        checked as :func:`~modquad_gym.oracle.feasible` checks it (a NaN row is a ValueError)."""
        return decide_with(self, check_wrenches(W), "auto")

    def separating_direction(self, r: np.ndarray) -> tuple[float, np.ndarray]:
        """(gamma, d) for one centred reduced wrench r: its exact gamma and a unit direction d
        (reduced coordinates) from the LP duals; when gamma > 1 + TOL, d is (close to) a facet
        normal, d . r ~ gamma * sum_j |d . g_j|. Callers must test d before relying on it."""
        gamma, d = gamma_and_direction(self, r)
        if d is None or not np.any(d):
            return gamma, np.zeros(self.rank)
        return gamma, d / np.linalg.norm(d)
