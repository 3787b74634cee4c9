"""Records a hover run step by step and sums each segment up into its metrics.

Metrics per segment, over its settled part (the last ``settle_fraction`` of it): maximum position
error (m), maximum attitude error (rad, the rotation angle of R), the saturated fraction (whole
segment and settled part) and, with an unknown load, the relative error of the load estimate at
the segment's end and the step headroom (along the change of load from the previous segment). A
segment cut short (drift past a limit, or a non-finite state) is marked ``diverged`` with its
``stop_reason`` and stop time and counts in full; so is one that runs its course but ends more
than ``recover_limit_m`` from the reference ("ended ... away").
"""

from __future__ import annotations

import math

import numpy as np

from modquad_gym.sim.hover.config import HoverConfig
from modquad_gym.sim.hover.result import HoverResult


def drift_reason(pos_err: float, att_err: float, cfg: HoverConfig) -> str | None:
    """Why a segment must stop now (a non-finite state, or drift past a limit), or None."""
    if not (np.isfinite(pos_err) and np.isfinite(att_err)):
        return "non-finite state"
    if pos_err > cfg.drift_limit_m:
        return f"position error passed {cfg.drift_limit_m:g} m"
    if att_err > cfg.drift_limit_rad:
        return f"attitude error passed {cfg.drift_limit_rad:g} rad"
    return None


class Recorder:
    """Preallocated time series over all segments (take-off is segment -1) and their metrics."""

    def __init__(self, segments: list[tuple[int, np.ndarray, int]], n_rotors: int) -> None:
        total = sum(n for _, _, n in segments)
        self.k = 0  # next record index: the control step counted from the run's start
        self.t = np.full(total, np.nan)
        self.seg = np.concatenate([np.full(n, i) for i, _, n in segments])
        self.pos = np.full(total, np.nan)
        self.att = np.full(total, np.nan)
        self.u = np.full((total, n_rotors), np.nan)
        self.load = np.full((total, 6), np.nan)
        self.est = np.full((total, 6), np.nan)
        self.sat = np.zeros(total, dtype=bool)
        self.settled = np.zeros(total, dtype=bool)
        n_tasks = sum(i >= 0 for i, _, _ in segments)
        self.gamma = np.empty(n_tasks)
        self.diverged = np.zeros(n_tasks, dtype=bool)
        self.metrics: list[dict] = []

    def record(self, t, pos_err, att_err, u, load, estimate, saturated, settled) -> None:
        """One control step's outcome."""
        k = self.k
        self.t[k], self.pos[k], self.att[k] = t, pos_err, att_err
        self.u[k], self.load[k], self.est[k] = u, load, estimate
        self.sat[k], self.settled[k] = saturated, settled
        self.k = k + 1

    def close(self, i: int, start: int, gamma: float, controller: str, cut: str | None, **extra):
        """Sum segment ``i`` (records ``start:k``) up; ``extra``: ``cut_short``, ``ctrl_dt``,
        ``load_estimate_error``, ``step_headroom``."""
        seg = slice(start, self.k)
        if extra["cut_short"]:
            self.settled[seg] = True  # a diverged segment counts in full
        window = self.settled[seg]
        stop = float((self.k - start) * extra["ctrl_dt"]) if extra["cut_short"] else None
        self.metrics.append(
            {
                "segment": i,
                "gamma": float(gamma) if np.isfinite(gamma) else None,
                "controller": controller,
                "diverged": bool(cut),
                "stop_reason": cut,
                "stop_time_s": stop,
                "max_position_error_m": float(np.nanmax(self.pos[seg][window])),
                "max_attitude_error_rad": float(np.nanmax(self.att[seg][window])),
                "saturated_fraction": float(self.sat[seg].mean()),
                "settled_saturated_fraction": float(self.sat[seg][window].mean()),
                "load_estimate_error": extra["load_estimate_error"],
                "step_headroom": extra["step_headroom"],
            }
        )
        if i >= 0:
            self.gamma[i] = gamma
            self.diverged[i] = bool(cut)

    def result(self, W: np.ndarray, cfg: HoverConfig, f_max: float, feasible) -> HoverResult:
        """The run's :class:`HoverResult` (steps skipped after a divergence left out)."""
        keep = ~np.isnan(self.t)
        task = self.seg >= 0
        return HoverResult(
            wrenches=W,
            f_max=f_max,
            known_load=cfg.known_load,
            load_frame=cfg.load_frame,
            time=self.t[keep],
            segment=self.seg[keep],
            position_error=self.pos[keep],
            attitude_error=self.att[keep],
            u=self.u[keep],
            saturated=self.sat[keep],
            settled=(self.settled & task)[keep],
            gamma=self.gamma,
            feasible=np.asarray(feasible, dtype=bool),
            diverged=self.diverged,
            load=self.load[keep],
            load_estimate=self.est[keep],
            segment_metrics=self.metrics,
            load_ramp_seconds=cfg.ramp_seconds,
            load_ramp_profile=cfg.load_ramp_profile,
        )


def estimate_error(estimate: np.ndarray, w: np.ndarray) -> float:
    """Relative error |estimate - w| / |w| of a load estimate (|w| floored at 1e-9)."""
    return float(np.linalg.norm(estimate - w) / max(float(np.linalg.norm(w)), 1e-9))


def settles_at_rest(gamma: float, tol: float) -> bool:
    """Whether a segment's load has a hover equilibrium (oracle gamma <= 1 within tol)."""
    return math.isfinite(gamma) and gamma <= 1.0 + tol
