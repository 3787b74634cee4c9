"""MuJoCo validation of structures: model builder, wrench bench, hover, pictures (paper Sec. VI).

MuJoCo is imported only inside this subpackage (``import modquad_gym`` never loads it).
``MUJOCO_GL`` defaults to ``egl`` here, before mujoco is first imported, so offscreen rendering
works headless; pictures fall back to matplotlib where no GL context can be made.
"""

from __future__ import annotations

import os

os.environ.setdefault("MUJOCO_GL", "egl")

from modquad_gym.sim.hover import (  # noqa: E402
    LOAD_FRAMES,
    LOAD_RAMP_PROFILES,
    HoverConfig,
    HoverGains,
    HoverResult,
    hover_linearization,
    run_hover,
    step_headroom,
    unreachable_wrench_directions,
    wrench_axis,
)
from modquad_gym.sim.model import SimModel, actuator_wrench, build_model, model_xml  # noqa: E402
from modquad_gym.sim.pictures import render_structure  # noqa: E402
from modquad_gym.sim.report import ValidationReport  # noqa: E402
from modquad_gym.sim.validate import validate  # noqa: E402
from modquad_gym.sim.wrench_stand import ALLOCATIONS, BenchResult, allocate_inputs, run_bench  # noqa: E402

__all__ = [
    "ALLOCATIONS",
    "BenchResult",
    "HoverConfig",
    "HoverGains",
    "HoverResult",
    "LOAD_FRAMES",
    "LOAD_RAMP_PROFILES",
    "SimModel",
    "actuator_wrench",
    "allocate_inputs",
    "build_model",
    "hover_linearization",
    "model_xml",
    "render_structure",
    "run_bench",
    "run_hover",
    "step_headroom",
    "unreachable_wrench_directions",
    "ValidationReport",
    "validate",
    "wrench_axis",
]
