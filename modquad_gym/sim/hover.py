"""Free flight: the structure hovers under gravity and holds its pose against each task's load.

Setup (gravity on, no wall): a take-off segment first (not part of the task metrics): the structure
starts a few centimetres off (0, 0, HOME_HEIGHT) and tilted, and converges while hovering at half
thrust (the centre of its feasible set). Then the task wrenches are applied in turn,
``seconds_per_wrench`` each, with no reset in between.

External load. A task wrench w is the *total* wrench the rotors must produce (gravity
compensation folded into f_z, normalised units). During segment i an external wrench ``d`` is
applied at the COM through ``xfrc_applied`` such that at equilibrium the rotors produce exactly w:

    d = -(w + gravity wrench),  in {S}:  d_S = -(w + [R^T m g ; 0]),

recomputed at every control step with the current attitude R (a load that follows the body, like a
tool pressed against a surface), and rotated into the world frame for ``xfrc_applied``. So gravity
plus load is ``-w`` in {S}, and hovering in place needs A u = w. This keeps the physical weight of
the modules (``module_mass``) and the normalised task units independent.

Controller (``control_hz``, default 500 Hz; the physics steps at 1 kHz):

* desired wrench in {S}:
  ``w_des = w + [R^T m (Kp e_p - Kd v) ; J (-Kr e_R - Kw omega) + omega x J omega]``
  with position error e_p = p_ref - p (world), velocity v (world), attitude error
  ``e_R = vee(R - R^T) / 2`` (reference level, R_ref = I) and body rates omega. Gains are set by
  natural frequencies (``omega_pos``, ``omega_att``, critically damped), scaled by the mass m and
  the inertia J, so they suit any structure. The feed-forward is the task wrench itself (the task
  is known; the feedback only corrects).
* bounded allocation, u in [0, f_max]: ``u = u_w + A^+ (w_des - w)`` with u_w the oracle's most
  centred exact allocation of w (:func:`modquad_gym.oracle.allocate`, once per segment). If that
  leaves the box by more than 1e-6 f_max, the bounded least-squares problem
  ``min |A u - w_des| s.t. 0 <= u <= f_max`` is solved instead (scipy ``lsq_linear``). Whatever
  the path, the rotors receive a u inside the box, and saturation is reported honestly: a control
  step counts as saturated when any rotor sits at 0 or f_max (within 1e-6 f_max).

Metrics per segment, over its settled part (the last ``settle_fraction`` of it): maximum position
error (m), maximum attitude error (rad, the rotation angle of R), and the saturated fraction.

Rank-deficient structures (one module: rank 4, a straight line: rank 5) cannot hold a general
load in every DOF: A^+ only reaches range(A), so the unactuated directions drift, and A^+ maps
part of an unreachable demand (e.g. a lateral force for one module) onto reachable torques, so such
structures also tilt; no underactuated (tilt-to-translate) controller is attempted. The run does not
crash: a segment whose position error exceeds ``drift_limit_m``, whose attitude error exceeds
``drift_limit_rad`` (past that a body-following load means little) or whose state becomes
non-finite ends early, is marked ``diverged`` and counts in full in the metrics; the next segment
restarts from home, at rest. An infeasible wrench fails the same way: the rotors saturate, the net
wrench cannot vanish, and the structure drifts.

Because the feed-forward equals the load exactly, a feasible wrench is held with no transient at
its switch-on; the feedback matters during take-off, for rank-deficient structures and for
infeasible wrenches, where the plots show it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ..oracle import TOL, allocate, check_f_max, check_wrenches, feasible
from ..structure import Structure
from .model import HOME_HEIGHT, SimModel, body_rotation, build_model


@dataclass(frozen=True)
class HoverGains:
    """Critically damped PD gains as natural frequencies (rad/s), scaled by mass and inertia."""

    omega_pos: float = 4.0
    omega_att: float = 8.0
    damping: float = 1.0


@dataclass
class HoverResult:
    """Time series and per-segment metrics of a hover run.

    Attributes:
        wrenches: (t, 6) task wrenches, one segment each.
        f_max: rotor thrust limit.
        time: (k,) control-step times in seconds.
        segment: (k,) the segment (wrench index, -1 for the take-off) of each control step.
        position_error: (k,) |p_ref - p| in metres.
        attitude_error: (k,) rotation angle of R away from level, radians.
        u: (k, 4n) rotor inputs sent.
        saturated: (k,) some rotor at 0 or f_max (within 1e-6 f_max).
        settled: (k,) the step lies in the settled part of a task segment.
        gamma: (t,) the oracle's gamma of each task wrench (<= 1 feasible, inf off range(A)).
        feasible: (t,) the oracle's verdict.
        diverged: (t,) the segment was cut short by drift (see the module docstring).
    """

    wrenches: np.ndarray
    f_max: float
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
    segment_metrics: list[dict] = field(default_factory=list)
    """Per segment (take-off first, index -1): gamma, diverged, settled errors, saturation."""

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


def _vee_skew(M: np.ndarray) -> np.ndarray:
    return 0.5 * np.array([M[2, 1] - M[1, 2], M[0, 2] - M[2, 0], M[1, 0] - M[0, 1]])


def _cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """a x b for 3-vectors (np.cross is slow for one pair inside the control loop)."""
    return np.array(
        [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]
    )


def rotation_angle(R: np.ndarray) -> float:
    """Angle (rad) of the rotation R, robust near 0 and pi."""
    s = np.linalg.norm(_vee_skew(R - R.T))
    c = 0.5 * (np.trace(R) - 1.0)
    return float(math.atan2(s, c))


def body_inertia(sim: SimModel) -> np.ndarray:
    """J (3, 3): the structure's inertia about its COM in {S}."""
    m = sim.model
    b = sim.body_id
    w, x, y, z = m.body_iquat[b]
    Q = np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
            [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
            [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
        ]
    )
    return Q @ np.diag(m.body_inertia[b]) @ Q.T


class _Allocator:
    """Bounded allocation around the centred exact allocation of one task wrench."""

    def __init__(self, A: np.ndarray, f_max: float) -> None:
        self.A = A
        self.f_max = f_max
        self.pinv = np.linalg.pinv(A)
        self.tol = TOL * f_max

    def set_task(self, w: np.ndarray) -> float:
        self.w = w
        self.u_w, gamma = allocate(self.A, w, self.f_max)
        return gamma

    def __call__(self, w_des: np.ndarray) -> np.ndarray:
        u = self.u_w + self.pinv @ (w_des - self.w)
        if np.all(u >= -self.tol) and np.all(u <= self.f_max + self.tol):
            return np.clip(u, 0.0, self.f_max)
        from scipy.optimize import lsq_linear

        res = lsq_linear(self.A, w_des, bounds=(0.0, self.f_max), method="bvls")
        return np.clip(res.x, 0.0, self.f_max)


def run_hover(
    structure: Structure | SimModel,
    wrenches: np.ndarray,
    f_max: float = 1.0,
    seconds_per_wrench: float = 2.0,
    control_hz: float = 500.0,
    gains: HoverGains | None = None,
    takeoff_seconds: float = 2.0,
    initial_offset: tuple[float, float, float] = (0.03, -0.02, 0.02),
    initial_tilt_rad: float = 0.05,
    settle_fraction: float = 0.3,
    drift_limit_m: float = 1.0,
    drift_limit_rad: float = 1.0,
) -> HoverResult:
    """Fly the structure and hold its pose against each task wrench's load (module docstring).

    The run starts with a take-off segment (index -1, ``takeoff_seconds`` long, not part of the
    task metrics): the structure starts ``initial_offset`` away from the reference and tilted by
    ``initial_tilt_rad``, and hovers at half thrust (w = A 1 f_max / 2, the centre of the
    feasible set) until it has converged. Then each task wrench is held in turn.

    Args:
        structure: a structure, or a flight model from ``build_model(..., bench=False)``.
        wrenches: (t, 6) task wrenches in {S} (the total the rotors must produce).
        f_max: rotor thrust limit (ignored when a model is given).
        seconds_per_wrench: simulated seconds per segment.
        control_hz: controller rate; must divide the physics rate (1 / timestep).
        gains: PD gains (default :class:`HoverGains`).
        takeoff_seconds: length of the take-off segment (0 skips it and the perturbation).
        initial_offset: start position minus the reference, metres (world frame).
        initial_tilt_rad: start tilt about the axis (1, 1, 0) / sqrt(2).
        settle_fraction: the last fraction of each segment over which errors are measured.
        drift_limit_m: position error that ends a segment as diverged.
        drift_limit_rad: attitude error that ends a segment as diverged.
    """
    import mujoco

    W = check_wrenches(wrenches)
    if isinstance(structure, SimModel):
        sim = structure
        if sim.bench:
            raise ValueError("run_hover needs a flight model (bench=False): the bench is welded")
    else:
        sim = build_model(structure, check_f_max(f_max), bench=False)
    if not (seconds_per_wrench > 0 and 0 < settle_fraction <= 1 and control_hz > 0):
        raise ValueError(
            f"need seconds_per_wrench > 0, 0 < settle_fraction <= 1, control_hz > 0; got "
            f"{seconds_per_wrench}, {settle_fraction}, {control_hz}"
        )
    if not takeoff_seconds >= 0:
        raise ValueError(f"takeoff_seconds must be >= 0, got {takeoff_seconds}")
    model = sim.model
    dt = model.opt.timestep
    substeps = round(1.0 / (control_hz * dt))
    if substeps < 1 or abs(substeps * control_hz * dt - 1.0) > 1e-9:
        raise ValueError(f"control_hz {control_hz} must divide the physics rate {1 / dt:g} Hz")
    n_ctrl = max(1, round(seconds_per_wrench * control_hz))
    n_takeoff = round(takeoff_seconds * control_hz)
    n_settled = max(1, round(settle_fraction * n_ctrl))
    gains = gains or HoverGains()
    m = sim.mass
    J = body_inertia(sim)
    g_world = np.array(model.opt.gravity)
    kp_p, kd_p = gains.omega_pos**2, 2 * gains.damping * gains.omega_pos
    kp_r, kd_r = gains.omega_att**2, 2 * gains.damping * gains.omega_att
    p_ref = np.array([0.0, 0.0, HOME_HEIGHT])
    alloc = _Allocator(sim.A, sim.f_max)
    b = sim.body_id
    tol = TOL * sim.f_max

    data = mujoco.MjData(model)

    def reset(perturb: bool) -> None:
        mujoco.mj_resetData(model, data)
        if perturb:
            data.qpos[:3] = p_ref + np.asarray(initial_offset, dtype=float)
            half = 0.5 * initial_tilt_rad
            axis = np.array([1.0, 1.0, 0.0]) / math.sqrt(2.0)
            data.qpos[3:7] = np.concatenate([[math.cos(half)], math.sin(half) * axis])
        mujoco.mj_forward(model, data)

    # segments: (index, wrench, control steps); -1 is the take-off at half thrust
    segments = [(i, w, n_ctrl) for i, w in enumerate(W)]
    if n_takeoff > 0:
        segments.insert(0, (-1, sim.A.sum(axis=1) * sim.f_max / 2.0, n_takeoff))
    reset(perturb=n_takeoff > 0)
    total = sum(n for _, _, n in segments)
    rec_t = np.full(total, np.nan)
    rec_seg = np.concatenate([np.full(n, i) for i, _, n in segments])
    rec_pos = np.full(total, np.nan)
    rec_att = np.full(total, np.nan)
    rec_u = np.full((total, sim.n_rotors), np.nan)
    rec_sat = np.zeros(total, dtype=bool)
    settled = np.zeros(total, dtype=bool)
    gammas = np.empty(len(W))
    diverged = np.zeros(len(W), dtype=bool)
    metrics = []
    k = 0
    for i, w, n_steps in segments:
        gamma = alloc.set_task(w)
        start = k
        cut = False
        for step in range(n_steps):
            R = body_rotation(sim, data)
            p = np.array(data.xpos[b])
            v = np.array(data.qvel[:3])
            omega = np.array(data.qvel[3:6])
            e_p = p_ref - p
            e_R = _vee_skew(R - R.T)
            f_corr = R.T @ (m * (kp_p * e_p - kd_p * v))
            t_corr = J @ (-kp_r * e_R - kd_r * omega) + _cross(omega, J @ omega)
            u = alloc(w + np.concatenate([f_corr, t_corr]))
            data.ctrl[:] = u
            # d = -(w + gravity wrench) in {S}, applied in the world frame at the COM
            data.xfrc_applied[b, :3] = -(R @ w[:3]) - m * g_world
            data.xfrc_applied[b, 3:] = -(R @ w[3:])
            mujoco.mj_step(model, data, nstep=substeps)
            pos_err = float(np.linalg.norm(p_ref - data.xpos[b]))
            att_err = rotation_angle(body_rotation(sim, data))
            rec_t[k] = (start + step + 1) / control_hz
            rec_pos[k] = pos_err
            rec_att[k] = att_err
            rec_u[k] = u
            rec_sat[k] = bool(np.any((u <= tol) | (u >= sim.f_max - tol)))
            settled[k] = step >= n_steps - n_settled
            k += 1
            if not np.isfinite(pos_err) or pos_err > drift_limit_m or att_err > drift_limit_rad:
                cut = True
                break
        if cut:
            settled[start:k] = True  # a diverged segment counts in full
        seg = slice(start, k)
        window = settled[seg]
        metrics.append(
            {
                "segment": i,
                "gamma": float(gamma) if np.isfinite(gamma) else None,
                "diverged": cut,
                "max_position_error_m": float(np.nanmax(rec_pos[seg][window])),
                "max_attitude_error_rad": float(np.nanmax(rec_att[seg][window])),
                "saturated_fraction": float(rec_sat[seg].mean()),
            }
        )
        if i >= 0:
            gammas[i] = gamma
            diverged[i] = cut
        if cut:
            k = start + n_steps
            reset(perturb=False)
    keep = ~np.isnan(rec_t)
    task = rec_seg >= 0
    return HoverResult(
        wrenches=W,
        f_max=sim.f_max,
        time=rec_t[keep],
        segment=rec_seg[keep],
        position_error=rec_pos[keep],
        attitude_error=rec_att[keep],
        u=rec_u[keep],
        saturated=rec_sat[keep],
        settled=(settled & task)[keep],
        gamma=gammas,
        feasible=np.asarray(feasible(sim.A, W, sim.f_max), dtype=bool),
        diverged=diverged,
        segment_metrics=metrics,
    )
