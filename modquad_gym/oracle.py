"""Is a wrench in the feasible-wrench zonotope W = {A u : 0 <= u <= f_max}? (paper Sec. IV)

Everything here works on the *centred, reduced* zonotope. With Q an orthonormal basis of range(A)
(rank r <= 6), a wrench w is feasible exactly when

* its off-range residual ``w - Q Q^T w`` is zero (rank-deficient A: one module has r = 4, a
  straight line of modules r = 5), and
* ``Q^T w = c + G x`` for some x in the cube [-1, 1]^m, where ``c = Q^T A 1 f_max / 2`` is the
  hover-at-half-thrust centre and ``G = Q^T A f_max / 2``.

The number ``gamma(w) = min { ||x||_inf : G x = Q^T w - c }`` says how far the worst rotor must
deviate from half thrust, as a fraction of f_max / 2. ``margin = 1 - gamma`` is therefore unit-free:
1 at the centre, 0 on the boundary of W, negative outside (-inf off range(A)). The paper's own
measure, ``lambda / |w|`` with ``max lambda s.t. A u = lambda w_hat, 0 <= u <= f_max``
(errata 1: an LP, not a QP), is offered as :func:`lambda_ratio` (>= 1 exactly when feasible).

Tolerance: decisions are exact up to ``TOL = 1e-6`` in rotor thrust relative to f_max (the
primal tolerance of the LP solvers; a wrench that needs u_i = (1 + 1e-7) f_max counts as feasible)
and ``RESIDUAL_TOL * (1 + |w|)`` in the off-range residual. Margins within TOL of zero are
snapped to 0, so ``margin >= 0`` and ``feasible`` agree exactly.

Methods (``method=`` in :func:`feasible`, :func:`margin`, :class:`WrenchOracle`):

``"auto"`` (default)
    Certificates first, LP last. A wrench is *accepted* when a cheap x in the cube solves
    G x = r (the minimum-norm solution, then a few alternating projections between the affine set
    and the cube); *rejected* when a direction d separates it, d . r > sum_j |d . g_j| (the
    support function of the centred zonotope), with directions from the coordinate axes, the
    wrench itself, the alternating-projection residual and a per-zonotope cache of directions
    that separated earlier wrenches. Every decision carries a certificate; the few wrenches left
    undecided go to the exact LP (DAQP). Margins always use the exact LP.
``"daqp"``
    One dense active-set LP per wrench (DAQP): the decision LP and the lambda-form margin LP.
``"scipy"``
    HiGHS through ``scipy.optimize.linprog``: the plain reference.
``"cvxpy"``
    The paper's optimisation written as an LP in cvxpy with Parameters (compiled once per shape).
``"hrep"``
    The exact H-representation by hyperplane shifting: one facet normal per independent
    (r-1)-subset of generators; gamma = max over facets |n . r| / sum_j |n . g_j|. Built once per
    zonotope (chunked), then every wrench is a matrix product: for large batches.
``"quickhull"``
    The paper's Algorithm 1 (divide-and-conquer Quickhull on the 0/f_max vertices); exponential,
    allowed for up to 12 generators (3 modules), as a cross-check only.
"""

from __future__ import annotations

import itertools
import math
from collections import OrderedDict
from collections.abc import Hashable

import numpy as np

TOL = 1e-6
"""Rotor-thrust tolerance of every decision, relative to f_max (see module docstring)."""

RESIDUAL_TOL = 1e-9
"""Off-range residual tolerance, relative to 1 + |w|."""

METHODS = ("auto", "daqp", "scipy", "cvxpy", "hrep", "quickhull")

_RANK_TOL = 1e-9
_AP_ITERATIONS = 8
_AP_ROUNDS = 2
_AP_MIN_ROWS = 6
_CACHE_DIRECTIONS = 64
_QUICKHULL_MAX_COLUMNS = 12


# --------------------------------------------------------------------------------------------
# input checking
# --------------------------------------------------------------------------------------------
def check_matrix(A: np.ndarray) -> np.ndarray:
    """A as a float (6, m) array, or a ValueError naming what is wrong."""
    arr = np.asarray(A, dtype=float)
    if arr.ndim != 2 or arr.shape[0] != 6 or arr.shape[1] < 1:
        raise ValueError(
            f"A must be a 6 x m configuration matrix with m >= 1, got shape {arr.shape}"
        )
    if not np.all(np.isfinite(arr)):
        bad = np.argwhere(~np.isfinite(arr))[0]
        raise ValueError(f"A has a non-finite entry at row {bad[0]}, column {bad[1]}")
    return arr


def check_wrenches(W: np.ndarray) -> np.ndarray:
    """W as a float (t, 6) array (a single 6-vector is promoted), or a ValueError."""
    arr = np.asarray(W, dtype=float)
    if arr.ndim == 1:
        arr = arr[None, :]
    if arr.ndim != 2 or arr.shape[1] != 6:
        raise ValueError(f"wrenches must have shape (t, 6) or (6,), got {np.shape(W)}")
    if not np.all(np.isfinite(arr)):
        row = int(np.argwhere(~np.isfinite(arr))[0, 0])
        raise ValueError(f"wrench row {row} is not finite: {arr[row].tolist()}")
    return arr


def check_f_max(f_max: float) -> float:
    f = float(f_max)
    if not (f > 0 and math.isfinite(f)):
        raise ValueError(f"f_max must be a positive, finite thrust, got {f_max!r}")
    return f


def _check_method(method: str) -> str:
    if method not in METHODS:
        raise ValueError(f"unknown method {method!r}; choose one of {', '.join(METHODS)}")
    return method


# --------------------------------------------------------------------------------------------
# the zonotope of one configuration matrix
# --------------------------------------------------------------------------------------------
class Zonotope:
    """The feasible wrenches of one configuration matrix, prepared for many membership tests.

    Holds the range basis, centre, generators and pseudo-inverse, plus lazily built extras (the
    H-representation, a cache of separating directions, DAQP work arrays). Build it once per
    structure and reuse it across wrenches, tasks and episodes (see :class:`WrenchOracle`).
    """

    def __init__(self, A: np.ndarray, f_max: float = 1.0) -> None:
        A = check_matrix(A)
        self.f_max = check_f_max(f_max)
        self.A = A
        self.m = A.shape[1]
        U, S, _ = np.linalg.svd(A, full_matrices=False)
        self.rank = int(np.sum(S > _RANK_TOL * max(S[0], 1.0)))
        self.Q = U[:, : self.rank]  # (6, r) orthonormal basis of range(A)
        B = self.Q.T @ A  # (r, m), full row rank
        self.G = B * (self.f_max / 2.0)  # generators of the centred zonotope
        self.c = B.sum(axis=1) * (self.f_max / 2.0)  # centre, reduced coordinates
        self.P = np.linalg.pinv(self.G)  # (m, r)
        self.GGinv = np.linalg.inv(self.G @ self.G.T)  # dual metric for separating directions
        # one alternating-projection step x <- P r + (I - P G) clip(x), as a right factor
        self._ap_step = (np.eye(self.m) - self.P @ self.G).T
        # cache of separating directions (rows, unit length) and their supports sum_j |d . g_j|
        eye = np.eye(self.rank)
        self._dirs = np.vstack([eye, -eye])
        self._supp = np.abs(self._dirs @ self.G).sum(axis=1)
        self._hrep: tuple[np.ndarray, np.ndarray] | None = None
        self._daqp: dict[str, np.ndarray] | None = None
        self._hull = None

    # --- coordinates ----------------------------------------------------------------------
    def reduce(self, W: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(r, off_range): centred reduced coordinates r = Q^T w - c (t, rank) and a bool (t,)
        that is True where w has a component outside range(A)."""
        b = W @ self.Q
        if self.rank == 6:  # range(A) is all of R^6: nothing is off range
            return b - self.c, np.zeros(len(W), dtype=bool)
        resid = np.linalg.norm(W - b @ self.Q.T, axis=1)
        off = resid > RESIDUAL_TOL * (1.0 + np.linalg.norm(W, axis=1))
        return b - self.c, off

    def support(self, D: np.ndarray) -> np.ndarray:
        """Support function of W in wrench-space directions D (k, 6): max_{w in W} d . w."""
        D = np.atleast_2d(np.asarray(D, dtype=float))
        return np.maximum(D @ self.A, 0.0).sum(axis=1) * self.f_max

    # --- the certified fast path ----------------------------------------------------------
    def _separated(self, R: np.ndarray, D: np.ndarray) -> np.ndarray:
        """Rows of R (t, r) separated from the zonotope by their own direction row of D."""
        proj = np.einsum("ij,ij->i", D, R)
        supp = np.abs(D @ self.G).sum(axis=1)
        return proj > supp * (1.0 + TOL) + 1e-12

    def _remember(self, D: np.ndarray) -> None:
        if not len(D):
            return
        D = D / np.linalg.norm(D, axis=1, keepdims=True)
        dirs = np.vstack([D, self._dirs])[: 2 * self.rank + _CACHE_DIRECTIONS]
        self._dirs = dirs
        self._supp = np.abs(dirs @ self.G).sum(axis=1)

    def decide_certified(self, W: np.ndarray) -> np.ndarray:
        """Exact decisions (t,) by certificates, with the DAQP LP for the undecided rest."""
        R, off = self.reduce(W)
        out = np.zeros(len(W), dtype=bool)
        todo = np.flatnonzero(~off)
        if not len(todo):
            return out
        R = R[todo]
        lim = 1.0 + 2.0 * TOL
        X = R @ self.P.T
        accept = np.abs(X).max(axis=1) <= lim
        # cached directions: one product against every remembered separating direction
        reject = ((R @ self._dirs.T) > self._supp * (1.0 + TOL) + 1e-12).any(axis=1)
        # the wrench's own direction, in plain and dual metric
        und = ~(accept | reject)
        if und.any():
            Ru = R[und]
            rej = self._separated(Ru, Ru) | self._separated(Ru, Ru @ self.GGinv)
            reject[np.flatnonzero(und)[rej]] = True
            und = ~(accept | reject)
        # alternating projections between {x : G x = r} and the cube, in rounds; after each
        # round, accept rows whose affine point lies in the cube and reject rows that the
        # residual direction separates; only the rest go on
        idx = np.flatnonzero(~(accept | reject))
        Xu, X0, Ru = X[idx].copy(), X[idx], R[idx]
        for _ in range(_AP_ROUNDS):
            if len(idx) < _AP_MIN_ROWS:  # a few LPs cost less than the projection rounds
                break
            for _ in range(_AP_ITERATIONS):
                np.minimum(Xu, 1.0, out=Xu)
                np.maximum(Xu, -1.0, out=Xu)
                Xu = Xu @ self._ap_step
                Xu += X0
            ok = np.abs(Xu).max(axis=1) <= lim
            accept[idx[ok]] = True
            E = Ru - np.clip(Xu, -1.0, 1.0) @ self.G.T
            D = E @ self.GGinv
            rej = ~ok & self._separated(Ru, D)
            reject[idx[rej]] = True
            self._remember(D[rej][:4])
            keep = ~(ok | rej)
            idx, Xu, X0, Ru = idx[keep], Xu[keep], X0[keep], Ru[keep]
        und = ~(accept | reject)
        for i in np.flatnonzero(und):
            accept[i] = self.decide_lp_one(R[i])
        out[todo] = accept
        return out

    # --- DAQP -----------------------------------------------------------------------------
    def _daqp_arrays(self) -> dict[str, np.ndarray]:
        if self._daqp is None:
            m, r = self.m, self.rank
            # decision: find x in [-1, 1]^m with G x = r
            dec_A = np.ascontiguousarray(self.G)
            dec_bu = np.concatenate([np.ones(m), np.zeros(r)])
            dec_bl = np.concatenate([-np.ones(m), np.zeros(r)])
            dec_sense = np.array([0] * m + [5] * r, dtype=np.int32)
            # margin, lambda form: max lam s.t. G x = lam r, x in [-1, 1]^m  (gamma = 1 / lam)
            lam_A = np.zeros((r, m + 1))
            lam_A[:, :m] = self.G
            lam_bu = np.concatenate([np.ones(m), [1e30], np.zeros(r)])
            lam_bl = np.concatenate([-np.ones(m), [-1e30], np.zeros(r)])
            lam_sense = np.array([0] * (m + 1) + [5] * r, dtype=np.int32)
            lam_cost = np.zeros(m + 1)
            lam_cost[-1] = -1.0
            self._daqp = dict(
                dec_H=np.zeros((m, m)),
                dec_f=np.zeros(m),
                dec_A=dec_A,
                dec_bu=dec_bu,
                dec_bl=dec_bl,
                dec_sense=dec_sense,
                lam_H=np.zeros((m + 1, m + 1)),
                lam_f=lam_cost,
                lam_A=lam_A,
                lam_bu=lam_bu,
                lam_bl=lam_bl,
                lam_sense=lam_sense,
            )
        return self._daqp

    def decide_lp_one(self, r: np.ndarray) -> bool:
        """Exact decision for one centred reduced wrench r by the DAQP LP (HiGHS if DAQP fails)."""
        import daqp

        a = self._daqp_arrays()
        m = self.m
        a["dec_bu"][m:] = r
        a["dec_bl"][m:] = r
        _, _, flag, _ = daqp.solve(
            a["dec_H"], a["dec_f"], a["dec_A"], a["dec_bu"], a["dec_bl"], a["dec_sense"]
        )
        if flag == 1:
            return True
        if flag == -1:
            return False
        return bool(self.gamma_scipy(r[None])[0] <= 1.0 + TOL)

    def gamma_daqp(self, R: np.ndarray) -> np.ndarray:
        """Exact gamma for each row of R by the lambda-form LP in DAQP."""
        import daqp

        a = self._daqp_arrays()
        out = np.empty(len(R))
        scale = np.linalg.norm(self.G)
        for i, r in enumerate(R):
            nr = np.linalg.norm(r)
            if nr <= 1e-12 * scale:
                out[i] = 0.0
                continue
            a["lam_A"][:, -1] = -r / nr
            x, _, flag, _ = daqp.solve(
                a["lam_H"], a["lam_f"], a["lam_A"], a["lam_bu"], a["lam_bl"], a["lam_sense"]
            )
            if flag == 1 and x[-1] > 0:
                out[i] = nr / x[-1]
            else:
                out[i] = self.gamma_scipy(r[None])[0]
        return out

    def separating_direction(self, r: np.ndarray) -> tuple[float, np.ndarray]:
        """(gamma, d) for one centred reduced wrench r: its exact gamma and a unit direction d
        (reduced coordinates) attaining it, d . r = gamma * sum_j |d . g_j| (a facet normal of
        the zonotope when gamma > 1: a certificate that separates r). From the DAQP LP duals."""
        import daqp

        a = self._daqp_arrays()
        nr = float(np.linalg.norm(r))
        if nr <= 1e-12 * np.linalg.norm(self.G):
            return 0.0, np.zeros(self.rank)
        a["lam_A"][:, -1] = -r / nr
        x, _, flag, info = daqp.solve(
            a["lam_H"], a["lam_f"], a["lam_A"], a["lam_bu"], a["lam_bl"], a["lam_sense"]
        )
        d = -np.asarray(info["lam"][self.m + 1 :], dtype=float)
        nd = np.linalg.norm(d)
        if flag != 1 or x[-1] <= 0 or nd == 0:
            return float(self.gamma_scipy(r[None])[0]), np.zeros(self.rank)
        return nr / float(x[-1]), d / nd

    # --- HiGHS (scipy) reference ----------------------------------------------------------
    def gamma_scipy(self, R: np.ndarray) -> np.ndarray:
        """Exact gamma for each row of R: min s s.t. G x = r, -s <= x_i <= s (HiGHS LP)."""
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
                cost, A_ub=A_ub, b_ub=b_ub, A_eq=A_eq, b_eq=r, bounds=(None, None), method="highs"
            )
            if res.status != 0:  # pragma: no cover - the LP is always feasible and bounded
                raise RuntimeError(f"HiGHS failed on wrench {i}: {res.message}")
            out[i] = res.fun
        return out

    def decide_scipy(self, R: np.ndarray) -> np.ndarray:
        """Exact decisions by the HiGHS feasibility LP: A u = w, 0 <= u <= f_max."""
        from scipy.optimize import linprog

        out = np.empty(len(R), dtype=bool)
        cost = np.zeros(self.m)
        for i, r in enumerate(R):
            res = linprog(cost, A_eq=self.G, b_eq=r, bounds=(-1.0, 1.0), method="highs")
            out[i] = res.status == 0
        return out

    # --- cvxpy reference ------------------------------------------------------------------
    def gamma_cvxpy(self, R: np.ndarray) -> np.ndarray:
        """Exact gamma for each row of R by the paper's LP in cvxpy (Parameters, DPP)."""
        prob, g_par, r_par, s_var = _cvxpy_problem(self.G.shape)
        g_par.value = self.G
        out = np.empty(len(R))
        for i, r in enumerate(R):
            r_par.value = r
            prob.solve()
            out[i] = float(s_var.value)
        return out

    # --- exact H-representation -----------------------------------------------------------
    def hrep(self, chunk: int = 8192) -> tuple[np.ndarray, np.ndarray]:
        """(N, h): unit facet normals (k, r) of the centred zonotope with |n . r| <= h on W.

        Hyperplane shifting: each independent (r-1)-subset of generators spans a hyperplane whose
        normal is their generalised cross product; its offset is the support sum_j |n . g_j|.
        Subsets are processed in chunks, so memory stays bounded for large m.
        """
        if self._hrep is None:
            self._hrep = _hyperplane_shifting(self.G, chunk)
        return self._hrep

    def gamma_hrep(self, R: np.ndarray) -> np.ndarray:
        N, h = self.hrep()
        if not len(N):  # rank 1: the zonotope is a segment
            g = np.abs(self.G).sum()
            return np.abs(R[:, 0]) / g
        return (np.abs(R @ N.T) / h).max(axis=1)

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


def _hyperplane_shifting(G: np.ndarray, chunk: int) -> tuple[np.ndarray, np.ndarray]:
    """Facet normals of the zonotope with generators G (r, m), and their supports.

    Every facet is spanned by r - 1 independent generators. We enumerate (r-2)-subsets S,
    take an orthonormal basis B_S (r, 2) of their orthogonal complement (batched QR), and for
    each later generator g_j the normal of span(S + {g_j}) is B_S rotated: B_S (-p_1, p_0) with
    p = B_S^T g_j. This costs one small QR per (r-2)-subset instead of r determinants per
    (r-1)-subset. Subsets are processed ``chunk`` at a time, so memory stays bounded.
    """
    r, m = G.shape
    if r == 1:
        return np.zeros((0, 1)), np.zeros(0)
    scale = float(np.abs(G).max())
    tol = 1e-9 * scale
    parts = []
    if r == 2:
        parts.append(np.stack([-G[1], G[0]], axis=1))
    else:
        combos = itertools.combinations(range(m), r - 2)
        cols = np.arange(m)
        while True:
            block = np.array(list(itertools.islice(combos, chunk)), dtype=np.intp)
            if not len(block):
                break
            M = G[:, block].transpose(1, 0, 2)  # (k, r, r-2)
            Qc, Rc = np.linalg.qr(M, mode="complete")
            independent = np.abs(np.diagonal(Rc, axis1=1, axis2=2)).min(axis=1) > tol
            B = Qc[independent][:, :, r - 2 :]  # (k, r, 2)
            last = block[independent, -1]
            P = np.einsum("kra,rm->kam", B, G)  # (k, 2, m)
            later = cols[None, :] > last[:, None]  # each (r-1)-subset once
            spans = np.hypot(P[:, 0], P[:, 1]) > tol
            k_idx, j_idx = np.nonzero(later & spans)
            p = P[k_idx, :, j_idx]  # (q, 2)
            n = np.einsum("qra,qa->qr", B[k_idx], np.stack([-p[:, 1], p[:, 0]], axis=1))
            parts.append(n)
    N = np.vstack(parts)
    N /= np.linalg.norm(N, axis=1, keepdims=True)
    # a canonical sign (first clearly non-zero entry positive), then deduplicate
    first = np.argmax(np.abs(N) > 1e-9, axis=1)
    N *= np.sign(N[np.arange(len(N)), first])[:, None]
    rounded = np.ascontiguousarray(np.round(N, 9) + 0.0)
    _, keep = np.unique(rounded.view(np.dtype((np.void, 8 * r))).ravel(), return_index=True)
    N = N[np.sort(keep)]
    h = np.abs(N @ G).sum(axis=1)
    return N, h


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


_CVXPY_CACHE: dict[tuple[int, int], tuple] = {}


def _cvxpy_problem(shape: tuple[int, int]):
    """(problem, G, r, s): a compiled-once cvxpy LP ``min s s.t. G x = r, |x_i| <= s``."""
    if shape not in _CVXPY_CACHE:
        import cvxpy as cp

        r, m = shape
        x = cp.Variable(m)
        s = cp.Variable()
        g_par = cp.Parameter((r, m))
        r_par = cp.Parameter(r)
        prob = cp.Problem(cp.Minimize(s), [g_par @ x == r_par, cp.abs(x) <= s])
        _CVXPY_CACHE[shape] = (prob, g_par, r_par, s)
    return _CVXPY_CACHE[shape]


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


def _gamma(z: Zonotope, W: np.ndarray, method: str) -> np.ndarray:
    R, off = z.reduce(W)
    out = np.full(len(W), np.inf)
    on = ~off
    if on.any():
        fn = {
            "auto": z.gamma_daqp,
            "daqp": z.gamma_daqp,
            "scipy": z.gamma_scipy,
            "cvxpy": z.gamma_cvxpy,
            "hrep": z.gamma_hrep,
            "quickhull": z.gamma_quickhull,
        }[method]
        out[on] = fn(R[on])
    return out


def _decide(z: Zonotope, W: np.ndarray, method: str) -> np.ndarray:
    if method == "auto":
        return z.decide_certified(W)
    if method in ("daqp", "scipy"):
        R, off = z.reduce(W)
        out = np.zeros(len(W), dtype=bool)
        on = np.flatnonzero(~off)
        if method == "daqp":
            out[on] = [z.decide_lp_one(R[i]) for i in on]
        else:
            out[on] = z.decide_scipy(R[on])
        return out
    return _gamma(z, W, method) <= 1.0 + TOL


def _margin(z: Zonotope, W: np.ndarray, method: str) -> np.ndarray:
    m = 1.0 - _gamma(z, W, method)
    m[np.abs(m) <= TOL] = 0.0
    return m


def feasible(A: np.ndarray, W: np.ndarray, f_max: float = 1.0, method: str = "auto") -> np.ndarray:
    """bool (t,): is each wrench (row of W, shape (t, 6)) in W = {A u : 0 <= u <= f_max}?

    Exact up to :data:`TOL` (module docstring). Raises ValueError for a malformed A or W,
    non-finite values or f_max <= 0.
    """
    W = check_wrenches(W)
    return _decide(Zonotope(A, f_max), W, _check_method(method))


def margin(A: np.ndarray, W: np.ndarray, f_max: float = 1.0, method: str = "auto") -> np.ndarray:
    """float (t,): ``1 - gamma`` per wrench, >= 0 exactly when feasible.

    gamma is the smallest s such that some allocation u with A u = w keeps every rotor within
    s * f_max / 2 of half thrust. So the margin is 1 at hover-at-half-thrust, 0 on the boundary,
    negative outside W, and -inf for wrenches off range(A) (rank-deficient structures).
    """
    W = check_wrenches(W)
    return _margin(Zonotope(A, f_max), W, _check_method(method))


def lambda_ratio(A: np.ndarray, W: np.ndarray, f_max: float = 1.0) -> np.ndarray:
    """The paper's measure per wrench: lambda* / |w| with (errata 1, an LP)
    ``max lambda s.t. A u = lambda w_hat, 0 <= u <= f_max``. >= 1 exactly when feasible;
    inf for w = 0; 0 when no positive multiple of w is feasible."""
    from scipy.optimize import linprog

    A = check_matrix(A)
    W = check_wrenches(W)
    f = check_f_max(f_max)
    m = A.shape[1]
    out = np.empty(len(W))
    cost = np.zeros(m + 1)
    cost[-1] = -1.0
    for i, w in enumerate(W):
        nw = np.linalg.norm(w)
        if nw == 0:
            out[i] = np.inf
            continue
        A_eq = np.hstack([A, -(w / nw)[:, None]])
        res = linprog(
            cost, A_eq=A_eq, b_eq=np.zeros(6), bounds=[(0, f)] * m + [(0, None)], method="highs"
        )
        out[i] = res.x[-1] / nw if res.status == 0 else 0.0
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
    )
    x, gamma = res.x[:m], float(res.fun)
    u = (1.0 + x) * (z.f_max / 2.0)
    return np.clip(u, 0.0, z.f_max), gamma
