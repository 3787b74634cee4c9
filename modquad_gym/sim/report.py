"""What :func:`modquad_gym.sim.validate.validate` returns (:class:`ValidationReport`) and its
``report.md`` text.

``ValidationReport.to_dict()`` gives the flat JSON record of ``modquad validate --json`` (the
keys and their order are part of the CLI's contract; non-finite numbers become None, JSON's null:
e.g. a ``step_headroom`` with no load step, which is unlimited, :func:`json_ready`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from modquad_gym.core.outputs import json_ready
from modquad_gym.sim.hover import HoverResult

SEGMENT_KEYS = (
    "segment",
    "gamma",
    "step_headroom",
    "max_position_error_m",
    "max_attitude_error_rad",
    "saturated_fraction",
    "settled_saturated_fraction",
    "load_estimate_error",
    "diverged",
    "stop_reason",
)
"""The per-segment numbers the report keeps of the unknown-load hover."""


def finite_or_none(x: float) -> float | None:
    """``x`` as a float, None when not finite (JSON has no inf or nan)."""
    x = float(x)
    return x if math.isfinite(x) else None


@dataclass
class HoverSummary:
    """The task-level numbers of one hover run (take-off excluded)."""

    max_position_error_m: float
    max_attitude_error_rad: float
    saturated_fraction: float
    settled_saturated_fraction: float
    diverged_segments: int
    segments_within_1cm: int
    controllers: list[str]
    max_load_estimate_error: float | None

    @classmethod
    def of(cls, hover: HoverResult) -> HoverSummary:
        task = [s for s in hover.segment_metrics if s["segment"] >= 0]
        return cls(
            max_position_error_m=hover.max_position_error,
            max_attitude_error_rad=hover.max_attitude_error,
            saturated_fraction=hover.saturated_fraction,
            settled_saturated_fraction=hover.settled_saturated_fraction,
            diverged_segments=int(hover.diverged.sum()),
            segments_within_1cm=int(sum(s["max_position_error_m"] <= 0.01 for s in task)),
            controllers=sorted(
                {c for s in hover.segment_metrics for c in s["controller"].split("+")}
            ),
            max_load_estimate_error=hover.max_load_estimate_error,
        )


@dataclass
class InfeasibleDemo:
    """A hover on a task wrench scaled out of the feasible set (saturation and drift)."""

    wrench: list[float]
    from_task_row: int
    feasible: bool
    gamma: float | None
    saturated_fraction: float
    max_position_error_m: float
    max_attitude_error_rad: float
    diverged: bool
    stop_reason: str | None
    stop_time_s: float | None

    @classmethod
    def of(cls, demo: HoverResult, wrench, row: int) -> InfeasibleDemo:
        seg = demo.segment_metrics[-1]
        return cls(
            wrench=[float(x) for x in wrench],
            from_task_row=row,
            feasible=bool(demo.feasible[0]),
            gamma=finite_or_none(demo.gamma[0]),
            saturated_fraction=demo.saturated_fraction,
            max_position_error_m=demo.max_position_error,
            max_attitude_error_rad=demo.max_attitude_error,
            diverged=bool(demo.diverged[0]),
            stop_reason=seg["stop_reason"],
            stop_time_s=seg["stop_time_s"],
        )


@dataclass
class ValidationReport:
    """Bench and hover numbers of one structure on one task (see ``validate``).

    The structure and task, the wrench bench (relative errors of the exact allocation and of
    the paper's pinv + clip, load-cell fidelity), the known-load hover (``hover``), and, when
    flown, the unknown-load hover (``unknown_load``, its ramp and per-segment numbers) and the
    infeasible demo; ``files`` maps picture and report names to the paths written."""

    n_modules: int
    cells: list[list[int]]
    modules: list[str]
    mass_kg: float
    task_kind: str
    rank: int
    unreachable_wrench_directions: list[dict]
    f_max: float
    n_wrenches: int
    feasible: bool
    n_feasible: int
    min_margin: float | None
    module_mass_kg: float
    bench_max_error: float
    bench_max_error_pinv_clip: float
    bench_max_sensor_error: float
    bench_pinv_clip_wrenches_missed: int
    bench_exact_at_limit: int
    hover_load_frame: str
    hover_seconds_per_wrench: float
    hover_wrenches: int
    hover_n_feasible: int
    hover: HoverSummary
    hover_takeoff: dict | None
    files: dict[str, str] = field(default_factory=dict)
    unknown_load: HoverSummary | None = None
    unknown_load_ramp_seconds: float | None = None
    unknown_load_segments: list[dict] | None = None
    infeasible_demo: InfeasibleDemo | None = None
    render_backend: str | None = None

    def to_dict(self) -> dict:
        """The flat JSON record (today's keys, in today's order)."""
        out = {k: getattr(self, k) for k in _HEAD}
        h = self.hover
        out |= {
            "hover_max_position_error_m": h.max_position_error_m,
            "hover_max_attitude_error_rad": h.max_attitude_error_rad,
            "saturated_fraction": h.saturated_fraction,
            "hover_settled_saturated_fraction": h.settled_saturated_fraction,
            "hover_diverged_segments": h.diverged_segments,
            "hover_segments_within_1cm": h.segments_within_1cm,
            "hover_controllers": h.controllers,
            "hover_takeoff": self.hover_takeoff,
            "files": self.files,
        }
        if self.unknown_load is not None:
            out["hover_unknown_load_ramp_seconds"] = self.unknown_load_ramp_seconds
            for key, value in vars(self.unknown_load).items():
                out[f"hover_unknown_load_{key}"] = value
            out["hover_unknown_load_segments"] = self.unknown_load_segments
        if self.infeasible_demo is not None:
            out["infeasible_demo"] = dict(vars(self.infeasible_demo))
        if self.render_backend is not None:
            out["render_backend"] = self.render_backend
        return json_ready(out)


_HEAD = (
    "n_modules",
    "cells",
    "modules",
    "mass_kg",
    "task_kind",
    "rank",
    "unreachable_wrench_directions",
    "f_max",
    "n_wrenches",
    "feasible",
    "n_feasible",
    "min_margin",
    "module_mass_kg",
    "bench_max_error",
    "bench_max_error_pinv_clip",
    "bench_max_sensor_error",
    "bench_pinv_clip_wrenches_missed",
    "bench_exact_at_limit",
    "hover_load_frame",
    "hover_seconds_per_wrench",
    "hover_wrenches",
    "hover_n_feasible",
)
