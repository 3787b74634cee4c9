"""Fly a structure along a dynamic task's trajectory in MuJoCo (feed-forward plus feedback).

The structure starts at rest on the reference (the trajectory translated so that it starts at
``(0, 0, HOME_HEIGHT)``), with the payload welded on. At ``control_hz`` the controller reads the
state and commands

    w = w_ff + A (-K x),    u = allocate(w) within 0 <= u <= f_max,

* ``w_ff``: the task's rotor wrench at the reference (Newton-Euler with the structure's mass and
  inertia, the payload and the exerted wrench, :mod:`modquad_gym.dynamics`), the reference
  being the trajectory interpolated at the control time (:meth:`Trajectory.at`);
* ``x = [e_p, theta, e_v, e_omega]``: position and velocity errors in the reference body frame,
  the attitude error theta = log(R_d^T R) and the rate error;
* ``K``: the hover controller's LQR (:func:`modquad_gym.sim.hover.gains.design_gains`) designed at
  the current feed-forward (the rotors' wrench tilts with the body while the inertial and
  gravity load stays fixed in the world: a line of modules, rank 5, rolls to push itself
  sideways), redesigned every ``reschedule_s`` seconds; the PD fallback where none stabilises;
* the allocation is the hover's (:class:`~modquad_gym.sim.hover.allocator.Allocator`):
  ``u = u_ref + A^+ (w - A u_ref)`` while it stays in the box (else an exact allocation inside
  it, else the feed-forward first, then the attitude, then the position correction), with the
  reference u_ref interpolated linearly between the oracle's most centred allocations of the
  feed-forward every ``reschedule_s`` seconds: smooth inputs that keep away from the limits.

The exerted wrench is applied to the body as the environment's reaction (``-R w_exerted``) in
the simulation, so the rotors must really produce it. Reported: the largest and RMS distance
between the flown and desired COM, the largest attitude error, and the share of control steps
in which some rotor sits at 0 or f_max (saturation).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from modquad_gym.core.extras import import_optional
from modquad_gym.core.validation import check_real
from modquad_gym.dynamics import DynamicTask, Trajectory, as_dynamic
from modquad_gym.dynamics import quaternions as quat
from modquad_gym.dynamics.wrenches import rigid_body_wrenches
from modquad_gym.geometry.structure import Structure
from modquad_gym.sim.failure import Failure
from modquad_gym.sim.hover.allocator import Allocator
from modquad_gym.sim.hover.config import HoverGains
from modquad_gym.sim.hover.gains import LQR, design_gains
from modquad_gym.sim.hover.linearization import Plant
from modquad_gym.sim.hover.rotations import rotation_angle, rotation_vector
from modquad_gym.sim.model import HOME_HEIGHT, SimModel, body_rotation, build_model


@dataclass(frozen=True)
class TrackConfig:
    """How to fly a trajectory.

    Attributes:
        control_hz: controller rate (the simulation steps at 1 kHz).
        gains: the LQR's tuning (:class:`HoverGains`).
        reschedule_s: seconds between two gain designs at the current feed-forward.
        drift_limit_m: stop the flight when the COM is this far from the reference.
    """

    control_hz: float = 500.0
    gains: HoverGains = field(default_factory=HoverGains)
    reschedule_s: float = 0.05
    drift_limit_m: float = 1.0

    def __post_init__(self) -> None:
        check_real(self.control_hz, "control_hz", 1.0, 1000.0)
        check_real(self.reschedule_s, "reschedule_s", positive=True)
        check_real(self.drift_limit_m, "drift_limit_m", positive=True)


@dataclass
class TrackResult:
    """A flight along a trajectory (arrays per control step).

    Attributes:
        t: (N,) control times, s. desired, flown: (N, 3) COM positions in the world, m.
        attitude: (N, 4) flown quaternions (w, x, y, z). attitude_error: (N,) rad.
        inputs: (N, 4n) rotor thrusts, N. saturated: (N,) bool.
        wrench_ff: (N, 6) feed-forward rotor wrenches. f_max: the thrust limit.
        diverged: why the flight was stopped early, or None.
    """

    t: np.ndarray
    desired: np.ndarray
    flown: np.ndarray
    attitude: np.ndarray
    attitude_error: np.ndarray
    inputs: np.ndarray
    saturated: np.ndarray
    wrench_ff: np.ndarray
    f_max: float
    diverged: str | None = None

    @property
    def position_error(self) -> np.ndarray:
        return np.linalg.norm(self.flown - self.desired, axis=1)

    @property
    def max_position_error_m(self) -> float:
        return float(self.position_error.max(initial=0.0))

    @property
    def rms_position_error_m(self) -> float:
        e = self.position_error
        return float(np.sqrt(np.mean(e**2))) if len(e) else 0.0

    @property
    def max_attitude_error_rad(self) -> float:
        return float(self.attitude_error.max(initial=0.0))

    @property
    def saturated_fraction(self) -> float:
        return float(self.saturated.mean()) if len(self.saturated) else 0.0

    def summary(self) -> dict:
        """The flight's numbers (the ``track_*`` keys of a validation)."""
        return {
            "track_max_position_error_m": self.max_position_error_m,
            "track_rms_position_error_m": self.rms_position_error_m,
            "track_max_attitude_error_rad": self.max_attitude_error_rad,
            "track_saturated_fraction": self.saturated_fraction,
            "track_seconds": float(self.t[-1]) if len(self.t) else 0.0,
            "track_diverged": self.diverged,
        }


def reference(task: DynamicTask, times: np.ndarray, structure: Structure) -> tuple:
    """(ref dict of :meth:`Trajectory.at` shifted to start at home, feed-forward (N, 6),
    exerted (N, 6)) at the control times. A time past the trajectory's end is the hold
    (:func:`fly_trajectory`'s ``hold_s``): the motion goes on as it ended, at its final velocity
    (at rest for a trajectory that ends at rest, as the generated ones do), no acceleration, its
    final attitude with no rotation, and its final exerted wrench, so that neither a step in the
    reference nor a load taken away is judged as the failure's doing."""
    traj = task.trajectory
    ref = traj.at(traj.t[0] + times)
    ref["position"] = ref["position"] - traj.position[0] + np.array([0.0, 0.0, HOME_HEIGHT])
    held = times > traj.duration + 1e-9
    if held.any():
        after = (times[held] - traj.duration)[:, None]
        end = traj.position[-1] - traj.position[0] + [0.0, 0.0, HOME_HEIGHT]
        ref["position"][held] = end + traj.velocity[-1] * after
        ref["velocity"][held] = traj.velocity[-1]
        ref["quaternion"][held] = traj.quaternion[-1] / np.linalg.norm(traj.quaternion[-1])
        for name in ("acceleration", "angular_velocity", "angular_acceleration"):
            ref[name][held] = 0.0
    sampled = Trajectory.resampled({**ref, "t": times})
    exerted = np.zeros((len(times), 6))
    if task.exerted is not None:
        from scipy.interpolate import make_interp_spline

        exerted = make_interp_spline(traj.t, task.exerted, k=1)(traj.t[0] + times)
        exerted[held] = task.exerted[-1]
    ff = rigid_body_wrenches(sampled, structure.mass, structure.inertia, task.payload) + exerted
    return ref, ff, exerted


def _plant(sim: SimModel, task: DynamicTask) -> Plant:
    """The controller's model: the structure with its payload (mass and inertia about {S})."""
    s = sim.structure
    mass, J = s.mass, np.array(s.inertia)
    if task.payload is not None:
        r = np.asarray(task.payload.offset)
        mass += task.payload.mass
        J += task.payload.mass * (r @ r * np.eye(3) - np.outer(r, r))
    return Plant.build(sim.A, sim.f_max, mass, J)


class _Gains:
    """The LQR (or PD) gains, rescheduled at the feed-forward (module docstring)."""

    def __init__(self, plant: Plant, gains: HoverGains, every: int) -> None:
        self.plant, self.gains, self.every = plant, gains, max(1, every)
        self.des = None

    def update(self, step: int, w_ff: np.ndarray) -> None:
        if self.des is None or step % self.every == 0:
            p = self.plant
            self.des = design_gains(p.A, w_ff, p.mass, p.J, self.gains, "world", False)

    def corrections(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(attitude, position) corrective wrenches for x = [e_p, theta, e_v, e_omega]."""
        p, g = self.plant, self.gains
        if self.des.kind == LQR:
            K = self.des.K
            return p.A @ (-K[:, 3:6] @ x[3:6] - K[:, 9:] @ x[9:]), p.A @ (
                -K[:, :3] @ x[:3] - K[:, 6:9] @ x[6:9]
            )
        kp, kd = g.omega_pos**2, 2 * g.damping * g.omega_pos
        kr, kw = g.omega_att**2, 2 * g.damping * g.omega_att
        f = p.mass * (-kp * x[:3] - kd * x[6:9])
        tau = p.J @ (-kr * x[3:6] - kw * x[9:])
        zero = np.zeros(3)
        return p.P @ np.concatenate([zero, tau]), p.P @ np.concatenate([f, zero])


class _Control:
    """Gains, allocator and reference inputs on one set of working rotors ``keep``."""

    def __init__(self, plant: Plant, keep: np.ndarray, cfg: TrackConfig, dt: float, ff) -> None:
        self.plant, self.keep = plant, keep
        self.alloc = Allocator(plant)
        self.gains = _Gains(plant, cfg.gains, round(cfg.reschedule_s / dt))
        self.u_ref = _reference_inputs(plant, ff, self.gains.every)

    def command(self, k: int, w_ff: np.ndarray, x: np.ndarray) -> np.ndarray:
        """Every rotor's input at step k (0 for the rotors not in ``keep``)."""
        self.gains.update(k, w_ff)
        self.alloc.u_ref, self.alloc.w_ref = self.u_ref[k], self.plant.A @ self.u_ref[k]
        w_att, w_pos = self.gains.corrections(x)
        u = np.zeros(len(self.keep))
        u[self.keep], _ = self.alloc(w_ff + w_att + w_pos, w_ff, w_att)
        return u


def fly_trajectory(
    structure: Structure,
    task: DynamicTask,
    config: TrackConfig | None = None,
    failure: Failure | None = None,
    detector=None,
    hold_s: float = 0.0,
) -> TrackResult:
    """Fly ``structure`` along ``task``'s trajectory in MuJoCo (module docstring), then go on
    ``hold_s`` seconds as it ended (:func:`reference`; default 0: none; the arrays cover it).

    ``failure``: rotors that stop during the flight (:class:`~modquad_gym.sim.failure.Failure`:
    their thrust 0 from ``failure.time_s``; from ``failure.detected_s`` the controller
    allocates without them); ``saturated`` then counts only the rotors still working. With a
    ``detector`` (:func:`~modquad_gym.sim.detector.make_detector`) the controller is not told:
    it switches when the detector decides, to the rotors it names, and again when it revises
    that (``run.detection``: the first decision's time and the rotors named last)."""
    mujoco = import_optional("mujoco")

    from modquad_gym.sim.detector import make_detector

    task = as_dynamic(task)  # a ValueError naming the type of anything else
    _check_failure(failure, structure)
    hold_s = check_real(hold_s, "hold_s", low=0.0)
    cfg = config or TrackConfig()
    sim = build_model(structure, task.f_max, payload=task.payload)
    model, data = sim.model, mujoco.MjData(sim.model)
    substeps = max(1, round(1.0 / (cfg.control_hz * model.opt.timestep)))
    dt = substeps * model.opt.timestep
    times = _control_times(task.trajectory.duration, hold_s, dt)
    ref, ff, exerted = reference(task, times, structure)
    plant = _plant(sim, task)
    control = _Control(plant, np.ones(sim.n_rotors, dtype=bool), cfg, dt, ff)
    working, known = control.keep, False
    _start(mujoco, model, data, ref)
    N, m = len(times), sim.n_rotors
    flown, att, inputs = np.zeros((N, 3)), np.zeros(N), np.zeros((N, m))
    attitude = np.zeros((N, 4))
    saturated = np.zeros(N, dtype=bool)
    diverged = None
    b = sim.body_id
    com = None  # the body's COM in {S}: a payload moves it off the origin
    if task.payload is not None:
        com = task.payload.mass * np.asarray(task.payload.offset) / plant.mass
    watch = None if failure is None else make_detector(detector, plant, failure.kind, dt, com)
    for k in range(N):
        late = watch is None and failure is not None and not known
        if late and times[k] >= failure.detected_s - 1e-9:
            control, known = _failed_control(failure, plant, cfg, dt, ff), True
        R = body_rotation(sim, data)
        Rd = quat.to_matrix(ref["quaternion"][k])
        x = _errors(R, Rd, data, b, ref, k)
        u = control.command(k, ff[k], x) if control is not None else np.zeros(m)
        u_cmd = u.copy()
        if failure is not None and times[k] >= failure.time_s - 1e-9:
            working = failure.working(m)
            u[~working] = 0.0  # the failed rotors give no thrust, whatever is commanded
        data.ctrl[:] = u
        data.xfrc_applied[b, :3] = -R @ exerted[k, :3]
        data.xfrc_applied[b, 3:] = -R @ exerted[k, 3:]
        if watch is not None:  # a first decision, or a revised one
            v, omega, load = (np.array(data.qvel[:3]), np.array(data.qvel[3:6]),
                              np.array(data.xfrc_applied[b]))  # fmt: skip
            hit = watch.update(times[k], R, v, omega, u_cmd, load, model.opt.gravity)
            if hit is not None:
                named = Failure(tuple(hit[1]), failure.time_s, 0.0, failure.kind)
                control = _failed_control(named, plant, cfg, dt, ff)
        flown[k], att[k], inputs[k] = data.xpos[b], rotation_angle(Rd.T @ R), u
        attitude[k] = data.xquat[b]
        saturated[k] = _at_limit(u[working], task.f_max)
        if np.linalg.norm(flown[k] - ref["position"][k]) > cfg.drift_limit_m:
            diverged = f"more than {cfg.drift_limit_m:g} m off the path at t = {times[k]:.3g} s"
            break
        mujoco.mj_step(model, data, nstep=substeps)
    n = k + 1
    run = TrackResult(times[:n], ref["position"][:n], flown[:n], attitude[:n], att[:n],
                      inputs[:n], saturated[:n], ff[:n], task.f_max, diverged)  # fmt: skip
    run.detector = watch
    run.detection = None if watch is None else watch.detected
    return run


def _start(mujoco, model, data, ref: dict) -> None:
    """The simulation's state at the reference's first point (its position, attitude, rates)."""
    data.qpos[:3], data.qpos[3:7] = ref["position"][0], ref["quaternion"][0]
    data.qvel[:3], data.qvel[3:6] = ref["velocity"][0], ref["angular_velocity"][0]
    mujoco.mj_forward(model, data)


def _control_times(duration: float, hold_s: float, dt: float) -> np.ndarray:
    """The control times: every step of ``dt`` up to the trajectory's end, then whole steps
    covering ``hold_s`` (the hold lasts at least ``hold_s``, less than a step more)."""
    times = np.arange(0.0, duration + 1e-9, dt)
    if hold_s > 0:
        times = np.arange(len(times) + math.ceil(hold_s / dt - 1e-9)) * dt
    return times


def _check_failure(failure, structure: Structure) -> None:
    """A ValueError unless ``failure`` is None or a :class:`Failure` of ``structure``'s rotors."""
    if failure is not None:
        if not isinstance(failure, Failure):
            raise ValueError(f"failure must be a Failure, got {type(failure).__name__}")
        failure.check_rotors(structure.configuration_matrix().shape[1])


def _failed_control(failure: Failure, plant: Plant, cfg: TrackConfig, dt: float, ff):
    """The control once the failure is known (None when no rotor is left)."""
    reduced = failure.plant(plant)
    if reduced is None:
        return None
    return _Control(reduced, failure.working(plant.A.shape[1]), cfg, dt, ff)


def _at_limit(u: np.ndarray, f_max: float) -> bool:
    """Some rotor of u at 0 or f_max (within the oracle's tolerance, as the allocator says)."""
    from modquad_gym.oracle import TOL

    tol = TOL * f_max
    return bool(np.any((u <= tol) | (u >= f_max - tol)))


def _reference_inputs(plant: Plant, ff: np.ndarray, every: int) -> np.ndarray:
    """(N, m) reference inputs: the most centred exact allocation of the feed-forward every
    ``every`` steps (the box's centre where it has none), linearly interpolated between."""
    from modquad_gym.oracle import TOL, allocate

    knots = np.unique(np.r_[np.arange(0, len(ff), every), len(ff) - 1])
    centre = np.full(plant.A.shape[1], plant.f_max / 2)
    U = []
    for k in knots:
        u, gamma = allocate(plant.A, ff[k], plant.f_max)
        U.append(u if math.isfinite(gamma) and gamma <= 1.0 + TOL else centre)
    U = np.array(U)
    steps = np.arange(len(ff))
    return np.stack([np.interp(steps, knots, U[:, j]) for j in range(U.shape[1])], axis=1)


def _errors(R, Rd, data, b, ref, k) -> np.ndarray:
    """x = [e_p, theta, e_v, e_omega] in the reference body frame (module docstring)."""
    e_p = Rd.T @ (np.array(data.xpos[b]) - ref["position"][k])
    e_v = Rd.T @ (np.array(data.qvel[:3]) - ref["velocity"][k])
    theta = rotation_vector(Rd.T @ R)
    e_w = np.array(data.qvel[3:6]) - R.T @ Rd @ ref["angular_velocity"][k]
    return np.concatenate([e_p, theta, e_v, e_w])
