"""Bounded rotor allocation, u in [0, f_max], around a centred exact reference allocation.

``u = u_ref + A^+ (w_des - A u_ref)``, with u_ref the oracle's most centred exact allocation
(:func:`modquad_gym.oracle.allocate`) of the task wrench or of the load estimate; A^+ keeps every
correction in range(A). When u leaves the box by more than ``TOL f_max``, alternating
projections between the box and ``{A u = w_des}`` look for an exact allocation strictly inside.
If there is none, priorities apply: the feed-forward first, then the attitude correction, then
the position correction, each scaled down (its direction kept) until it fits; if even the
feed-forward cannot be allocated (an infeasible load), the bounded least-squares allocation
``min |M^-1 (A u - w_des)| s.t. 0 <= u <= f_max`` (the error measured as acceleration).
"""

from __future__ import annotations

import math

import numpy as np

from modquad_gym.oracle import TOL, allocate
from modquad_gym.sim.hover.linearization import Plant

AP_ITERATIONS = 60  # alternating projections tried before giving up on an exact allocation
AP_MARGIN = 1e-4  # ... into the box shrunk by this fraction of f_max (strictly inside)


class Allocator:
    """Rotor inputs for a desired wrench, always inside the box (module docstring)."""

    def __init__(self, plant: Plant) -> None:
        self.A = plant.A
        self.f_max = plant.f_max
        self.pinv = plant.pinv
        self.tol = TOL * plant.f_max
        self.u_ref = np.full(plant.A.shape[1], plant.f_max / 2.0)
        self.w_ref = plant.A @ self.u_ref
        self.Minv = plant.Minv
        self.MinvA = plant.Minv @ plant.A

    def recentre(self, w: np.ndarray) -> float:
        """Make the most centred exact allocation of w the reference (if w is feasible); return
        the oracle's gamma of w."""
        u, gamma = allocate(self.A, w, self.f_max)
        if math.isfinite(gamma) and gamma <= 1.0 + TOL:
            self.u_ref, self.w_ref = u, self.A @ u
        return gamma

    def in_box(self, u: np.ndarray) -> bool:
        """Every rotor within [0, f_max] up to the tolerance."""
        return bool(np.all(u >= -self.tol) and np.all(u <= self.f_max + self.tol))

    def _interior(self, w: np.ndarray, u: np.ndarray) -> np.ndarray | None:
        """Alternating projections between the box (shrunk by AP_MARGIN f_max) and the affine set
        {A u = w}: an exact allocation strictly inside the box, or None if none is found."""
        lo, hi = AP_MARGIN * self.f_max, (1.0 - AP_MARGIN) * self.f_max
        scale = 1e-9 * (1.0 + float(np.linalg.norm(w)))
        for _ in range(AP_ITERATIONS):
            u = np.clip(u, lo, hi)
            r = w - self.A @ u
            if float(np.linalg.norm(r)) <= scale:
                return u
            u = u + self.pinv @ r
        return None

    def exact(self, w: np.ndarray) -> np.ndarray | None:
        """An allocation of w in the box (around the reference, else strictly inside), or None."""
        u = self.u_ref + self.pinv @ (w - self.w_ref)
        if self.in_box(u):
            return np.clip(u, 0.0, self.f_max)
        return self._interior(w, u)

    def _scaled(self, u0: np.ndarray, dw: np.ndarray) -> np.ndarray:
        """u0 + alpha A^+ dw with the largest alpha in [0, 1] that keeps it in the box."""
        du = self.pinv @ dw
        with np.errstate(divide="ignore", invalid="ignore"):
            room = np.where(du > 0, (self.f_max - u0) / du, np.where(du < 0, -u0 / du, np.inf))
        alpha = float(np.clip(room.min(initial=1.0), 0.0, 1.0))
        return np.clip(u0 + alpha * du, 0.0, self.f_max)

    def __call__(
        self, w_des: np.ndarray, w_ff: np.ndarray, w_att: np.ndarray
    ) -> tuple[np.ndarray, bool]:
        """(u in the box, whether A u = w_des was met).

        ``w_des = w_ff + w_att + w_pos``: feed-forward, attitude correction, position correction;
        priorities as in the module docstring.
        """
        u = self.exact(w_des)
        if u is not None:
            return u, True
        u_ff = self.exact(w_ff)
        if u_ff is None:
            from scipy.optimize import lsq_linear

            res = lsq_linear(self.MinvA, self.Minv @ w_des, bounds=(0.0, self.f_max), method="bvls")
            return np.clip(res.x, 0.0, self.f_max), False
        u_att = self.exact(w_ff + w_att)
        if u_att is None:
            return self._scaled(u_ff, w_att), False
        return self._scaled(u_att, w_des - w_ff - w_att), False

    def saturated(self, u: np.ndarray) -> bool:
        """Some rotor at 0 or f_max (within the tolerance)."""
        return bool(np.any((u <= self.tol) | (u >= self.f_max - self.tol)))
