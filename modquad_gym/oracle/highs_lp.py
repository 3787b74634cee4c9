"""The ``"scipy"`` method: HiGHS through ``scipy.optimize.linprog``, the plain reference.

gamma is the gamma LP of :mod:`modquad_gym.oracle.lp` (``min s s.t. G x = r, |x_i| <= s``) with
tightened tolerances, on the equilibrated rows ``V x = r / sigma`` (as :mod:`.daqp_lp`: HiGHS's
absolute feasibility tolerance then means the same at every scale and condition of A),
re-evaluated from the allocation. Decisions come from its gamma by the tolerance rule (not from
HiGHS's own tolerance).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from modquad_gym.oracle.lp import HIGHS_OPTIONS, GammaLP, ray_lp

if TYPE_CHECKING:
    from modquad_gym.oracle.zonotope import Zonotope


def gamma_highs(z: Zonotope, R: np.ndarray) -> np.ndarray:
    """Exact gamma for each row of R (centred reduced wrenches in range(A)) by HiGHS."""
    lp = GammaLP.build(z.V)
    out = np.empty(len(R))
    for i, r in enumerate(R):
        res = lp.solve(r / z.sigma)
        if res.status == 0:
            out[i] = z.gamma_of_allocation(res.x[: z.m], r)
        else:  # always feasible and bounded: a numerical failure (ill-conditioned A)
            out[i] = _walked(z, r, res.message)
    return out


def _walked(z: Zonotope, r: np.ndarray, why: str) -> float:
    """gamma of r by the compiled walk (:mod:`.kernels`), where HiGHS reported no optimum;
    a ValueError naming A's condition number where the walk gives up too."""
    from modquad_gym.oracle import kernels  # numba: compiled on first use, cached on disk

    G, P, k = kernels.walk_view(z)
    out = np.full(1, np.nan)
    R = np.ascontiguousarray(r[None] * k, dtype=float)
    kernels.gamma_rows(G, P, kernels.prepare(G, P), R, np.inf, out, np.empty((0, z.rank)))
    if np.isnan(out[0]):
        raise ValueError(condition_error(z, f"HiGHS: {why}; the compiled walk gave up too"))
    return float(out[0])


def condition_error(z: Zonotope, why: str) -> str:
    """A one-line message for an LP that failed on z's matrix: why, and A's condition number
    (that of the reduced generators G: the ratio of A's largest and smallest kept singular
    values), against the oracle's accuracy domain."""
    S = np.linalg.svd(z.G, compute_uv=False)
    cond = S[0] / S[-1] if len(S) and S[-1] > 0 else np.inf
    return (
        f"A: the oracle's LP failed on this matrix ({why}); its condition number is {cond:.3g} "
        "(the oracle is accurate to condition numbers of about 1e6: modquad_gym.oracle.tolerance)"
    )


def ray_highs(z: Zonotope, D: np.ndarray, lo: float, hi: float) -> np.ndarray:
    """The paper's LP from the origin per row d of D (range(A) coordinates, units of f_max):
    max lambda s.t. B u = lambda d_hat, lo <= u <= hi with B = Q^T A (HiGHS); 0 where even
    lambda = 0 has no such u. Solved on the equilibrated rows ``2 V u = lambda d_hat / sigma``
    (as :func:`gamma_highs`): the ray LP's lambda along ``e = (d_hat / sigma) / |d_hat / sigma|``
    is lambda |d_hat / sigma|."""
    B = z.V * 2.0
    zero = np.zeros(B.shape[0])
    out = np.empty(len(D))
    for i, d in enumerate(D):
        e = d / np.linalg.norm(d) / z.sigma
        lam = ray_lp(B, zero, e, lo, hi, HIGHS_OPTIONS)
        out[i] = 0.0 if lam is None else lam / np.linalg.norm(e)
    return out
