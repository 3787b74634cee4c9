"""The oracle's two linear programs, built in one place for every caller.

* The **gamma LP** ``min s s.t. G x = r, -s <= x_i <= s`` (:class:`GammaLP`): the gamma of a
  centred reduced wrench r and its most centred allocation. Solved by HiGHS for the ``"scipy"``
  method and for :func:`~modquad_gym.oracle.allocate`.
* The **ray LP** ``max lambda s.t. B u = o + lambda d_hat, lo <= u <= hi, lambda >= 0``
  (:func:`ray_cost`, :func:`ray_matrix`, :func:`ray_lp`): the paper's measure (errata 1: an LP,
  not a QP). :func:`~modquad_gym.oracle.lambda_ratio` solves it from o = 0, the DAQP method with
  B = G and the cube [-1, 1], and the hover's step headroom from the current wrench.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

HIGHS_OPTIONS = {"primal_feasibility_tolerance": 1e-10, "dual_feasibility_tolerance": 1e-10}
"""HiGHS tolerances tightened (absolute: the oracle's LPs run on equilibrated rows): its gamma
is within 5e-11 of the exact one on stock structures (:mod:`~modquad_gym.oracle.tolerance`)."""


def ray_cost(m: int) -> np.ndarray:
    """Cost of the ray LP over the variables (u (m,), lambda): minimise -lambda."""
    cost = np.zeros(m + 1)
    cost[-1] = -1.0
    return cost


def ray_matrix(B: np.ndarray, d_hat: np.ndarray) -> np.ndarray:
    """Equality rows of the ray LP, ``[B, -d_hat]`` (r, m + 1): B u - lambda d_hat = o."""
    return np.hstack([B, -np.asarray(d_hat, dtype=float)[:, None]])


def ray_lp(
    B: np.ndarray,
    origin: np.ndarray,
    direction: np.ndarray,
    lo: float,
    hi: float,
    options: dict | None = None,
) -> float | None:
    """The ray LP behind :func:`~modquad_gym.oracle.lambda_ratio` and the hover's step headroom:
    the largest ``lambda >= 0`` with ``B u = origin + lambda direction / |direction|`` for some
    ``lo <= u <= hi`` (HiGHS), or None when no such u exists even at lambda = 0."""
    from scipy.optimize import linprog

    m = B.shape[1]
    d = np.asarray(direction, dtype=float)
    res = linprog(
        ray_cost(m),
        A_eq=ray_matrix(B, d / np.linalg.norm(d)),
        b_eq=np.asarray(origin, dtype=float),
        bounds=[(lo, hi)] * m + [(0, None)],
        method="highs",
        options=options,
    )
    if res.status == 3:  # unbounded: impossible with a bounded u; guard anyway
        return math.inf
    return float(res.x[-1]) if res.status == 0 else None


@dataclass(frozen=True)
class GammaLP:
    """``min s s.t. G x = r, -s <= x_i <= s`` over (x (m,), s) for generators G (r, m): the
    smallest s such that some x in the cube [-s, s]^m reaches r, i.e. gamma(r)."""

    cost: np.ndarray
    A_ub: np.ndarray
    b_ub: np.ndarray
    A_eq: np.ndarray

    @classmethod
    def build(cls, G: np.ndarray) -> GammaLP:
        rank, m = G.shape
        cost = np.zeros(m + 1)
        cost[-1] = 1.0
        eye = np.eye(m)
        col = -np.ones((m, 1))
        A_ub = np.vstack([np.hstack([eye, col]), np.hstack([-eye, col])])
        A_eq = np.hstack([G, np.zeros((rank, 1))])
        return cls(cost, A_ub, np.zeros(2 * m), A_eq)

    def solve(self, r: np.ndarray):
        """HiGHS's result (scipy OptimizeResult) for one r: x = res.x[:-1], s = res.fun."""
        from scipy.optimize import linprog

        return linprog(
            self.cost,
            A_ub=self.A_ub,
            b_ub=self.b_ub,
            A_eq=self.A_eq,
            b_eq=r,
            bounds=(None, None),
            method="highs",
            options=HIGHS_OPTIONS,
        )
