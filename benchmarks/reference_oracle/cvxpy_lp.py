"""The ``"cvxpy"`` method: the readable reference, the paper's optimisation written as an LP.

``max lambda s.t. B u = o + lambda d_hat, 0 <= u <= f_max`` (errata 1: an LP, not a QP), in cvxpy
with Parameters (DPP, compiled once per shape), in range(A) coordinates (B = Q^T A; the off-range
residual is checked first, as for every method). With o = 0 and d = w it is the paper's literal
LP: ``lambda* >= |w|`` exactly when w is in W (``lambda_ratio(..., method="cvxpy")``). For
decisions and margins the ray starts at the hover wrench instead (o = c, d = w - c): then
``gamma = |w - c| / lambda*``, so one LP gives both the decision (``lambda* >= |w - c| / (1 +
TOL)``, the tolerance rule) and the margin ``1 - gamma``.
"""

from __future__ import annotations

import functools
from typing import TYPE_CHECKING

import numpy as np

from modquad_gym.oracle.lp import HIGHS_OPTIONS
from modquad_gym.oracle.scale import row_norms

if TYPE_CHECKING:
    from modquad_gym.oracle.zonotope import Zonotope

_CVXPY_CACHE: dict[tuple[int, int], tuple] = {}


def cvxpy_problem(shape: tuple[int, int]):
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
        return {"solver": "HIGHS", **HIGHS_OPTIONS}
    return {"solver": "CLARABEL", "tol_gap_abs": 1e-11, "tol_gap_rel": 1e-11, "tol_feas": 1e-11}


def lambda_cvxpy(
    z: Zonotope,
    origins: np.ndarray,
    directions: np.ndarray,
    lo: float = 0.0,
    hi: float | None = None,
) -> tuple[np.ndarray, list]:
    """The paper's LP per row, in range(A) coordinates and units of f_max: ``max lambda
    s.t. B u = o + lambda d_hat, lo <= u <= hi`` with B = Q^T A (hi defaults to 1, i.e.
    f_max). Returns (lambda*, u*), u* in units of f_max."""
    prob, par, lam, u = cvxpy_problem(z.G.shape)
    par["B"].value = z.G * 2.0
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


def ray_cvxpy(z: Zonotope, D: np.ndarray, lo: float, hi: float) -> np.ndarray:
    """The paper's LP from the origin per row d of D: lambda* of :func:`lambda_cvxpy` with o = 0."""
    return lambda_cvxpy(z, np.zeros_like(D), D, lo, hi)[0]


def gamma_cvxpy(z: Zonotope, R: np.ndarray) -> np.ndarray:
    """Exact gamma for each row of R by the paper's LP along the ray from the hover wrench:
    gamma = |r| / lambda* (re-evaluated from the allocation u*)."""
    out = np.zeros(len(R))
    norms = row_norms(R)
    live = np.flatnonzero(norms > 1e-14 * z.scale)
    if len(live):
        origins = np.broadcast_to(z.c, (len(live), z.rank))
        lams, us = lambda_cvxpy(z, origins, R[live])
        for k, i in enumerate(live):
            x = us[k] * 2.0 - 1.0  # G x = lambda r_hat
            out[i] = (
                z.gamma_of_allocation(x * (norms[i] / lams[k]), R[i]) if lams[k] > 0 else np.inf
            )
    return out
