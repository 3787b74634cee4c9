"""The hover through a failure: hold one rotor wrench at home while some rotors stop.

:func:`hover_with_failure` is the flight :func:`modquad_gym.sim.fault_flight.fly_with_failure`
flies for a static task (a trajectory task flies
:func:`modquad_gym.sim.track.fly_trajectory` instead); :mod:`modquad_gym.sim.failure` says what
happens at the failure and at its detection.
"""

from __future__ import annotations

import numpy as np

from modquad_gym.core.validation import check_real, check_wrenches
from modquad_gym.geometry.structure import Structure
from modquad_gym.oracle import TOL, check_f_max
from modquad_gym.sim.detector import make_detector
from modquad_gym.sim.failure import Failure
from modquad_gym.sim.track import TrackResult


def hover_with_failure(
    structure: Structure,
    w: np.ndarray,
    failure: Failure,
    seconds: float,
    f_max: float = 1.0,
    config=None,
    detector=None,
) -> TrackResult:
    """Hold the rotor wrench ``w`` (6,) at home for ``seconds`` through ``failure``.

    Starts at rest, level, at home; the world-fixed load ``-(w + gravity wrench)`` acts
    throughout, the load known to the controller (:class:`~modquad_gym.sim.hover.HoverController`
    with a :class:`~modquad_gym.sim.hover.HoverConfig`, ``config`` or the defaults). Stopped
    early past the hover's drift limits (``diverged`` says why). Arrays per control step, the
    state read before the step as in :func:`~modquad_gym.sim.track.fly_trajectory`. With a
    ``detector`` (:class:`~modquad_gym.sim.detector.DetectorConfig`, or a (config, noise)
    pair) the controller is not told of the failure: it switches when the
    :class:`~modquad_gym.sim.detector.FailureDetector` decides, to the rotors it names, again
    at each revision (``run.detection``: (first time, columns named last) or None)."""
    from modquad_gym.sim.hover import HoverConfig, HoverController, Plant, rotation_angle
    from modquad_gym.sim.hover.recorder import drift_reason
    from modquad_gym.sim.hover.run import Flight
    from modquad_gym.sim.model import build_model

    seconds = check_real(seconds, "seconds", positive=True)
    if not isinstance(failure, Failure):
        raise ValueError(f"failure must be a Failure, got {type(failure).__name__}")
    failure.check_rotors(structure.configuration_matrix().shape[1])
    w = check_wrenches(np.asarray(w, dtype=float)[None])[0]
    cfg = HoverConfig.make(config, f_max=check_f_max(f_max), takeoff_seconds=0.0,
                           known_load=True, load_frame="world")  # fmt: skip
    sim = build_model(structure, cfg.f_max, bench=False)
    flight = Flight(sim, cfg)
    flight.reset(perturb=False)
    plant = Plant.of(sim)
    ctrl = HoverController(plant, cfg, flight.ctrl_dt)
    ctrl.begin_segment(w)
    flight.apply_load(w)
    m, dt = sim.n_rotors, flight.ctrl_dt
    N = max(1, round(seconds / dt))
    t = np.arange(N) * dt
    flown, att, quat_ = np.zeros((N, 3)), np.zeros(N), np.zeros((N, 4))
    inputs, saturated = np.zeros((N, m)), np.zeros(N, dtype=bool)
    working, known, diverged = np.ones(m, dtype=bool), False, None
    watch = make_detector(detector, plant, failure.kind, dt)
    believed = failure
    for k in range(N):
        if watch is None and not known and t[k] >= failure.detected_s - 1e-9:
            ctrl, known = _failed_controller(failure, plant, cfg, dt, w), True
        state = flight.state()
        u = np.zeros(m)
        if ctrl is not None:  # the intact controller, or the reduced one once it knows
            u[believed.working(m) if known else slice(None)], _ = ctrl.command(w, state)
        if watch is not None:  # a first decision, or a revised one
            load = np.array(flight.data.xfrc_applied[flight.body])
            hit = watch.update(t[k], state[0], state[3], state[4], u, load, flight.gravity)
            if hit is not None:
                believed = Failure(tuple(hit[1]), failure.time_s, 0.0, failure.kind)
                ctrl, known = _failed_controller(believed, plant, cfg, dt, w), True
        if t[k] >= failure.time_s - 1e-9:
            working = failure.working(m)
            u[~working] = 0.0  # the failed rotors give no thrust, whatever is commanded
        flown[k] = flight.data.xpos[flight.body]
        quat_[k] = flight.data.xquat[flight.body]
        att[k] = rotation_angle(state[0])
        inputs[k], saturated[k] = u, _at_limit(u[working], cfg.f_max)
        diverged = drift_reason(float(np.linalg.norm(state[1])), att[k], cfg)
        if diverged:
            diverged = f"{diverged} at t = {t[k]:.3g} s"
            break
        flight.step(u)
    n = k + 1
    desired = np.tile(flight.p_ref, (n, 1))
    run = TrackResult(t[:n], desired, flown[:n], quat_[:n], att[:n], inputs[:n],
                      saturated[:n], np.tile(w, (n, 1)), cfg.f_max, diverged)  # fmt: skip
    run.detection = None if watch is None else watch.detected
    run.detector = watch
    return run


def _failed_controller(failure: Failure, plant, cfg, dt: float, w: np.ndarray):
    """The hover controller once the failure is known (None when no rotor is left)."""
    from modquad_gym.sim.hover import HoverController

    reduced = failure.plant(plant)
    if reduced is None:
        return None
    ctrl = HoverController(reduced, cfg, dt)
    ctrl.begin_segment(w)
    return ctrl


def _at_limit(u: np.ndarray, f_max: float) -> bool:
    tol = TOL * f_max
    return bool(np.any((u <= tol) | (u >= f_max - tol)))
