"""MuJoCo hover in parts: settings (:mod:`.config`), plant and linearisation
(:mod:`.linearization`), gains (:mod:`.gains`), allocator (:mod:`.allocator`), load estimator
(:mod:`.estimator`), load profile (:mod:`.load`), controller (:mod:`.controller`), recorder
(:mod:`.recorder`, :mod:`.result`) and the run itself (:mod:`.run`).

Measurements and the design history of this hover are in ``results/hover_notes.md``.
"""

from __future__ import annotations

from modquad_gym.sim.hover.allocator import Allocator
from modquad_gym.sim.hover.config import LOAD_FRAMES, LOAD_RAMP_PROFILES, HoverConfig, HoverGains
from modquad_gym.sim.hover.controller import HoverController
from modquad_gym.sim.hover.estimator import LoadEstimator
from modquad_gym.sim.hover.gains import Design, design_gains
from modquad_gym.sim.hover.linearization import (
    Plant,
    body_inertia,
    hover_linearization,
    unreachable_wrench_directions,
    wrench_axis,
)
from modquad_gym.sim.hover.load import LoadRamp, external_wrench, ramp_fraction, step_headroom
from modquad_gym.sim.hover.recorder import Recorder
from modquad_gym.sim.hover.result import HoverResult
from modquad_gym.sim.hover.rotations import rotation_angle, rotation_vector
from modquad_gym.sim.hover.run import run_hover

__all__ = [
    "LOAD_FRAMES",
    "LOAD_RAMP_PROFILES",
    "Allocator",
    "Design",
    "HoverConfig",
    "HoverController",
    "HoverGains",
    "HoverResult",
    "LoadEstimator",
    "LoadRamp",
    "Plant",
    "Recorder",
    "body_inertia",
    "design_gains",
    "external_wrench",
    "hover_linearization",
    "ramp_fraction",
    "rotation_angle",
    "rotation_vector",
    "run_hover",
    "step_headroom",
    "unreachable_wrench_directions",
    "wrench_axis",
]
