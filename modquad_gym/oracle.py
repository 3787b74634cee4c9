"""Is a wrench in the feasible-wrench zonotope W = {A u : 0 <= u <= f_max}? (paper Sec. IV)

Everything here works on the *centred, reduced* zonotope. With Q an orthonormal basis of range(A)
(rank r <= 6), a wrench w is feasible exactly when

* its off-range residual ``w - Q Q^T w`` is zero (rank-deficient A: one module has r = 4, a
  straight line of modules r = 5), and
* ``Q^T w / f_max = c + G x`` for some x in the cube [-1, 1]^m, where ``c = Q^T A 1 / 2`` is the
  hover-at-half-thrust centre and ``G = Q^T A / 2`` (reduced coordinates are in units of f_max).

The number ``gamma(w) = min { ||x||_inf : G x = Q^T w / f_max - c }`` says how far the worst
rotor must deviate from half thrust, as a fraction of f_max / 2 (the gauge of the zonotope about
its centre). ``margin = 1 - gamma`` is therefore unit-free: 1 at the centre, 0 on the boundary of
W, negative outside (-inf off range(A), or where gamma leaves the float range). The paper's own
measure, ``lambda / |w|`` with ``max lambda s.t. A u = lambda w_hat, 0 <= u <= f_max`` (errata 1:
an LP, not a QP), is offered as
:func:`lambda_ratio` (>= 1 exactly when feasible).

The tolerance rule (one rule, every method)
-------------------------------------------
A wrench w is **feasible** exactly when

1. its off-range residual is at most ``RESIDUAL_TOL * (f_max + |w|)`` (checked once, in
   :meth:`Zonotope.reduce`, for every method), and
2. ``gamma(w) <= 1 + TOL``, with ``TOL = 1e-6``. Equivalently: some allocation ``A u = w`` has
   every rotor in ``[-TOL f_max / 2, (1 + TOL / 2) f_max]``; or: w lies in the zonotope scaled by
   ``1 + TOL`` about its centre.

Every method decides by this rule from its own computed gamma (or from certificates that bound
gamma on one side of ``1 + TOL``). The margin is ``1 - gamma`` with every value whose gamma lies in
``[1 - TOL, 1 + TOL]`` reported as exactly 0, so for every method ``margin >= 0`` exactly when
``feasible`` (:func:`decide_from_gamma`, :func:`margin_from_gamma`; the certified ``"auto"``
decisions and the margin's LP gamma agree outside the band below, and inside it the margin takes
its sign from the decision). :func:`lambda_ratio` applies the same rule.

Scale: wrenches are divided by f_max on entry (:meth:`Zonotope.reduce`), so every answer is the
same for (s W, s f_max) at any scale s whose values are representable (the tests run s from 1e-9
to 1e12). Huge wrenches (torques of 1e200, say) are decided by the exact bounding-box certificate,
and their gamma comes from homogeneity, ``gamma(r) = t gamma(r / t)``: the LPs only ever see
numbers of order one, and no step squares a huge value.

Agreement band: every method computes gamma to better than 1e-9 (LP gammas are re-evaluated from
the returned allocation, so they never undercut the true gamma; HiGHS runs with tightened
tolerances; measured: DAQP within 4e-10 of HiGHS, H-representation and cvxpy within 1e-12), and
every certificate keeps a clearance of ``_GUARD = 1e-8`` from the threshold. So all methods agree
on every wrench with ``|gamma - (1 + TOL)| > BAND = 1e-7``; inside that band the answer depends
on round-off. ``"quickhull"`` (joggled input) is a cross-check only (see its method).

Methods (``method=`` in :func:`feasible`, :func:`margin`, :class:`WrenchOracle`):

``"auto"`` (default)
    Certificates first, LP last. A wrench is *accepted* when an x in the cube solves G x = r
    (the minimum-norm solution, then Douglas-Rachford iterations between the affine set and the
    cube, vectorised over the undecided wrenches); *rejected* when a direction d separates it,
    d . r > (1 + TOL) sum_j |d . g_j| (the support function of the centred zonotope), with d the
    Douglas-Rachford residual in the dual metric or a cached direction that separated an earlier
    wrench of this zonotope. Every certificate is exact (checked in float64) and keeps a clearance
    of ``_GUARD`` from the threshold; the few wrenches left undecided go to the exact LP gamma
    (DAQP). Margins use the exact LP gamma.
``"daqp"``
    One dense active-set LP per wrench (DAQP): ``max lambda s.t. G x = lambda r_hat, |x| <= 1,
    lambda >= 0``, gamma = |r| / lambda re-evaluated from the returned allocation; HiGHS if DAQP
    does not report an optimum.
``"scipy"``
    HiGHS through ``scipy.optimize.linprog`` (``min s s.t. G x = r, |x_i| <= s``): the plain
    reference. Decisions come from its gamma by the rule above (not from HiGHS's own tolerance).
``"cvxpy"``
    The readable reference: the paper's optimisation written correctly as an LP (errata 1),
    ``max lambda s.t. B u = o + lambda d_hat, 0 <= u <= f_max``, in cvxpy with Parameters (DPP,
    compiled once per shape), in range(A) coordinates (B = Q^T A; the off-range residual is
    checked first, as for every method). With o = 0 and d = w it is the paper's literal LP:
    ``lambda* >= |w|`` exactly when w is in W (used by ``lambda_ratio(..., method="cvxpy")``).
    For decisions and margins the ray starts at the hover wrench instead (o = c, d = w - c):
    then ``gamma = |w - c| / lambda*``, so one LP gives both the decision
    (``lambda* >= |w - c| / (1 + TOL)``, the rule above) and the margin ``1 - gamma``.
``"hrep"``
    The exact H-representation by hyperplane shifting: one facet normal per independent
    (r-1)-subset of generators (generalised cross products, all subsets at once by a Laplace
    recursion of minors, chunked); gamma = max over facets |n . r| / sum_j |n . g_j|. Decisions
    first try the cheap exact support-function rejection (no H-representation needed when it
    decides every wrench); margins and the undecided rest use the H-representation, built once per
    zonotope. For large batches against one structure.
``"quickhull"``
    The paper's Algorithm 1 (divide-and-conquer Quickhull on the 0/f_max vertices); exponential,
    allowed for up to 12 generators (3 modules), as a cross-check only.
"""

from __future__ import annotations

import functools
import itertools
import math
from collections import OrderedDict
from collections.abc import Hashable, Iterator

import numpy as np

from .validation import check_f_max, check_matrix, check_wrenches  # noqa: F401 - re-exported

TOL = 1e-6
"""Decision tolerance: feasible when gamma <= 1 + TOL (module docstring, "The tolerance rule")."""

RESIDUAL_TOL = 1e-9
"""Off-range residual tolerance, relative to f_max + |w|."""

BAND = 1e-7
"""Methods agree on every wrench with |gamma - (1 + TOL)| > BAND (floating-point accuracy)."""

METHODS = ("auto", "daqp", "scipy", "cvxpy", "hrep", "quickhull")

_GUARD = 1e-8  # clearance of every certificate from the threshold 1 + TOL
_ACCEPT = 1.0 + TOL - _GUARD  # certificates accept when some |x|_inf <= _ACCEPT
_REJECT = 1.0 + TOL + _GUARD  # ... reject when d . r > _REJECT * sum_j |d . g_j|
_RANK_TOL = 1e-9
_DR_ROUNDS = (10, 20)  # Douglas-Rachford iterations per round, certificates after each
_DR_MIN_ROWS = 4  # with fewer undecided wrenches, LPs cost less than the iterations
_CACHE_DIRECTIONS = 64
_QUICKHULL_MAX_COLUMNS = 12
_HIGHS_OPTIONS = {"primal_feasibility_tolerance": 1e-10, "dual_feasibility_tolerance": 1e-10}
_BIG = 1e150  # rows of w / f_max beyond this are handled without squaring (no overflow)
_FAR = 1e6  # rows beyond this many bounding boxes get their gamma by homogeneity (see _gamma)


# --------------------------------------------------------------------------------------------
# input checking
# --------------------------------------------------------------------------------------------
def _check_method(method: str) -> str:
    if method not in METHODS:
        raise ValueError(f"unknown method {method!r}; choose one of {', '.join(METHODS)}")
    return method


def _row_norms(X: np.ndarray) -> np.ndarray:
    """Euclidean norm of each row of X, without overflow for any finite entries."""
    t = np.abs(X).max(axis=1, initial=0.0) if X.shape[1] else np.zeros(len(X))
    safe = np.where(t > 0.0, t, 1.0)
    Y = X / safe[:, None]
    return t * np.sqrt(np.einsum("ij,ij->i", Y, Y))


MAX_TASK_VALUE = 1e100
"""Largest wrench component (in newtons or newton-metres, and in units of f_max) that
:func:`check_task_scale` accepts: far beyond anything a structure can exert, and small enough
that no step of a search overflows."""


def check_task_scale(W: np.ndarray, f_max: float) -> np.ndarray:
    """W (checked, (t, 6)) when f_max lies in [1e-300, 1e300] and every |w_i| and every
    |w_i| / f_max is at most :data:`MAX_TASK_VALUE`, else a ValueError naming the value. The
    searches call it: they test one task against many structures and multiply and square its
    numbers on the way, where the oracle itself takes any finite value
    (:meth:`Zonotope.reduce`)."""
    W, f_max = check_wrenches(W), check_f_max(f_max)
    if not 1e-300 <= f_max <= 1e300:
        raise ValueError(f"f_max = {f_max:g} is outside 1e-300..1e300 (check the units)")
    if not len(W):
        return W
    with np.errstate(over="ignore", under="ignore"):
        size = np.maximum(np.abs(W), np.abs(W) / f_max).max(axis=1)
    if not size.max() <= MAX_TASK_VALUE:
        row = int(np.argmax(~(size <= MAX_TASK_VALUE)))
        raise ValueError(
            f"wrench row {row} {W[row].tolist()} with f_max = {f_max:g} is beyond "
            f"{MAX_TASK_VALUE:g} (newtons, and times f_max): far beyond what any structure can "
            "exert (check the units)"
        )
    return W


def decide_from_gamma(gamma: np.ndarray) -> np.ndarray:
    """The tolerance rule: feasible exactly when gamma <= 1 + TOL (inf: off range)."""
    return np.asarray(gamma) <= 1.0 + TOL


def margin_from_gamma(gamma: np.ndarray) -> np.ndarray:
    """``1 - gamma``, with 0 wherever gamma lies in [1 - TOL, 1 + TOL]: >= 0 exactly when
    :func:`decide_from_gamma` is True."""
    gamma = np.asarray(gamma, dtype=float)
    band = (gamma >= 1.0 - TOL) & decide_from_gamma(gamma)
    return np.where(band, 0.0, 1.0 - gamma)


# --------------------------------------------------------------------------------------------
# the zonotope of one configuration matrix
# --------------------------------------------------------------------------------------------
class Zonotope:
    """The feasible wrenches of one configuration matrix, prepared for many membership tests.

    Holds the range basis, centre, generators and pseudo-inverse (all from one SVD), plus lazily
    built extras (the H-representation, a cache of separating directions, DAQP work arrays).
    Build it once per structure and reuse it across wrenches, tasks and episodes (see
    :class:`WrenchOracle`).
    """

    def __init__(self, A: np.ndarray, f_max: float = 1.0) -> None:
        A = check_matrix(A)
        self.f_max = check_f_max(f_max)
        self.A = A
        self.m = A.shape[1]
        U, S, Vt = np.linalg.svd(A, full_matrices=False)
        self.rank = r = int(np.count_nonzero(S > _RANK_TOL * max(S[0], 1.0)))
        self.Q = U[:, :r]  # (6, r) orthonormal basis of range(A)
        self._V = V = Vt[:r]  # (r, m) orthonormal rows
        # Reduced coordinates are in units of f_max (the task is normalised at the entry,
        # ``reduce``), so every decision is invariant to scaling the wrenches and f_max together.
        self.sigma = S[:r] / 2.0  # singular values of G
        self._scale = float(self.sigma[0]) if r else 0.0
        self._dual = 1.0 / self.sigma**2  # the dual metric: (G G^T)^-1 is diagonal here
        self.G = self.sigma[:, None] * V  # generators of the centred zonotope, Q^T A / 2
        self.c = self.G.sum(axis=1)  # centre (hover at half thrust), reduced coordinates
        self._axes = np.abs(self.G).sum(axis=1)  # supports of +-e_i: the bounding box
        self.P = V.T / self.sigma  # (m, r) pseudo-inverse of G
        self._step: np.ndarray | None = None  # Douglas-Rachford step, built on first use
        # cache of directions that separated earlier wrenches, with supports sum_j |d . g_j|
        self._dirs: np.ndarray | None = None
        self._supp: np.ndarray | None = None
        self._hrep: tuple[np.ndarray, np.ndarray] | None = None
        self._daqp: dict[str, np.ndarray] | None = None
        self._hull = None

    @property
    def GGinv(self) -> np.ndarray:
        """(G G^T)^-1, diagonal in these coordinates: the dual metric for directions."""
        return np.diag(self._dual)

    # --- coordinates ----------------------------------------------------------------------
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
        resid = _row_norms(Wh - bh @ self.Q.T)
        off = lost | (resid > RESIDUAL_TOL * (1.0 / scale + _row_norms(Wh)))
        return b - self.c, off

    def support(self, D: np.ndarray) -> np.ndarray:
        """Support function of W in wrench-space directions D (k, 6): max_{w in W} d . w."""
        D = np.atleast_2d(np.asarray(D, dtype=float))
        return np.maximum(D @ self.A, 0.0).sum(axis=1) * self.f_max

    # --- certificates ---------------------------------------------------------------------
    def _separated(self, R: np.ndarray, D: np.ndarray) -> np.ndarray:
        """Rows of R (t, r) that their own direction row of D separates from the zonotope
        scaled by 1 + TOL + _GUARD: an exact certificate that gamma > 1 + TOL."""
        proj = np.einsum("ij,ij->i", D, R)
        return proj > np.abs(D @ self.G).sum(axis=1) * _REJECT

    def _remember(self, D: np.ndarray) -> None:
        """Put directions D (k, r) (any length: the tests are scale-free) first in the cache of
        directions that separated earlier wrenches."""
        supp = np.abs(D @ self.G).sum(axis=1)
        if self._dirs is None:
            self._dirs, self._supp = D, supp
        else:
            keep = _CACHE_DIRECTIONS - len(D)
            self._dirs = np.concatenate([D, self._dirs[:keep]])
            self._supp = np.concatenate([supp, self._supp[:keep]])

    def reject_by_cache(self, R: np.ndarray) -> np.ndarray:
        """bool (t,): rows of R separated by a cached direction (one that separated an earlier
        wrench). Exact: True means gamma > 1 + TOL."""
        if self._dirs is None:
            return np.zeros(len(R), dtype=bool)
        return ((R @ self._dirs.T) > self._supp * _REJECT).any(axis=1)

    def reject_by_box(self, R: np.ndarray) -> np.ndarray:
        """bool (t,): rows of R outside the zonotope's bounding box (the supports of the
        coordinate axes) scaled by 1 + TOL + _GUARD. Exact, and free of overflow for any
        finite R: every row it keeps is bounded by the box."""
        return (np.abs(R) > self._axes * _REJECT).any(axis=1)

    def reject_by_support(self, R: np.ndarray) -> np.ndarray:
        """bool (t,): rows of R (centred reduced wrenches) that a cheap direction separates: the
        cached directions, the coordinate axes (the left singular vectors of A) and the wrench's
        own direction in the plain and the dual metric. Exact: True means gamma > 1 + TOL."""
        reject = self.reject_by_box(R) | self.reject_by_cache(R)
        rest = np.flatnonzero(~reject)
        if len(rest):
            Ru = R[rest]
            k = len(rest)
            D = np.concatenate([Ru, Ru * self._dual])  # plain and dual metric
            proj = np.einsum("ij,ij->i", D, np.concatenate([Ru, Ru]))
            sep = proj > np.abs(D @ self.G).sum(axis=1) * _REJECT
            reject[rest[sep[:k] | sep[k:]]] = True
        return reject

    def decide_certified(self, W: np.ndarray) -> np.ndarray:
        """Exact decisions (t,) by certificates, with the DAQP LP for the undecided rest."""
        R, off = self.reduce(W)
        if not off.any():
            return self.decide_reduced(R)
        out = np.zeros(len(W), dtype=bool)
        todo = np.flatnonzero(~off)
        if len(todo):
            out[todo] = self.decide_reduced(R[todo])
        return out

    def decide_reduced(self, R: np.ndarray) -> np.ndarray:
        """Exact decisions for centred reduced wrenches R (t, rank) that lie in range(A)."""
        outside = self.reject_by_box(R)
        if outside.any():  # the rest is bounded by the box: no overflow below
            accept = np.zeros(len(R), dtype=bool)
            inside = np.flatnonzero(~outside)
            if len(inside):
                accept[inside] = self.decide_reduced(R[inside])
            return accept
        X0 = R @ self.P.T  # minimum-norm allocations
        accept = np.abs(X0).max(axis=1) <= _ACCEPT
        if accept.all():
            return accept
        idx = np.flatnonzero(~accept)
        if self._dirs is not None:  # directions that separated earlier wrenches
            idx = idx[~self.reject_by_cache(R[idx])]
        learned = []
        # Douglas-Rachford between {x : G x = r} and the cube, in rounds; after each round,
        # accept rows whose affine point lies in the cube and reject rows that the residual
        # direction separates (in the dual metric); only the rest go on
        if len(idx) >= _DR_MIN_ROWS:
            m = self.m
            step = self._dr_step()
            # transposed, so that Z and B are contiguous blocks of C = [Z; B] (2m, k)
            X0t, Rt = X0[idx].T.copy(), R[idx].T
            C = np.empty((2 * m, len(idx)))
            C[:m] = X0t
            T = np.empty_like(X0t)
            for n_iter in _DR_ROUNDS:
                Z, B = C[:m], C[m:]
                for _ in range(n_iter):
                    # Z <- Z + P_affine(2 B - Z) - B = step [Z; B] + x0, with B = P_cube(Z)
                    np.maximum(Z, -1.0, out=B)
                    np.minimum(B, 1.0, out=B)
                    np.matmul(step, C, out=T)
                    np.add(T, X0t, out=Z)
                np.maximum(Z, -1.0, out=B)
                np.minimum(B, 1.0, out=B)
                E = Rt - self.G @ B  # residual of the cube point B (r, k)
                X = self.P @ E
                X += B  # the affine point nearest to B
                ok = np.abs(X).max(axis=0) <= _ACCEPT
                D = E * self._dual[:, None]
                rej = np.einsum("ik,ik->k", D, Rt) > np.abs(self.G.T @ D).sum(axis=0) * _REJECT
                accept[idx[ok]] = True
                if rej.any():
                    learned.append(D[:, rej][:, :2].T)
                keep = ~(ok | rej)
                if keep.all():
                    continue
                idx, C, X0t, Rt, T = idx[keep], C[:, keep], X0t[:, keep], Rt[:, keep], T[:, keep]
                if len(idx) < _DR_MIN_ROWS:
                    break
        for i in idx:  # the few undecided rows: the exact LP
            accept[i], d = self._decide_lp(R[i])
            if d is not None and len(learned) < 4:
                learned.append(d[None])
        if learned:
            self._remember(np.vstack(learned)[:4])
        return accept

    def _dr_step(self) -> np.ndarray:
        """(m, 2m): one Douglas-Rachford step as a left factor of [Z; B] (columns are rows):
        Z + P_affine(2 B - Z) - B - x0 = (I - N) Z + (2 N - I) B, N the null(G) projector."""
        if self._step is None:
            m = self.m
            step = np.empty((m, 2 * m))
            row = np.matmul(self._V.T, self._V, out=step[:, :m])  # row-space projector, I - N
            np.multiply(row, -2.0, out=step[:, m:])
            step[:, m:] += np.eye(m)
            self._step = step
        return self._step

    # --- DAQP -----------------------------------------------------------------------------
    def _daqp_arrays(self) -> dict[str, np.ndarray]:
        if self._daqp is None:
            m, r = self.m, self.rank
            # gamma: max lam s.t. G x = lam r_hat, x in [-1, 1]^m, lam >= 0 (gamma = |r| / lam);
            # the bound lam >= 0 (always feasible) makes DAQP several times faster than a free lam
            lam_A = np.empty((r, m + 1))
            lam_A[:, :m] = self.G
            self._daqp = dict(_daqp_constants(m, r), A=lam_A)
        return self._daqp

    def _decide_lp(self, r: np.ndarray) -> tuple[bool, np.ndarray | None]:
        """Exact decision for one centred reduced wrench r by the DAQP LP gamma and the rule.
        Returns (feasible, a separating direction when infeasible, else None)."""
        gamma, d = self._gamma_lp(r)
        ok = bool(gamma <= 1.0 + TOL)
        return ok, (None if ok else d)

    def _gamma_of(self, x: np.ndarray, r: np.ndarray) -> float:
        """gamma bound from an allocation x with G x ~ r: corrected onto G x = r exactly (up to
        round-off) and measured, so it never undercuts the true gamma."""
        x = x - self.P @ (self.G @ x - r)
        return float(np.abs(x).max())

    def _gamma_lp(self, r: np.ndarray) -> tuple[float, np.ndarray | None]:
        """(gamma, d) for one centred reduced wrench r by the DAQP LP: gamma re-evaluated from the
        returned allocation (an upper bound, within 1e-9 of HiGHS: measured <= 4e-10), d the dual
        direction (about a facet normal, or None). HiGHS when DAQP does not report an optimum."""
        import daqp

        nr = float(np.linalg.norm(r))
        if nr <= 1e-14 * self._scale:
            return 0.0, None
        a = self._daqp_arrays()
        a["A"][:, -1] = -r / nr
        x, _, flag, info = daqp.solve(a["H"], a["f"], a["A"], a["bu"], a["bl"], a["sense"])
        lam = float(x[-1]) if flag == 1 else 0.0
        if lam <= 0.0:
            return float(self.gamma_scipy(r[None])[0]), None
        d = -np.asarray(info["lam"][self.m + 1 :], dtype=float)
        return self._gamma_of(x[: self.m] * (nr / lam), r), d

    def decide_lp_one(self, r: np.ndarray) -> bool:
        """Exact decision for one centred reduced wrench r by the DAQP LP gamma."""
        return bool(self._gamma_lp(r)[0] <= 1.0 + TOL)

    def gamma_daqp(self, R: np.ndarray) -> np.ndarray:
        """Exact gamma for each row of R by the lambda-form LP in DAQP."""
        return np.array([self._gamma_lp(r)[0] for r in R], dtype=float)

    def separating_direction(self, r: np.ndarray) -> tuple[float, np.ndarray]:
        """(gamma, d) for one centred reduced wrench r: its exact gamma and a unit direction d
        (reduced coordinates) from the LP duals; when gamma > 1 + TOL, d is (close to) a facet
        normal, d . r ~ gamma * sum_j |d . g_j|. Callers must test d before relying on it."""
        gamma, d = self._gamma_lp(r)
        if d is None or not np.any(d):
            return gamma, np.zeros(self.rank)
        return gamma, d / np.linalg.norm(d)

    # --- HiGHS (scipy) reference ----------------------------------------------------------
    def gamma_scipy(self, R: np.ndarray) -> np.ndarray:
        """Exact gamma for each row of R: min s s.t. G x = r, -s <= x_i <= s (HiGHS LP with
        tightened tolerances, gamma re-evaluated from the allocation)."""
        from scipy.optimize import linprog

        m = self.m
        cost = np.zeros(m + 1)
        cost[-1] = 1.0
        eye = np.eye(m)
        col = -np.ones((m, 1))
        A_ub = np.vstack([np.hstack([eye, col]), np.hstack([-eye, col])])
        b_ub = np.zeros(2 * m)
        A_eq = np.hstack([self.G, np.zeros((self.rank, 1))])
        out = np.empty(len(R))
        for i, r in enumerate(R):
            res = linprog(
                cost,
                A_ub=A_ub,
                b_ub=b_ub,
                A_eq=A_eq,
                b_eq=r,
                bounds=(None, None),
                method="highs",
                options=_HIGHS_OPTIONS,
            )
            if res.status != 0:  # pragma: no cover - the LP is always feasible and bounded
                raise RuntimeError(f"HiGHS failed on wrench {i}: {res.message}")
            out[i] = self._gamma_of(res.x[:m], r)
        return out

    def decide_scipy(self, R: np.ndarray) -> np.ndarray:
        """Decisions by the HiGHS gamma and the tolerance rule (rows of R in range(A))."""
        return decide_from_gamma(self.gamma_scipy(R))

    # --- cvxpy reference: the paper's LP ---------------------------------------------------
    def lambda_cvxpy(
        self, origins: np.ndarray, directions: np.ndarray, lo: float = 0.0, hi: float | None = None
    ) -> tuple[np.ndarray, list]:
        """The paper's LP per row, in range(A) coordinates and units of f_max: ``max lambda
        s.t. B u = o + lambda d_hat, lo <= u <= hi`` with B = Q^T A (hi defaults to 1, i.e.
        f_max). Returns (lambda*, u*), u* in units of f_max."""
        prob, par, lam, u = _cvxpy_problem(self.G.shape)
        par["B"].value = self.G * 2.0
        par["lo"].value = float(lo)
        par["hi"].value = 1.0 if hi is None else float(hi)
        lams, us = np.empty(len(origins)), []
        for i, (o, d) in enumerate(zip(origins, directions)):
            par["o"].value = o
            par["d"].value = d / np.linalg.norm(d)
            prob.solve(**_cvxpy_solver())
            if prob.status not in ("optimal", "optimal_inaccurate"):  # pragma: no cover
                raise RuntimeError(f"cvxpy failed on row {i}: {prob.status}")
            lams[i] = float(lam.value)
            us.append(np.asarray(u.value, dtype=float))
        return lams, us

    def gamma_cvxpy(self, R: np.ndarray) -> np.ndarray:
        """Exact gamma for each row of R by the paper's LP along the ray from the hover wrench:
        gamma = |r| / lambda* (re-evaluated from the allocation u*)."""
        out = np.zeros(len(R))
        norms = _row_norms(R)
        live = np.flatnonzero(norms > 1e-14 * self._scale)
        if len(live):
            origins = np.broadcast_to(self.c, (len(live), self.rank))
            lams, us = self.lambda_cvxpy(origins, R[live])
            for k, i in enumerate(live):
                x = us[k] * 2.0 - 1.0  # G x = lambda r_hat
                out[i] = self._gamma_of(x * (norms[i] / lams[k]), R[i]) if lams[k] > 0 else np.inf
        return out

    # --- exact H-representation -----------------------------------------------------------
    def hrep(self, chunk: int = 1 << 16) -> tuple[np.ndarray, np.ndarray]:
        """(N, h): unit facet normals (k, r) of the centred zonotope with |n . r| <= h on W.

        Hyperplane shifting: each independent (r-1)-subset of generators spans a hyperplane whose
        normal is their generalised cross product; its offset is the support sum_j |n . g_j|.
        Normals are produced and deduplicated ``chunk`` at a time, so memory stays bounded.
        """
        if self._hrep is None:
            self._hrep = _hyperplane_shifting(self.G, chunk)
        return self._hrep

    def gamma_hrep(self, R: np.ndarray, rows: int = 1 << 20) -> np.ndarray:
        N, h = self.hrep()
        if not len(N):  # rank <= 1: the zonotope is a segment (or a point)
            return np.abs(R).sum(axis=1) / max(np.abs(self.G).sum(), 1e-300)
        step = max(1, rows // len(N))  # bounded (rows x facets) products
        out = np.empty(len(R))
        for a in range(0, len(R), step):
            out[a : a + step] = (np.abs(R[a : a + step] @ N.T) / h).max(axis=1)
        return out

    def decide_hrep(self, R: np.ndarray) -> np.ndarray:
        """Decisions for rows of R in range(A): the cheap exact support-function rejection
        first, then the H-representation (built only if some row is left)."""
        out = np.zeros(len(R), dtype=bool)
        rest = np.flatnonzero(~self.reject_by_support(R))
        if len(rest):
            out[rest] = decide_from_gamma(self.gamma_hrep(R[rest]))
        return out

    # --- the paper's Algorithm 1 ----------------------------------------------------------
    def gamma_quickhull(self, R: np.ndarray) -> np.ndarray:
        """Gamma from the convex hull of the 0/f_max vertices (Algorithm 1), m <= 12 only."""
        if self.m > _QUICKHULL_MAX_COLUMNS:
            raise ValueError(
                f"quickhull is exponential; it is allowed for at most {_QUICKHULL_MAX_COLUMNS} "
                f"generators (3 modules), got {self.m}"
            )
        if self._hull is None:
            pts = _divide_and_conquer_vertices(2.0 * self.G)  # vertices of W - 0, reduced
            from scipy.spatial import ConvexHull

            # joggled input: the 0/1 vertex sets are highly degenerate in 6-d
            hull = ConvexHull(pts - self.G.sum(axis=1), qhull_options="QJ")  # centred at c
            eq = hull.equations  # n . x + off <= 0 inside, off < 0 since 0 is interior
            self._hull = (eq[:, :-1], -eq[:, -1])
        N, h = self._hull
        return (R @ N.T / h).max(axis=1)


@functools.cache
def _daqp_constants(m: int, r: int) -> dict[str, np.ndarray]:
    """The parts of the DAQP gamma LP that depend only on the shape (shared, never written)."""
    cost = np.zeros(m + 1)
    cost[-1] = -1.0
    return dict(
        H=np.zeros((m + 1, m + 1)),
        f=cost,
        bu=np.concatenate([np.ones(m), [1e30], np.zeros(r)]),
        bl=np.concatenate([-np.ones(m), [0.0], np.zeros(r)]),
        sense=np.array([0] * (m + 1) + [5] * r, dtype=np.int32),
    )


# --------------------------------------------------------------------------------------------
# hyperplane shifting: all generalised cross products at once
# --------------------------------------------------------------------------------------------
_LAPLACE: dict[tuple[int, int], tuple] = {}


def _laplace_table(r: int, k: int) -> tuple:
    """Laplace expansion of every k x k minor along its last column, as a scatter table.

    For the k-row subsets R of range(r) (lexicographic) and the (k-1)-row subsets:
    ``det M[R, :k] = sum sign * M[row, k-1] * det M[sub, :k-1]`` over the entries
    (sub, dst = index of R, row, sign). Returns (sub, dst, row, sign, n_sub, n_dst).
    """
    key = (r, k)
    if key not in _LAPLACE:
        prev = {s: i for i, s in enumerate(itertools.combinations(range(r), k - 1))}
        sets = list(itertools.combinations(range(r), k))
        entries = [
            (prev[s[:t] + s[t + 1 :]], q, s[t], (-1.0) ** (t + k - 1))
            for q, s in enumerate(sets)
            for t in range(k)
        ]
        sub, dst, row, sign = (np.array(col) for col in zip(*entries))
        _LAPLACE[key] = (sub.astype(np.intp), dst.astype(np.intp), row, sign, len(prev), len(sets))
    return _LAPLACE[key]


def _extend_minors(
    G: np.ndarray, last: np.ndarray, minors: np.ndarray, k: int
) -> Iterator[tuple[int, int, np.ndarray]]:
    """Minors of the k-subsets of columns, from those of the (k-1)-subsets.

    ``minors`` (p, C(r, k-1)) holds every (k-1)-row minor of each (k-1)-subset of columns, whose
    last columns ``last`` are sorted. A k-subset is a (k-1)-subset plus a later column s, so for
    each s the parents are a prefix (``cnt`` rows) and their children's minors are one matrix
    product, ``minors[:cnt] @ T`` with T (C(r, k-1), C(r, k)) built from column s. Yields
    (s, cnt, T); the children come out ordered by their last column.
    """
    sub, dst, row, sign, n_sub, n_dst = _laplace_table(G.shape[0], k)
    T = np.zeros((n_sub, n_dst))
    for s in range(G.shape[1]):
        cnt = int(np.searchsorted(last, s))
        if cnt:
            T[sub, dst] = sign * G[row, s]
            yield s, cnt, T


def _hyperplane_shifting(G: np.ndarray, chunk: int = 1 << 16) -> tuple[np.ndarray, np.ndarray]:
    """Facet normals of the zonotope with generators G (r, m), and their supports.

    Every facet is spanned by r - 1 independent generators; its normal is their generalised
    cross product, n_i = (-1)^i det(M without row i) for M = G[:, subset] (r, r-1). All of them
    come from a Laplace recursion: the (k x k)-minors of every k-subset of columns are matrix
    products of the (k-1)-minors (:func:`_extend_minors`), level by level up to r - 2; the last
    level maps straight to the normals in blocks of at most ``chunk``. Zero normals (dependent
    subsets) are dropped, the rest normalised to a canonical sign and deduplicated by hashing
    (verified by a second hash, exact fallback), a chunk at a time: memory stays bounded.
    """
    r, m = G.shape
    if r <= 1:
        return np.zeros((0, r)), np.zeros(0)
    tol = 1e-9 * float(np.abs(G).max()) ** (r - 1)
    dedupe = _Deduplicator(r, tol, chunk)
    if r == 2:
        dedupe.add(np.stack([-G[1], G[0]], axis=1))
    else:
        last, minors = np.arange(m), np.ascontiguousarray(G.T)
        for k in range(2, r - 1):
            n_dst = math.comb(r, k)
            out = np.empty((math.comb(m, k), n_dst))
            new_last = np.empty(len(out), dtype=np.intp)
            at = 0
            for s, cnt, T in _extend_minors(G, last, minors, k):
                np.matmul(minors[:cnt], T, out=out[at : at + cnt])
                new_last[at : at + cnt] = s
                at += cnt
            last, minors = new_last, out
        # (r-1)-row subsets in lexicographic order miss row r-1, r-2, ..., 0
        perm = np.arange(r)[::-1]
        sgn = (-1.0) ** np.arange(r)
        for _, cnt, T in _extend_minors(G, last, minors, r - 1):
            Tn = T[:, perm] * sgn
            for a in range(0, cnt, chunk):
                dedupe.add(minors[a : min(cnt, a + chunk)] @ Tn)
    N = dedupe.result()
    h = np.empty(len(N))
    for a in range(0, len(N), chunk):  # supports, a chunk of facets at a time
        h[a : a + chunk] = np.abs(N[a : a + chunk] @ G).sum(axis=1)
    return N, h


_SIGN_DIRECTION = np.random.default_rng(7).standard_normal(6)
_HASH = np.random.default_rng(8).standard_normal((6, 2))


class _Deduplicator:
    """Collects normals (rows), drops zero ones, normalises them to unit length and a canonical
    sign, and keeps one per direction (rounded to 1e-9). Memory: the unique rows plus one chunk."""

    def __init__(self, r: int, tol: float, chunk: int) -> None:
        self.r, self.tol, self.chunk = r, tol, chunk
        self.buf: list[np.ndarray] = []
        self.size = 0
        self.kept = np.zeros((0, r))

    def add(self, N: np.ndarray) -> None:
        self.buf.append(N)
        self.size += len(N)
        if self.size >= self.chunk:
            self._flush()

    def _flush(self) -> None:
        if not self.buf:
            return
        N = np.vstack(self.buf) if len(self.buf) > 1 else self.buf[0]
        self.buf, self.size = [], 0
        norm = np.sqrt(np.einsum("ij,ij->i", N, N))
        live = norm > self.tol
        if not live.all():
            N, norm = N[live], norm[live]
        N /= np.where(N @ _SIGN_DIRECTION[: self.r] < 0.0, -norm, norm)[:, None]
        if len(self.kept):
            N = np.vstack([self.kept, N])
        self.kept = N[_unique_rows(N)]

    def result(self) -> np.ndarray:
        self._flush()
        return self.kept


def _unique_rows(N: np.ndarray) -> np.ndarray:
    """Sorted indices of one row per distinct row of N after rounding to 1e-9.

    Rows are grouped by a hash (a random projection of the rounded row, whose low bits carry the
    row index so that one plain sort does it) and every group is verified by a second,
    independent projection; if any disagrees, rows are compared exactly instead."""
    n, r = N.shape
    K = N * 1e9
    np.rint(K, out=K)
    h = K @ _HASH[:r]  # (n, 2)
    bits = max(1, int(n - 1).bit_length())
    low = np.uint64((1 << bits) - 1)
    packed = np.ascontiguousarray(h[:, 0]).view(np.uint64) & ~low
    packed |= np.arange(n, dtype=np.uint64)
    packed.sort()
    idx = (packed & low).astype(np.intp)
    group = packed >> np.uint64(bits)
    start = np.ones(n, dtype=bool)
    np.not_equal(group[1:], group[:-1], out=start[1:])
    first = idx[np.maximum.accumulate(np.where(start, np.arange(n), 0))]
    if not np.array_equal(h[first, 1], h[idx, 1]):  # a collision of the first hash
        rows = np.ascontiguousarray(K).view(np.dtype((np.void, 8 * r))).ravel()
        return np.sort(np.unique(rows, return_index=True)[1])
    return np.sort(idx[start])


def _divide_and_conquer_vertices(A: np.ndarray) -> np.ndarray:
    """Vertices of {A u : u in {0,1}^m} by the paper's recursion (hull of Minkowski sums)."""
    from scipy.spatial import ConvexHull, QhullError

    m = A.shape[1]
    if m == 1:
        return np.vstack([np.zeros(A.shape[0]), A[:, 0]])
    left = _divide_and_conquer_vertices(A[:, : (m + 1) // 2])
    right = _divide_and_conquer_vertices(A[:, (m + 1) // 2 :])
    pts = (left[:, None, :] + right[None, :, :]).reshape(-1, A.shape[0])
    pts = np.unique(np.round(pts, 12), axis=0)
    try:
        return pts[ConvexHull(pts, qhull_options="QJ").vertices]
    except (QhullError, ValueError):  # lower-dimensional so far: keep every point
        return pts


# --------------------------------------------------------------------------------------------
# cvxpy: the paper's LP with Parameters, compiled once per shape
# --------------------------------------------------------------------------------------------
_CVXPY_CACHE: dict[tuple[int, int], tuple] = {}


def _cvxpy_problem(shape: tuple[int, int]):
    """(problem, parameters, lambda, u) for the paper's LP (errata 1) in range(A) coordinates:

        max lambda  s.t.  B u = o + lambda d_hat,  lo <= u <= hi

    with Parameters B (r, m) = Q^T A, o, d_hat (r,) and scalars lo, hi. It is DPP (parameters
    enter affinely, lambda * d_hat is parameter times variable), so cvxpy compiles it once per
    shape and every later solve only substitutes the parameter values.
    """
    if shape not in _CVXPY_CACHE:
        import cvxpy as cp

        r, m = shape
        u = cp.Variable(m)
        lam = cp.Variable()
        par = {
            "B": cp.Parameter((r, m)),
            "o": cp.Parameter(r),
            "d": cp.Parameter(r),
            "lo": cp.Parameter(),
            "hi": cp.Parameter(),
        }
        constraints = [par["B"] @ u == par["o"] + lam * par["d"], u >= par["lo"], u <= par["hi"]]
        prob = cp.Problem(cp.Maximize(lam), constraints)
        assert prob.is_dpp()
        _CVXPY_CACHE[shape] = (prob, par, lam, u)
    return _CVXPY_CACHE[shape]


@functools.cache
def _cvxpy_solver() -> dict:
    """HiGHS (simplex: vertex solutions) with tightened tolerances when cvxpy has it."""
    import cvxpy as cp

    if "HIGHS" in cp.installed_solvers():
        return {"solver": "HIGHS", **_HIGHS_OPTIONS}
    return {"solver": "CLARABEL", "tol_gap_abs": 1e-11, "tol_gap_rel": 1e-11, "tol_feas": 1e-11}


# --------------------------------------------------------------------------------------------
# the oracle: cached zonotopes, decisions and margins
# --------------------------------------------------------------------------------------------
class WrenchOracle:
    """Feasibility and margins of task wrenches for many structures, with a per-structure cache.

    Args:
        f_max: maximum thrust per rotor (N, normalised to 1 in the paper).
        method: one of :data:`METHODS` (see the module docstring); ``"auto"`` is the default.
        cache_size: how many prepared zonotopes to keep (least recently used are dropped).

    ``calls`` counts the wrench-structure tests made (one per wrench per structure).
    """

    def __init__(self, f_max: float = 1.0, method: str = "auto", cache_size: int = 4096) -> None:
        self.f_max = check_f_max(f_max)
        self.method = _check_method(method)
        self.cache_size = int(cache_size)
        self._cache: OrderedDict[Hashable, Zonotope] = OrderedDict()
        self.calls = 0

    def zonotope(self, A: np.ndarray, key: Hashable | None = None) -> Zonotope:
        """The prepared zonotope of A, cached under ``key`` (e.g. a structure's key)."""
        if key is None:
            return Zonotope(A, self.f_max)
        z = self._cache.get(key)
        if z is None:
            z = Zonotope(A, self.f_max)
            self._cache[key] = z
            if len(self._cache) > self.cache_size:
                self._cache.popitem(last=False)
        else:
            self._cache.move_to_end(key)
        return z

    def feasible(self, A: np.ndarray, W: np.ndarray, key: Hashable | None = None) -> np.ndarray:
        W = check_wrenches(W)
        z = self.zonotope(A, key)
        self.calls += len(W)
        return _decide(z, W, self.method)

    def margin(self, A: np.ndarray, W: np.ndarray, key: Hashable | None = None) -> np.ndarray:
        W = check_wrenches(W)
        z = self.zonotope(A, key)
        self.calls += len(W)
        return _margin(z, W, self.method)


_GAMMA = {
    "auto": Zonotope.gamma_daqp,
    "daqp": Zonotope.gamma_daqp,
    "scipy": Zonotope.gamma_scipy,
    "cvxpy": Zonotope.gamma_cvxpy,
    "hrep": Zonotope.gamma_hrep,
    "quickhull": Zonotope.gamma_quickhull,
}


def _gamma(z: Zonotope, W: np.ndarray, method: str) -> np.ndarray:
    """gamma per wrench by ``method`` (inf off range(A)).

    gamma is positively homogeneous in the centred reduced wrench r, so a row far outside the
    zonotope (beyond ``_FAR`` times its bounding box: huge torques, say) is solved as
    ``t * gamma(r / t)`` with t = max |r_i|, and the LPs only ever see numbers of order one."""
    R, off = z.reduce(W)
    out = np.full(len(W), np.inf)
    on = np.flatnonzero(~off)
    if len(on):
        R = R[on]
        t = np.abs(R).max(axis=1)
        far = t > _FAR * max(float(z._axes.max()), 1e-300)
        if far.any():
            R = R.copy()
            R[far] /= t[far, None]
        g = _GAMMA[method](z, R)
        with np.errstate(over="ignore"):
            g[far] *= t[far]
        out[on] = g
    return out


def _decide(z: Zonotope, W: np.ndarray, method: str) -> np.ndarray:
    if method == "auto":
        return z.decide_certified(W)
    if method == "hrep":
        R, off = z.reduce(W)
        out = np.zeros(len(W), dtype=bool)
        on = np.flatnonzero(~off)
        if len(on):
            out[on] = z.decide_hrep(R[on])
        return out
    return decide_from_gamma(_gamma(z, W, method))


def _margin(z: Zonotope, W: np.ndarray, method: str) -> np.ndarray:
    gamma = _gamma(z, W, method)
    out = margin_from_gamma(gamma)
    if method == "auto":
        # the certified decisions and the LP gamma agree unless gamma is within the LP's
        # accuracy of 1 + TOL; there the certificate wins, so the sign always matches feasible()
        ok = z.decide_certified(W)
        out[ok & (out < 0)] = 0.0
        out[~ok & (out >= 0)] = np.nextafter(-TOL, -np.inf)
    return out


def feasible(A: np.ndarray, W: np.ndarray, f_max: float = 1.0, method: str = "auto") -> np.ndarray:
    """bool (t,): is each wrench (row of W, shape (t, 6)) in W = {A u : 0 <= u <= f_max}?

    Exact up to the tolerance rule of the module docstring: on range(A) (residual at most
    ``RESIDUAL_TOL * (1 + |w|)``) and gamma <= 1 + :data:`TOL`. Raises ValueError for a
    malformed A or W, non-finite values or f_max <= 0.
    """
    W = check_wrenches(W)
    return _decide(Zonotope(A, f_max), W, _check_method(method))


def margin(A: np.ndarray, W: np.ndarray, f_max: float = 1.0, method: str = "auto") -> np.ndarray:
    """float (t,): ``1 - gamma`` per wrench, >= 0 exactly when feasible.

    gamma is the smallest s such that some allocation u with A u = w keeps every rotor within
    s * f_max / 2 of half thrust. So the margin is 1 at hover-at-half-thrust, 0 on the boundary
    (and for every gamma in [1 - TOL, 1 + TOL], the tolerance band), negative outside W, and -inf
    for wrenches off range(A) (rank-deficient structures) or so large that 1 - gamma leaves the
    float range. The same for (s W, s f_max) at any scale s.
    """
    W = check_wrenches(W)
    return _margin(Zonotope(A, f_max), W, _check_method(method))


def lambda_ratio(
    A: np.ndarray, W: np.ndarray, f_max: float = 1.0, method: str = "scipy"
) -> np.ndarray:
    """The paper's measure per wrench: lambda* / |w| with (errata 1, an LP)
    ``max lambda s.t. A u = lambda w_hat, lo <= u <= hi``, solved by HiGHS (``method="scipy"``)
    or the cvxpy problem (``method="cvxpy"``).

    The same tolerance rule as :func:`feasible`: the thrust bounds are widened to
    ``[-TOL f_max / 2, (1 + TOL / 2) f_max]`` (the zonotope scaled by 1 + TOL about its centre),
    so lambda_ratio >= 1 exactly when ``feasible`` (its sign is taken from ``feasible`` for the
    wrenches where the two LPs' round-off disagree: within :data:`BAND` of the threshold).
    inf for w = 0; 0 when no positive multiple of w is feasible (e.g. off range(A)).
    """
    if method not in ("scipy", "cvxpy"):
        raise ValueError(f"lambda_ratio supports method 'scipy' or 'cvxpy', got {method!r}")
    W = check_wrenches(W)
    z = Zonotope(A, f_max)
    lo, hi = -TOL / 2.0, 1.0 + TOL / 2.0  # in units of f_max, as z's reduced coordinates
    norms = _row_norms(W)
    out = np.full(len(W), np.inf)
    _, off = z.reduce(W)
    out[off] = 0.0
    live = np.flatnonzero(~off & (norms > 0))
    if len(live):
        # directions in range(A) coordinates, each scaled to max |d_i| = 1 (the ratio
        # lambda / |d| does not depend on the length of d, and the LP sees numbers of order one)
        D = W[live] @ z.Q
        D /= np.abs(D).max(axis=1, keepdims=True)
        if method == "cvxpy":
            lams = z.lambda_cvxpy(np.zeros_like(D), D, lo, hi)[0]
        else:
            lams = _lambda_highs(z.G * 2.0, D, lo, hi)
        # lambda* is in units of f_max: the ratio is lambda* / (|w| / f_max)
        with np.errstate(over="ignore", divide="ignore"):
            out[live] = lams / (_row_norms(W[live] @ z.Q) / z.f_max)
    ok = _decide(z, W, "auto")
    out[ok & (out < 1.0)] = 1.0
    out[~ok & (out >= 1.0)] = np.nextafter(1.0, 0.0)
    return out


def ray_lp(
    B: np.ndarray,
    origin: np.ndarray,
    direction: np.ndarray,
    lo: float,
    hi: float,
    options: dict | None = None,
) -> float | None:
    """The LP behind :func:`lambda_ratio` and the hover's step headroom: the largest
    ``lambda >= 0`` with ``B u = origin + lambda direction / |direction|`` for some
    ``lo <= u <= hi`` (HiGHS), or None when no such u exists even at lambda = 0."""
    from scipy.optimize import linprog

    r, m = B.shape
    cost = np.zeros(m + 1)
    cost[-1] = -1.0
    d = np.asarray(direction, dtype=float)
    res = linprog(
        cost,
        A_eq=np.hstack([B, -(d / np.linalg.norm(d))[:, None]]),
        b_eq=np.asarray(origin, dtype=float),
        bounds=[(lo, hi)] * m + [(0, None)],
        method="highs",
        options=options,
    )
    if res.status == 3:  # unbounded: impossible with a bounded u; guard anyway
        return math.inf
    return float(res.x[-1]) if res.status == 0 else None


def _lambda_highs(B: np.ndarray, D: np.ndarray, lo: float, hi: float) -> np.ndarray:
    """max lambda s.t. B u = lambda d_hat, lo <= u <= hi per row d of D (HiGHS)."""
    zero = np.zeros(B.shape[0])
    out = np.empty(len(D))
    for i, d in enumerate(D):
        lam = ray_lp(B, zero, d, lo, hi, _HIGHS_OPTIONS)
        out[i] = 0.0 if lam is None else lam
    return out


def allocate(A: np.ndarray, w: np.ndarray, f_max: float = 1.0) -> tuple[np.ndarray, float]:
    """The most centred exact allocation for one wrench: (u, gamma) with A u = w and every rotor
    within gamma * f_max / 2 of half thrust. When gamma > 1 the wrench is infeasible and u is
    the least-squares allocation clipped to [0, f_max] (what the rotors can do)."""
    z = Zonotope(A, f_max)
    w = check_wrenches(w)[0]
    R, off = z.reduce(w[None])
    if off[0]:
        u = np.clip(np.linalg.lstsq(z.A, w, rcond=None)[0], 0.0, z.f_max)
        return u, math.inf
    from scipy.optimize import linprog

    m = z.m
    cost = np.zeros(m + 1)
    cost[-1] = 1.0
    eye = np.eye(m)
    col = -np.ones((m, 1))
    res = linprog(
        cost,
        A_ub=np.vstack([np.hstack([eye, col]), np.hstack([-eye, col])]),
        b_ub=np.zeros(2 * m),
        A_eq=np.hstack([z.G, np.zeros((z.rank, 1))]),
        b_eq=R[0],
        bounds=(None, None),
        method="highs",
        options=_HIGHS_OPTIONS,
    )
    x, gamma = res.x[:m], float(res.fun)
    u = (1.0 + x) * (z.f_max / 2.0)
    return np.clip(u, 0.0, z.f_max), gamma
