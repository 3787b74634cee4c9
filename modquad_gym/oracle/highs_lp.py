"""The ``"scipy"`` method: HiGHS through ``scipy.optimize.linprog``, the plain reference.

gamma is the gamma LP of :mod:`modquad_gym.oracle.lp` (``min s s.t. G x = r, |x_i| <= s``) with
tightened tolerances, re-evaluated from the allocation. Decisions come from its gamma by the
tolerance rule (not from HiGHS's own tolerance).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from modquad_gym.oracle.lp import HIGHS_OPTIONS, GammaLP, ray_lp

if TYPE_CHECKING:
    from modquad_gym.oracle.zonotope import Zonotope


def gamma_highs(z: Zonotope, R: np.ndarray) -> np.ndarray:
    """Exact gamma for each row of R (centred reduced wrenches in range(A)) by HiGHS."""
    lp = GammaLP.build(z.G)
    out = np.empty(len(R))
    for i, r in enumerate(R):
        res = lp.solve(r)
        if res.status != 0:  # pragma: no cover - the LP is always feasible and bounded
            raise RuntimeError(f"HiGHS failed on wrench {i}: {res.message}")
        out[i] = z.gamma_of_allocation(res.x[: z.m], r)
    return out


def ray_highs(z: Zonotope, D: np.ndarray, lo: float, hi: float) -> np.ndarray:
    """The paper's LP from the origin per row d of D (range(A) coordinates, units of f_max):
    max lambda s.t. B u = lambda d_hat, lo <= u <= hi with B = Q^T A (HiGHS); 0 where even
    lambda = 0 has no such u."""
    B = z.G * 2.0
    zero = np.zeros(B.shape[0])
    out = np.empty(len(D))
    for i, d in enumerate(D):
        lam = ray_lp(B, zero, d, lo, hi, HIGHS_OPTIONS)
        out[i] = 0.0 if lam is None else lam
    return out
