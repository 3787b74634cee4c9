"""The external load of a hover task: its wrench, how it changes between task wrenches, and how
much room the feasible set leaves past it.

A task wrench w is the *total* wrench the rotors must produce. While it is held, the external
wrench ``d = -(w + gravity wrench)`` (gravity wrench ``[m g ; 0]``, torque-free at the COM) acts
at the COM, so that at equilibrium (level, in place) the rotors produce exactly w. This keeps the
modules' physical weight and the normalised task units independent.

With the load known to the controller, w switches in a step at the start of each segment. With
the load unknown, the load ramps from the previous wrench to the next over the first
``load_ramp_seconds`` of the segment: ``w(t) = w_prev + s(t / T) (w - w_prev)`` with
``s(x) = (1 - cos(pi x)) / 2`` (``"cosine"``: no jump in the load's rate at either end) or
``s(x) = x`` (``"linear"``). The feasible set is convex, so a ramp between two feasible wrenches
stays feasible.

``load_frame`` ``"world"`` (default) keeps ``-w`` fixed in the world, like gravity: when the
structure tilts its rotor wrench turns with it and the load does not (tilting steers the force,
as a quadrotor tilts to translate). ``"body"`` keeps ``-w`` fixed in {S}: the net wrench on the
body is ``A u - w`` whatever the attitude.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from modquad_gym.oracle import ray_lp


def ramp_fraction(s: float, profile: str) -> float:
    """How far (0 to 1) a load ramp has gone at s in [0, 1] of its duration."""
    s = min(max(s, 0.0), 1.0)
    return 0.5 * (1.0 - math.cos(math.pi * s)) if profile == "cosine" else s


@dataclass(frozen=True)
class LoadRamp:
    """The load of one segment: from ``w_from`` to ``w_to`` over the first ``n_ramp`` control
    steps (0: a step), then held."""

    w_from: np.ndarray
    w_to: np.ndarray
    n_ramp: int
    profile: str = "cosine"

    def at(self, step: int) -> np.ndarray:
        """The load's task wrench during control step ``step`` (0-based) of the segment."""
        if step < self.n_ramp:
            frac = ramp_fraction((step + 1) / self.n_ramp, self.profile)
            return self.w_from + frac * (self.w_to - self.w_from)
        return self.w_to

    def changes(self, step: int) -> bool:
        """Whether the load's wrench may differ from the previous step's (a world-fixed load is
        written to the simulator only then)."""
        return step <= self.n_ramp


def external_wrench(
    w: np.ndarray, mass: float, gravity: np.ndarray, R: np.ndarray | None = None
) -> np.ndarray:
    """d (6,) in the world frame: ``-(w + gravity wrench)``, w fixed in the world (R None) or
    in the body (rotated by R)."""
    f, tau = (w[:3], w[3:]) if R is None else (R @ w[:3], R @ w[3:])
    return np.concatenate([-f - mass * gravity, -tau])


def step_headroom(
    A: np.ndarray, w: np.ndarray, w_prev: np.ndarray, f_max: float = 1.0
) -> float | None:
    """How far past w, along the load step w - w_prev, the rotors can still push (wrench units).

    The largest lambda >= 0 with w + lambda (w - w_prev) / |w - w_prev| feasible (the oracle's
    :func:`~modquad_gym.oracle.ray_lp`); None if w itself is infeasible, inf for no step. With
    an unknown load, braking after the step needs a wrench beyond w along it, so a small
    headroom means a large transient, however the controller is tuned.
    """
    d = np.asarray(w, dtype=float) - np.asarray(w_prev, dtype=float)
    if float(np.linalg.norm(d)) < 1e-12:
        return math.inf
    return ray_lp(A, w, d, 0.0, f_max)
