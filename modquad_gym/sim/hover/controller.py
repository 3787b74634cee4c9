"""The hover controller: gains, allocator and (unknown load) load estimator put together.

Desired wrench ``w_des = w_ff + w_att + w_pos``: feed-forward plus the gains' attitude and
position corrections (:func:`.gains.corrections`), allocated with priorities
(:class:`.allocator.Allocator`). With the load known, ``w_ff`` is the task wrench and the gains
are designed at it once per segment. With the load unknown, ``w_ff`` is the estimate
(:class:`.estimator.LoadEstimator`), which starts at the take-off trim; the gains are
rescheduled on it at most every ``RESCHEDULE_S`` seconds, when it moved by over
``RESCHEDULE_REL`` of its size.
"""

from __future__ import annotations

import numpy as np

from modquad_gym.oracle import allocate
from modquad_gym.sim.hover.allocator import Allocator
from modquad_gym.sim.hover.config import HoverConfig
from modquad_gym.sim.hover.estimator import LoadEstimator
from modquad_gym.sim.hover.gains import Design, corrections, design_gains, integral_rate
from modquad_gym.sim.hover.linearization import Plant

RESCHEDULE_S = 0.25  # unknown load: shortest time between two gain designs
RESCHEDULE_REL = 0.05  # unknown load: redesign when the estimate moved by this fraction


class HoverController:
    """Turns a measured state into rotor inputs (module docstring)."""

    def __init__(self, plant: Plant, cfg: HoverConfig, ctrl_dt: float) -> None:
        self.plant = plant
        self.cfg = cfg
        self.gains = cfg.gains
        self.alloc = Allocator(plant)
        w_trim = plant.trim
        self.estimator = (
            None if cfg.known_load else LoadEstimator(plant, cfg.gains.omega_obs, ctrl_dt, w_trim)
        )
        self.alloc.recentre(w_trim)
        self.des = self._design(w_trim)
        self.t_design = 0.0
        self.kinds = {self.des.kind}

    def _design(self, w: np.ndarray) -> Design:
        p = self.plant
        integral = self.estimator is not None
        return design_gains(p.A, w, p.mass, p.J, self.gains, self.cfg.load_frame, integral)

    def begin_segment(self, w: np.ndarray) -> float:
        """A new task wrench: the oracle's gamma of it (with a known load, also the reference
        allocation and the gains at it; an unknown load is not announced to the controller)."""
        if self.estimator is None:
            gamma = self.alloc.recentre(w)
            self.des = self._design(w)
        else:
            gamma = allocate(self.plant.A, w, self.plant.f_max)[1]  # for the report only
        self.kinds = {self.des.kind}
        return gamma

    def reschedule(self, t_now: float) -> None:
        """Unknown load: redesign the gains at the estimate when it has moved (module doc)."""
        if self.estimator is None or t_now - self.t_design < RESCHEDULE_S - 1e-12:
            return
        w_est = self.estimator.estimate
        if np.linalg.norm(w_est - self.des.w) > RESCHEDULE_REL * np.linalg.norm(self.des.w):
            self.des = self._design(w_est.copy())
            self.alloc.recentre(w_est)
            self.kinds.add(self.des.kind)
            self.t_design = t_now

    def command(self, w_task: np.ndarray, state: tuple) -> tuple[np.ndarray, np.ndarray]:
        """(u, feed-forward) at ``state = (R, e_p, theta, v, omega)``; ``w_task`` is used only
        when the load is known."""
        R, e_p, theta, v, omega = state
        est = self.estimator
        if est is not None:
            est.observe(v, omega)
        w_ff = w_task if est is None else est.estimate
        w_att, w_pos = corrections(self.des, self.plant, self.gains, state)
        u, exact = self.alloc(w_ff + w_att + w_pos, w_ff, w_att)
        if est is not None:
            est.sent(v, omega, u, R)
            rate = integral_rate(self.des, self.plant, self.gains, R, e_p, theta)
            est.integrate(rate, exact, self.alloc)
        return u, w_ff

    def restart(self, w: np.ndarray, t_now: float) -> None:
        """After a divergence (unknown load): the estimate, reference and gains restart at w."""
        if self.estimator is None:
            return
        self.estimator.reset(w)
        self.alloc.recentre(w)
        self.des = self._design(w.copy())
        self.t_design = t_now
