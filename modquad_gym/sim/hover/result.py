"""What a hover run returns: time series and per-segment metrics (:class:`HoverResult`)."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np


@dataclass
class HoverResult:
    """Time series and per-segment metrics of a hover run.

    Attributes:
        wrenches: (t, 6) task wrenches, one segment each.
        f_max: rotor thrust limit.
        known_load: whether the controller was told the load (:mod:`.estimator`).
        load_frame: ``"world"`` or ``"body"``.
        time: (k,) control-step times in seconds.
        segment: (k,) the segment (wrench index, -1 for the take-off) of each control step.
        position_error: (k,) |p_ref - p| in metres.
        attitude_error: (k,) rotation angle of R away from level, radians.
        u: (k, 4n) rotor inputs sent.
        saturated: (k,) some rotor at 0 or f_max (within 1e-6 f_max).
        settled: (k,) the step lies in the settled part of a task segment.
        gamma: (t,) the oracle's gamma of each task wrench (<= 1 feasible, inf off range(A)).
        feasible: (t,) the oracle's verdict.
        diverged: (t,) the segment was cut short by drift or ended away (:mod:`.recorder`).
        load: (k, 6) the wrench the external load stood for at each control step (the task
            wrench, or its ramp from the previous one): d = -(load + gravity wrench).
        load_estimate: (k, 6) the controller's feed-forward: the load itself when known, the
            estimate w_obs + w_hat (observer + integral action) when not.
    """

    wrenches: np.ndarray
    f_max: float
    known_load: bool
    load_frame: str
    time: np.ndarray
    segment: np.ndarray
    position_error: np.ndarray
    attitude_error: np.ndarray
    u: np.ndarray
    saturated: np.ndarray
    settled: np.ndarray
    gamma: np.ndarray
    feasible: np.ndarray
    diverged: np.ndarray
    load: np.ndarray
    load_estimate: np.ndarray
    segment_metrics: list[dict] = field(default_factory=list)
    """Per segment (take-off first, index -1): gamma, controller, diverged (stop_reason,
    stop_time_s), settled errors, saturation, load estimate error (unknown load)."""
    load_ramp_seconds: float = 0.0
    """How long the load took to go from one task wrench to the next (0: a step)."""
    load_ramp_profile: str = "cosine"
    """``"cosine"`` or ``"linear"`` (meaningful when ``load_ramp_seconds > 0``)."""

    @property
    def max_position_error(self) -> float:
        """Largest settled position error over all segments, metres."""
        return float(self.position_error[self.settled].max(initial=0.0))

    @property
    def max_attitude_error(self) -> float:
        """Largest settled attitude error over all segments, radians."""
        return float(self.attitude_error[self.settled].max(initial=0.0))

    @property
    def saturated_fraction(self) -> float:
        """Fraction of the task's control steps (take-off excluded) with a rotor at 0 or f_max."""
        task = self.segment >= 0
        return float(self.saturated[task].mean()) if task.any() else 0.0

    @property
    def settled_saturated_fraction(self) -> float:
        """Fraction of the settled control steps with a rotor at 0 or f_max."""
        return float(self.saturated[self.settled].mean()) if self.settled.any() else 0.0

    @property
    def max_load_estimate_error(self) -> float | None:
        """Largest relative error |w_hat - w| / |w| of the load estimate at a segment's end
        (unknown load; None with a known load or no task segment)."""
        errs = [
            s["load_estimate_error"]
            for s in self.segment_metrics
            if s["segment"] >= 0 and s.get("load_estimate_error") is not None
        ]
        return max(errs) if errs else None
