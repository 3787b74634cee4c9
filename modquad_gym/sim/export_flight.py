"""Fly an exported MJCF on its own: gravity, its rotors and the package's hover controller, and
nothing else (no external load, unlike ``modquad validate``, which cancels the weight so that
the rotors make exactly the task wrench).

Everything the controller knows is read back from the file, so the flight tests the file and not
the structure it came from: the configuration matrix from the actuators (rotor k's column is
its site's thrust axis ``R_k gear[:3]`` and ``p_k x R_k gear[:3] + R_k gear[3:]``, the drag
torque), ``f_max`` from their ``ctrlrange``, mass and inertia from body ``structure``. The
robot starts off its reference (the file's start pose) by the hover's take-off offset and tilt
(:class:`~modquad_gym.sim.hover.HoverConfig`) and the controller holds the hover wrench
``[0, 0, m g, 0, 0, 0]`` with the load known: a robot that can lift itself
(:func:`~modquad_gym.sim.export.thrust_to_weight` >= 1, with room to steer) comes back to its
reference; one that cannot sinks.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from modquad_gym.core.extras import import_optional
from modquad_gym.sim.hover.config import HoverConfig
from modquad_gym.sim.hover.rotations import rotation_angle, rotation_vector


@dataclass(frozen=True)
class FreeFlight:
    """An exported robot's flight under gravity alone (:func:`fly_mjcf`).

    Attributes:
        thrust_to_weight: the largest multiple of its weight its rotors hold up level.
        seconds: simulated time.
        final_position_error_m: distance from the reference at the end.
        max_position_error_m: largest distance from the reference during the flight.
        final_attitude_error_rad: rotation away from the start attitude (level) at the end.
        saturated_fraction: share of control steps with some rotor at 0 or f_max.
    """

    thrust_to_weight: float
    seconds: float
    final_position_error_m: float
    max_position_error_m: float
    final_attitude_error_rad: float
    saturated_fraction: float

    def to_dict(self) -> dict:
        return {k: float(v) for k, v in self.__dict__.items()}


@dataclass(frozen=True)
class FileRobot:
    """What the controller needs, read from a loaded MJCF (module docstring)."""

    model: object
    body: int
    A: np.ndarray
    f_max: float
    mass: float
    J: np.ndarray


def robot_of(model, where: str = "the model") -> FileRobot:
    """The robot of an exported model: body ``structure`` with a free joint, its COM at the
    body origin, one site actuator per rotor with ctrlrange [0, f_max]; ValueError otherwise."""
    mujoco = import_optional("mujoco")

    body = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, "structure")
    free = mujoco.mjtJoint.mjJNT_FREE
    if body < 0 or model.body_jntnum[body] != 1 or model.jnt_type[model.body_jntadr[body]] != free:
        raise ValueError(f"{where}: no free body 'structure' (not a modquad_gym MJCF export)")
    if model.nu == 0 or np.any(model.actuator_trntype != mujoco.mjtTrn.mjTRN_SITE):
        raise ValueError(f"{where}: its actuators are not rotors on sites")
    ranges = np.asarray(model.actuator_ctrlrange)
    if np.any(ranges[:, 0] != 0.0) or np.ptp(ranges[:, 1]) > 0:
        raise ValueError(f"{where}: the rotors' ctrlrange is not one [0, f_max]")
    if np.linalg.norm(model.body_ipos[body]) > 1e-9:
        raise ValueError(f"{where}: body 'structure' has its COM off its origin")
    columns = []
    for k in range(model.nu):
        site = model.actuator_trnid[k, 0]
        R = np.empty(9)
        mujoco.mju_quat2Mat(R, model.site_quat[site])
        R = R.reshape(3, 3)
        gear = model.actuator_gear[k]
        force = R @ gear[:3]
        columns.append(
            np.concatenate([force, np.cross(model.site_pos[site], force) + R @ gear[3:]])
        )
    Q = np.empty(9)
    mujoco.mju_quat2Mat(Q, model.body_iquat[body])
    Q = Q.reshape(3, 3)
    J = Q @ np.diag(model.body_inertia[body]) @ Q.T
    mass = float(model.body_subtreemass[body])
    return FileRobot(model, body, np.array(columns).T, float(ranges[0, 1]), mass, J)


def fly_mjcf(source, seconds: float = 1.0, config: HoverConfig | None = None) -> FreeFlight:
    """Fly an exported MJCF (a path, or the MJCF text) for ``seconds`` under gravity alone with
    the package's hover controller (module docstring); ``config`` sets the controller's gains,
    rate and start offset (default :class:`~modquad_gym.sim.hover.HoverConfig`)."""
    mujoco = import_optional("mujoco")

    from modquad_gym.core.validation import check_real
    from modquad_gym.oracle import lambda_ratio
    from modquad_gym.sim.export_formats import parse_export, read_export
    from modquad_gym.sim.hover.controller import HoverController
    from modquad_gym.sim.hover.linearization import Plant

    seconds = check_real(seconds, "seconds", positive=True)
    text, where = read_export(source, "MJCF")
    robot = robot_of(parse_export(mujoco.MjModel.from_xml_string, text, where), where)
    model = robot.model
    cfg = HoverConfig.make(config, known_load=True)
    substeps, dt = cfg.control_steps(model.opt.timestep)
    weight = -robot.mass * np.asarray(model.opt.gravity)
    hover = np.concatenate([weight, np.zeros(3)])
    plant = Plant.build(robot.A, robot.f_max, robot.mass, robot.J)
    ctrl = HoverController(plant, cfg, dt)
    ctrl.begin_segment(hover)
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    p_ref = np.array(data.xpos[robot.body])
    R_ref = np.array(data.xmat[robot.body]).reshape(3, 3)
    data.qpos[:3] += np.asarray(cfg.initial_offset, dtype=float)
    half = 0.5 * cfg.initial_tilt_rad
    tilt = np.concatenate([[np.cos(half)], np.sin(half) * np.array([1.0, 1.0, 0.0]) / np.sqrt(2)])
    turned = np.empty(4)
    mujoco.mju_mulQuat(turned, tilt, np.array(data.qpos[3:7]))
    data.qpos[3:7] = turned
    mujoco.mj_forward(model, data)
    n = max(1, round(seconds / dt))
    errors, saturated = [], 0
    for _ in range(n):
        R = np.array(data.xmat[robot.body]).reshape(3, 3) @ R_ref.T
        e_p = np.array(data.xpos[robot.body]) - p_ref
        state = (R, e_p, rotation_vector(R), np.array(data.qvel[:3]), np.array(data.qvel[3:6]))
        u, _ = ctrl.command(hover, state)
        saturated += ctrl.alloc.saturated(u)
        data.ctrl[:] = u
        mujoco.mj_step(model, data, nstep=substeps)
        errors.append(float(np.linalg.norm(data.xpos[robot.body] - p_ref)))
    R_end = np.array(data.xmat[robot.body]).reshape(3, 3) @ R_ref.T
    ratio = lambda_ratio(robot.A, [hover], robot.f_max)
    return FreeFlight(
        thrust_to_weight=float(ratio[0]),
        seconds=n * dt,
        final_position_error_m=errors[-1],
        max_position_error_m=max(errors),
        final_attitude_error_rad=rotation_angle(R_end),
        saturated_fraction=saturated / n,
    )
