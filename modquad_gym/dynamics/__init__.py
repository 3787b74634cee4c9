"""Dynamic tasks: design a structure for a motion, a payload and exerted wrenches, with the
structure's own mass and inertia (its wrenches depend on the structure being designed).

* :mod:`.trajectory`: :class:`Trajectory`, sampled poses and derivatives (given or by splines);
  :mod:`.samples` reads its samples, :mod:`.splines` fits them, estimates the derivatives' error
  and checks given derivatives against them;
* :mod:`.wrenches`: :func:`required_wrenches` (Newton-Euler), :class:`Payload`, and
  :class:`LinearWrenches`, the rotor wrenches as a linear function of mass and inertia;
* :mod:`.task`: :class:`DynamicTask` (trajectory, payload, exerted wrenches, f_max; JSON files)
  and the lift check that refuses, before any work, a payload no structure can carry;
* :mod:`.motions`: hover, line, circle, figure-eight and push tasks (:data:`MOTIONS`).
"""

from modquad_gym.dynamics.motions import MOTIONS, circle, figure_eight, hover, line, push
from modquad_gym.dynamics.task import DynamicTask, as_dynamic, check_liftable, lift_capacity
from modquad_gym.dynamics.trajectory import MAX_SAMPLES, Trajectory
from modquad_gym.dynamics.wrenches import (
    LinearWrenches,
    Payload,
    required_wrenches,
    rigid_body_wrenches,
)

__all__ = [
    "MAX_SAMPLES",
    "MOTIONS",
    "DynamicTask",
    "LinearWrenches",
    "Payload",
    "Trajectory",
    "as_dynamic",
    "check_liftable",
    "circle",
    "figure_eight",
    "hover",
    "lift_capacity",
    "line",
    "push",
    "required_wrenches",
    "rigid_body_wrenches",
]
