"""Load estimate for an unknown load: a load observer plus integral action with anti-windup.

The controller is told neither the task wrenches nor when they change. Its feed-forward is
``w_obs + w_hat``:

* ``w_obs``, a first-order disturbance observer of bandwidth ``omega_obs``: over each control
  step, the wrench the rotors would have needed for no acceleration,
  ``A u - [m R^T dv/dt ; J d(omega)/dt + omega x J omega]`` (inputs sent, measured velocities,
  projected onto range(A)), low-pass filtered. At rest it is A u, i.e. the load; it lags a
  changing load by about (rate of change) / ``omega_obs``.
* ``w_hat``, integral action for what the observer misses (here its lag), stepped with the
  gains' integral rate (:func:`.gains.integral_rate`). Anti-windup: it integrates only while the
  allocation is exact (without the observer: while the new estimate stays allocatable).

``omega_obs = 0`` removes the observer: integral action alone then finds the load.
"""

from __future__ import annotations

import math

import numpy as np

from modquad_gym.sim.hover.allocator import Allocator
from modquad_gym.sim.hover.linearization import Plant
from modquad_gym.sim.hover.rotations import cross


class LoadEstimator:
    """The running estimate ``w_obs + w_hat`` of the load (module docstring)."""

    def __init__(self, plant: Plant, omega_obs: float, ctrl_dt: float, w_start: np.ndarray):
        self.plant = plant
        self.ctrl_dt = ctrl_dt
        self.observer = omega_obs > 0
        self.gain = 1.0 - math.exp(-omega_obs * ctrl_dt)  # first-order low-pass per step
        self.reset(w_start)

    def reset(self, w: np.ndarray) -> None:
        """Start over from the estimate w (the take-off trim, or a restart's equilibrium)."""
        self.w_obs = w.copy() if self.observer else np.zeros(6)
        self.w_hat = w - self.w_obs
        self._last = None  # (v, omega, u, R) of the previous control step

    @property
    def estimate(self) -> np.ndarray:
        """The current load estimate (the feed-forward)."""
        return self.w_obs + self.w_hat

    def observe(self, v: np.ndarray, omega: np.ndarray) -> None:
        """Update the observer with the velocities measured after the last input."""
        if not self.observer or self._last is None:
            return
        p = self.plant
        v0, om0, u0, R0 = self._last
        om = 0.5 * (omega + om0)
        acc = np.concatenate(
            [p.mass * (R0.T @ (v - v0)), p.J @ (omega - om0) + self.ctrl_dt * cross(om, p.J @ om)]
        )
        self.w_obs = self.w_obs + self.gain * (p.P @ (p.A @ u0 - acc / self.ctrl_dt) - self.w_obs)

    def sent(self, v: np.ndarray, omega: np.ndarray, u: np.ndarray, R: np.ndarray) -> None:
        """Remember the input sent at this state (the observer's next step uses it)."""
        self._last = (v, omega, u, R)

    def integrate(self, rate: np.ndarray, exact: bool, alloc: Allocator) -> None:
        """Step the integral part by ``rate``, unless that would wind up (module docstring)."""
        w_next = self.w_hat + self.ctrl_dt * rate
        if exact or (not self.observer and alloc.exact(w_next) is not None):
            self.w_hat = w_next
