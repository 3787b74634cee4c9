"""Random dynamic tasks: a motion of :data:`~.motions.MOTIONS` with random parameters, often with
a payload held off the centre, and a push through a tool below the structure.

:class:`MotionTasks` is the task source of the dynamic benchmark tier
(``make_generator("motions")``, ``ModQuadAssemblyDynamic-v0``). Lift alone does not decide its
tasks: an off-centre payload and a push through a tool below the structure ask for torques, a
turning circle for yaw acceleration, so the minimum structure depends on its shape and not only
on its size. Each draw uses only the given ``rng`` (reproducible under a seed); ``meta`` records
the motion, its parameters and the torque sources.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from modquad_gym.core.validation import check_name, check_real, check_rng
from modquad_gym.dynamics.motions import DEFAULT_F_MAX, MOTIONS
from modquad_gym.dynamics.task import DynamicTask
from modquad_gym.dynamics.wrenches import Payload

RANGES = {
    "payload_kg": (0.1, 0.8),
    "hover_payload_kg": (0.3, 1.6),
    "payload_radius_m": (0.0, 0.4),
    "payload_drop_m": (0.0, 0.3),
    "line_distance_m": (1.0, 3.0),
    "line_acceleration": (1.0, 4.0),
    "line_climb": (-0.5, 0.5),
    "circle_radius_m": (0.5, 1.5),
    "circle_speed": (0.5, 2.0),
    "eight_size_m": (0.5, 1.5),
    "eight_speed": (0.5, 1.8),
    "push_distance_m": (1.0, 2.0),
    "push_speed": (0.2, 1.0),
    "push_force_n": (0.5, 6.0),
    "tool_length_m": (0.0, 0.4),
}
"""Uniform ranges of the random parameters (SI units; speeds in m/s, accelerations in m/s^2;
``line_climb`` is the vertical component of the line's direction before normalising)."""


@dataclass(frozen=True)
class MotionTasks:
    """A random motion (uniform over ``motions``) with parameters uniform in :data:`RANGES`.

    A hover always carries a payload (``hover_payload_kg``); any other motion carries one
    (``payload_kg``) with probability ``payload_share``. A payload hangs ``payload_drop_m``
    below the structure's centre of mass, ``payload_radius_m`` off its axis in a random
    direction. A push pushes through a tool ``tool_length_m`` below the centre of mass, so the
    contact force also asks for a pitching torque. A circle keeps its heading or turns with the
    path (equal odds). Samples at ``rate`` Hz.
    """

    motions: tuple[str, ...] = tuple(MOTIONS)
    payload_share: float = 0.6
    rate: float = 10.0
    f_max: float = DEFAULT_F_MAX
    name: str = "motions"

    def __post_init__(self) -> None:
        motions = (self.motions,) if isinstance(self.motions, str) else tuple(self.motions)
        unknown = [m for m in motions if m not in MOTIONS]
        if not motions or unknown:
            raise ValueError(
                f"motions: unknown {unknown[0] if unknown else 'empty list'!r}; choose from "
                f"{', '.join(MOTIONS)}"
            )
        object.__setattr__(self, "motions", motions)
        check_real(self.payload_share, "payload_share", low=0.0, high=1.0)
        check_real(self.rate, "rate", positive=True)
        check_real(self.f_max, "f_max", positive=True)
        check_name(self.name)

    def __call__(self, rng: np.random.Generator) -> DynamicTask:
        motion = self.motions[int(check_rng(rng).integers(len(self.motions)))]

        def u(key: str) -> float:
            return float(rng.uniform(*RANGES[key]))

        payload = None
        if motion == "hover" or rng.random() < self.payload_share:
            mass = u("hover_payload_kg" if motion == "hover" else "payload_kg")
            radius, angle = u("payload_radius_m"), float(rng.uniform(0.0, 2 * np.pi))
            offset = (radius * np.cos(angle), radius * np.sin(angle), -u("payload_drop_m"))
            payload = Payload(mass, offset)
        common = {"f_max": self.f_max, "payload": payload, "rate": self.rate, "name": self.name}
        heading = float(rng.uniform(0.0, 2 * np.pi))
        flat = (np.cos(heading), np.sin(heading), 0.0)
        if motion == "hover":
            task = MOTIONS["hover"](1.0, **common)
        elif motion == "line":
            direction = (flat[0], flat[1], u("line_climb"))
            task = MOTIONS["line"](
                u("line_distance_m"), u("line_acceleration"), direction=direction, **common
            )
        elif motion == "circle":
            turn = "tangent" if rng.random() < 0.5 else "fixed"
            task = MOTIONS["circle"](
                u("circle_radius_m"), u("circle_speed"), heading=turn, **common
            )
        elif motion == "figure-eight":
            task = MOTIONS["figure-eight"](u("eight_size_m"), u("eight_speed"), **common)
        else:
            task = MOTIONS["push"](
                u("push_distance_m"), u("push_speed"), u("push_force_n"), direction=flat, **common
            )
            return _through_tool(task, u("tool_length_m"))
        return task


def _through_tool(task: DynamicTask, length: float) -> DynamicTask:
    """``task`` (a push) with its contact force applied ``length`` metres below the centre of
    mass: the exerted wrench gains the torque r x f, r = (0, 0, -length)."""
    exerted = np.array(task.exerted)
    exerted[:, 3:] = np.cross([0.0, 0.0, -length], exerted[:, :3])
    meta = {**task.meta, "tool_length_m": length}
    return DynamicTask(task.trajectory, task.payload, exerted, task.f_max, task.name, meta)
