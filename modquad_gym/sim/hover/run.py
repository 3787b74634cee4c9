"""Free flight: the structure hovers under gravity and holds its pose against each task's load.

A take-off segment comes first (index -1, not part of the task metrics): the structure starts a
few centimetres off ``(0, 0, HOME_HEIGHT)`` and tilted, and converges while hovering at half
thrust (the centre of its feasible set). Then the task wrenches are held in turn,
``seconds_per_wrench`` each, with no reset in between, except after a diverged segment: the
structure then restarts at home, level, at rest, at the hover equilibrium of that segment's load
(the take-off trim if the load is infeasible), so one divergence does not spill into the next
segment's numbers. The parts: :mod:`.load` (the external load and its ramps), :mod:`.gains`,
:mod:`.allocator`, :mod:`.estimator`, :mod:`.controller`, :mod:`.recorder`.
"""

from __future__ import annotations

import contextlib
import math
from collections.abc import Callable, Iterator

import numpy as np

from modquad_gym.core.bars import progress_bar
from modquad_gym.core.extras import import_optional
from modquad_gym.core.validation import check_wrenches
from modquad_gym.geometry.structure import Structure
from modquad_gym.oracle import TOL, feasible
from modquad_gym.sim.hover.config import HoverConfig
from modquad_gym.sim.hover.controller import HoverController
from modquad_gym.sim.hover.linearization import Plant
from modquad_gym.sim.hover.load import LoadRamp, external_wrench, step_headroom
from modquad_gym.sim.hover.recorder import Recorder, drift_reason, estimate_error, settles_at_rest
from modquad_gym.sim.hover.result import HoverResult
from modquad_gym.sim.hover.rotations import rotation_angle, rotation_vector
from modquad_gym.sim.model import HOME_HEIGHT, SimModel, body_rotation, build_model


class Flight:
    """The MuJoCo side of a hover: reset, apply the load, read the state, step."""

    def __init__(self, sim: SimModel, cfg: HoverConfig) -> None:
        mujoco = import_optional("mujoco")

        self._mj = mujoco
        self.sim = sim
        self.cfg = cfg
        self.data = mujoco.MjData(sim.model)
        self.body = sim.body_id
        self.substeps, self.ctrl_dt = cfg.control_steps(sim.model.opt.timestep)
        self.p_ref = np.array([0.0, 0.0, HOME_HEIGHT])
        self.gravity = np.array(sim.model.opt.gravity)

    def reset(self, perturb: bool) -> None:
        """Back to rest at home; ``perturb``: offset and tilted as configured (take-off)."""
        self._mj.mj_resetData(self.sim.model, self.data)
        if perturb:
            self.data.qpos[:3] = self.p_ref + np.asarray(self.cfg.initial_offset, dtype=float)
            half = 0.5 * self.cfg.initial_tilt_rad
            axis = np.array([1.0, 1.0, 0.0]) / math.sqrt(2.0)
            self.data.qpos[3:7] = np.concatenate([[math.cos(half)], math.sin(half) * axis])
        self._mj.mj_forward(self.sim.model, self.data)

    def apply_load(self, w: np.ndarray, R: np.ndarray | None = None) -> None:
        """Apply ``-(w + gravity wrench)`` at the COM (w world-fixed, or body-fixed via R)."""
        self.data.xfrc_applied[self.body] = external_wrench(w, self.sim.mass, self.gravity, R)

    def state(self) -> tuple:
        """(R, e_p, theta, v, omega): attitude, position error, rotation vector, velocities."""
        R = body_rotation(self.sim, self.data)
        e_p = np.array(self.data.xpos[self.body]) - self.p_ref
        v = np.array(self.data.qvel[:3])
        omega = np.array(self.data.qvel[3:6])
        return R, e_p, rotation_vector(R), v, omega

    def step(self, u: np.ndarray) -> tuple[float, float]:
        """Send u for one control period; (position error m, attitude error rad) after it."""
        self.data.ctrl[:] = u
        self._mj.mj_step(self.sim.model, self.data, nstep=self.substeps)
        pos_err = float(np.linalg.norm(self.p_ref - self.data.xpos[self.body]))
        return pos_err, rotation_angle(body_rotation(self.sim, self.data))


def _flight_model(structure: Structure | SimModel, f_max: float) -> SimModel:
    if isinstance(structure, SimModel):
        if structure.bench:
            raise ValueError("run_hover needs a flight model (bench=False): the bench is welded")
        return structure
    return build_model(structure, f_max, bench=False)


def run_hover(
    structure: Structure | SimModel,
    wrenches: np.ndarray,
    config: HoverConfig | None = None,
    *,
    on_segment: Callable[[float], object] | None = None,
    **changes: object,
) -> HoverResult:
    """Fly the structure and hold its pose against each task wrench's load.

    Args:
        structure: a structure, or a flight model from ``build_model(..., bench=False)``.
        wrenches: (t, 6) task wrenches in {S} (the total the rotors must produce).
        config: how to fly (default :class:`HoverConfig`).
        on_segment: called after each segment (the take-off too) with its planned simulated
            seconds, e.g. a progress bar's ``update``.
        **changes: fields of ``config`` to replace, e.g. ``known_load=False``.
    """
    cfg = HoverConfig.make(config, **changes)
    W = check_wrenches(wrenches)
    sim = _flight_model(structure, cfg.f_max)
    flight = Flight(sim, cfg)
    plant = Plant.of(sim)
    ctrl = HoverController(plant, cfg, flight.ctrl_dt)
    n_ctrl, n_takeoff, _ = cfg.segment_steps()
    segments = [(i, w, n_ctrl) for i, w in enumerate(W)]
    if n_takeoff > 0:
        segments.insert(0, (-1, plant.trim, n_takeoff))
    flight.reset(perturb=n_takeoff > 0)
    rec = Recorder(segments, sim.n_rotors)
    w_prev = plant.trim
    for segment in segments:
        w_prev = _fly_segment(flight, ctrl, rec, segment, w_prev)
        if on_segment is not None:
            on_segment(segment[2] * flight.ctrl_dt)
    return rec.result(W, cfg, sim.f_max, feasible(plant.A, W, sim.f_max))


def _fly_segment(
    flight: Flight, ctrl: HoverController, rec: Recorder, segment: tuple, w_prev: np.ndarray
) -> np.ndarray:
    """Hold one segment's load; return the load the next segment changes from."""
    cfg, dt = flight.cfg, flight.ctrl_dt
    i, w, n_steps = segment
    n_settled = cfg.segment_steps()[2]
    gamma = ctrl.begin_segment(w)
    n_ramp = min(round(cfg.ramp_seconds * cfg.control_hz), n_steps) if i >= 0 else 0
    ramp = LoadRamp(w_prev, w, n_ramp, cfg.load_ramp_profile)
    start = rec.k
    cut = None
    for step in range(n_steps):
        w_load = ramp.at(step)
        if cfg.load_frame == "world" and ramp.changes(step):
            flight.apply_load(w_load)
        ctrl.reschedule((start + step) * dt)
        state = flight.state()
        u, w_ff = ctrl.command(w, state)
        if cfg.load_frame == "body":
            flight.apply_load(w_load, state[0])
        pos_err, att_err = flight.step(u)
        saturated = ctrl.alloc.saturated(u)
        settled = step >= n_steps - n_settled
        rec.record((start + step + 1) * dt, pos_err, att_err, u, w_load, w_ff, saturated, settled)
        cut = drift_reason(pos_err, att_err, cfg)
        if cut:
            break
    cut_short = cut is not None
    if not cut_short and pos_err > cfg.recover_limit_m:  # ran its course but did not come back
        cut = f"ended {pos_err:.3g} m away (not back within {cfg.recover_limit_m:g} m)"
    est = ctrl.estimator
    rec.close(
        i,
        start,
        gamma,
        "+".join(sorted(ctrl.kinds)),
        cut,
        cut_short=cut_short,
        ctrl_dt=dt,
        load_estimate_error=None if est is None else estimate_error(est.estimate, w),
        step_headroom=(
            step_headroom(ctrl.plant.A, w, w_prev, ctrl.plant.f_max)
            if est is not None and i >= 0
            else None
        ),
    )
    if not cut:
        return w
    # restart at rest at home, at the equilibrium of this load if it has one, else the trim
    w_next = w if settles_at_rest(gamma, TOL) else ctrl.plant.trim
    rec.k = start + n_steps
    flight.reset(perturb=False)
    ctrl.restart(w_next, rec.k * dt)
    return w_next


@contextlib.contextmanager
def hover_bar(progress: bool, config: HoverConfig, segments: list[int]) -> Iterator:
    """A tqdm bar on stderr over the simulated seconds of flights of ``segments`` task
    segments each (and a take-off each), as :func:`run_hover`'s ``on_segment``; None (no
    bar) without ``progress``. The bar is closed at the end."""
    n_ctrl, n_takeoff, _ = config.segment_steps()
    total = sum(n_takeoff + k * n_ctrl for k in segments) / config.control_hz
    bar = progress_bar(progress, "hover", total=total,
                       bar_format="{desc}: {percentage:3.0f}%|{bar}| {n:.0f}/{total:.0f} "
                       "simulated s [{elapsed}<{remaining}]")  # fmt: skip
    if bar is None:
        yield None
        return
    try:  # never past the total: the segments' seconds, summed, may pass it by round-off
        yield lambda seconds: bar.update(min(seconds, bar.total - bar.n))
    finally:
        bar.close()
