"""The ``"daqp"`` method: one dense active-set LP per wrench (DAQP).

The ray LP of :mod:`modquad_gym.oracle.lp` on the equilibrated rows ``V x = rho``: ``G x = r``
with row i divided by its singular value (``G = sigma V``, ``rho = r / sigma``, V with orthogonal
rows of equal norm), so that DAQP's absolute tolerances mean the same at every scale and
condition of A; and the cube [-1, 1]: ``max lambda s.t. V x = lambda rho_hat, |x| <= 1,
lambda >= 0``; gamma = |rho| / lambda, re-evaluated from the returned allocation (an upper
bound; its accuracy: :mod:`~modquad_gym.oracle.tolerance`). HiGHS
(:mod:`modquad_gym.oracle.highs_lp`) when DAQP does not report an optimum. The LP's duals give a
separating direction, which the certified method and the searches reuse.
"""

from __future__ import annotations

import functools
from typing import TYPE_CHECKING

import numpy as np

from modquad_gym.oracle.highs_lp import gamma_highs
from modquad_gym.oracle.lp import ray_cost, ray_matrix
from modquad_gym.oracle.tolerance import TOL

if TYPE_CHECKING:
    from modquad_gym.oracle.zonotope import Zonotope


RECHECK = TOL
"""DAQP gammas in ``(1 + TOL, 1 + TOL + RECHECK]`` are recomputed by HiGHS: DAQP's are upper
bounds (re-evaluated from its allocation) but its proximal iterations leave them up to 1.3e-7
high on the stock 64-module lattice (:mod:`~modquad_gym.oracle.tolerance`), which must not
reject a feasible wrench."""


@functools.cache
def _daqp_constants(m: int, r: int) -> dict[str, np.ndarray]:
    """The parts of the DAQP gamma LP that depend only on the shape (shared, never written):
    bounds [-1, 1] on x, lambda >= 0 (always feasible: several times faster than a free
    lambda), and r equality rows with right-hand side 0."""
    return dict(
        H=np.zeros((m + 1, m + 1)),
        f=ray_cost(m),
        bu=np.concatenate([np.ones(m), [1e30], np.zeros(r)]),
        bl=np.concatenate([-np.ones(m), [0.0], np.zeros(r)]),
        sense=np.array([0] * (m + 1) + [5] * r, dtype=np.int32),
    )


def _daqp_arrays(z: Zonotope) -> dict[str, np.ndarray]:
    """The DAQP work arrays of z (built once; the last column of A is set per wrench)."""
    if z.lp is None:
        z.lp = dict(_daqp_constants(z.m, z.rank), A=ray_matrix(z.V, np.zeros(z.rank)))
    return z.lp


def gamma_and_direction(z: Zonotope, r: np.ndarray) -> tuple[float, np.ndarray | None]:
    """(gamma, d) for one centred reduced wrench r by the DAQP LP: gamma re-evaluated from the
    returned allocation, d the dual direction (about a facet normal, or None)."""
    import daqp

    if float(np.linalg.norm(r)) <= 1e-14 * z.scale:
        return 0.0, None
    rho = r / z.sigma  # the equilibrated right-hand side: V x = rho
    nr = float(np.linalg.norm(rho))
    a = _daqp_arrays(z)
    a["A"][:, -1] = -rho / nr
    x, _, flag, info = daqp.solve(a["H"], a["f"], a["A"], a["bu"], a["bl"], a["sense"])
    lam = float(x[-1]) if flag == 1 else 0.0
    if lam <= 0.0:
        return float(gamma_highs(z, r[None])[0]), None
    d = -np.asarray(info["lam"][z.m + 1 :], dtype=float) / z.sigma  # duals of G x = r
    return z.gamma_of_allocation(x[: z.m] * (nr / lam), r), d


def gamma_daqp(z: Zonotope, R: np.ndarray) -> np.ndarray:
    """Exact gamma for each row of R (centred reduced wrenches in range(A)) by DAQP; the
    smaller of DAQP's and HiGHS's (both upper bounds) just above the threshold (RECHECK)."""
    out = np.array([gamma_and_direction(z, r)[0] for r in R], dtype=float)
    near = np.flatnonzero((out > 1.0 + TOL) & (out <= 1.0 + TOL + RECHECK))
    if len(near):
        out[near] = np.minimum(out[near], gamma_highs(z, R[near]))
    return out
