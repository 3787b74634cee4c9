"""Fly a structure through its worst single failure (a rotor, or a module's rotors, stop).

:func:`fly_with_failure` picks the failure of kind ``fault`` that leaves the smallest margin over
the task's rotor wrenches (:func:`worst_failure`, the oracle's
:meth:`~modquad_gym.oracle.faults.FaultTolerance.worst_failure`) and flies it in MuJoCo
(:mod:`modquad_gym.sim.failure`: the failed rotors' thrust is 0 from the failure on; after a
detection delay the allocator and the gains work on A without them):

* a **static task** (wrenches): the structure starts at rest at home, level, holding the task
  wrench with the smallest margin under that failure (the hover's load convention,
  :mod:`modquad_gym.sim.hover.load`: the external load is ``-(w + gravity wrench)``, so the
  rotors must produce w, with the load known to the controller), for ``seconds``; the failure
  strikes halfway (:func:`hover_with_failure`);
* a **dynamic task**: the flight along its trajectory (:func:`modquad_gym.sim.track.fly_trajectory`)
  with the failure halfway through the trajectory's duration, or :data:`LEAD_S` before the
  moment the failure hurts most (the sample with the smallest margin after it) when that moment
  comes earlier.

Reported (:meth:`FaultFlight.summary`): from the failure on, the largest distance between the
flown and desired COM (``fault_max_position_error_m``), the share of steps with a working rotor
at 0 or f_max (``fault_saturated_fraction``); which rotors failed (module, cell) and when; the
failure's margin and whether every such failure is tolerated (``oracle.faults.tolerates``).
A certified tolerant structure should keep within :data:`GOAL_M` after the failure; one that does
not saturates and drifts. ``modquad validate --fault`` (:mod:`.validate_fault`) flies it and the
intact minimum, with pictures.
"""

from __future__ import annotations

import os

os.environ.setdefault("MUJOCO_GL", "egl")  # before mujoco is first imported: headless rendering

from dataclasses import dataclass  # noqa: E402

import numpy as np  # noqa: E402

from modquad_gym.core.validation import check_real, check_wrenches  # noqa: E402
from modquad_gym.geometry.structure import Structure  # noqa: E402
from modquad_gym.oracle import TOL, check_f_max, check_task_scale, margin  # noqa: E402
from modquad_gym.oracle.failures import module_failures  # noqa: E402
from modquad_gym.oracle.faults import FaultTolerance, check_fault, failure_sets  # noqa: E402
from modquad_gym.search.checker import LP_ROTORS  # noqa: E402
from modquad_gym.sim.detector import make_detector  # noqa: E402
from modquad_gym.sim.failure import DETECTION_DELAY_S, Failure, flown_delay  # noqa: E402, F401
from modquad_gym.sim.inertial import check_simulable  # noqa: E402
from modquad_gym.sim.report import finite_or_none  # noqa: E402
from modquad_gym.sim.track import TrackConfig, TrackResult  # noqa: E402

FAULT_HOVER_SECONDS = 4.0
"""Simulated seconds of the hover through a failure (static tasks); the failure is at half."""

LEAD_S = 0.5
"""Dynamic task: the failure strikes halfway through the trajectory, or this many seconds before
the moment it hurts most (its sample of smallest margin) when that moment comes earlier, so that
the flight after the failure always passes it."""

GOAL_M = 0.05
"""The position error a tolerant structure should keep within after the failure (5 cm)."""


def failure_columns(structure: Structure, fault: str) -> list[np.ndarray]:
    """The column sets of A that one failure of kind ``fault`` removes: each rotor, each
    module's rotors (its own rotor count) or each pair of rotors, in the order of
    :meth:`~modquad_gym.geometry.structure.Structure.configuration_matrix`."""
    fault = check_fault(fault)
    starts = np.cumsum([0] + [m.n_rotors for m in structure.modules])
    if fault not in ("module", "rotor+module"):  # each rotor, or each pair of rotors
        return failure_sets(int(starts[-1]), fault)
    return module_failures(starts, fault)


@dataclass(frozen=True)
class WorstFailure:
    """The failure that leaves the smallest margin over a task's rotor wrenches.

    Attributes:
        index: its index among :func:`failure_columns`.
        columns: the rotors it stops.
        margin: the smallest margin over the wrenches after it (< 0: some wrench is lost),
            signed as :func:`~modquad_gym.oracle.faults.fault_margin` signs it.
        row: the wrench with that margin.
        tolerates: the structure keeps every wrench after every failure of that kind.
    """

    index: int
    columns: np.ndarray
    margin: float
    row: int
    tolerates: bool


def worst_failure(structure: Structure, W: np.ndarray, f_max: float, fault: str) -> WorstFailure:
    """The failure of kind ``fault`` that leaves the smallest margin over the rotor wrenches W
    (rows of a (t, 6) array), and the wrench nearest the boundary after it."""
    W = check_wrenches(W)
    f_max = check_f_max(f_max)
    A = np.array(structure.configuration_matrix())
    sets = failure_columns(structure, fault)
    tol = FaultTolerance(A, f_max, sets)
    method = "daqp" if A.shape[1] <= LP_ROTORS else "compiled"  # as the searches decide
    i, worst = tol.worst_failure(W, method)
    tolerates = bool(tol.decide(W, method).all())
    keep = np.ones(A.shape[1], dtype=bool)
    keep[sets[i]] = False
    if keep.any():
        row = int(np.argmin(margin(A[:, keep], W, f_max, method)))
    else:  # a one-module structure without its module: nothing is left
        row = int(np.argmax(np.linalg.norm(W, axis=1)))
    if tolerates and worst < 0:  # the LP's round-off against the exact decision
        worst = 0.0
    elif not tolerates and worst >= 0:
        worst = float(np.nextafter(-TOL, -np.inf))
    return WorstFailure(i, sets[i], float(worst), row, tolerates)


@dataclass
class FaultFlight:
    """A flight through a failure and the failure it went through.

    Attributes:
        structure: the structure flown.
        flight: ``"hover"`` (static task) or ``"trajectory"`` (dynamic task).
        fault: ``"rotor"`` or ``"module"``.
        failure: what stopped and when (:class:`~modquad_gym.sim.failure.Failure`).
        worst: why this failure (:class:`WorstFailure`).
        run: the time series (:class:`~modquad_gym.sim.track.TrackResult`; for a hover the
            desired position is home throughout and ``wrench_ff`` the held wrench).
        task_name: for titles.
    """

    structure: Structure
    flight: str
    fault: str
    failure: Failure
    worst: WorstFailure
    run: TrackResult
    task_name: str = ""

    @property
    def after(self) -> np.ndarray:
        """bool (N,): the control steps from the failure on."""
        return self.run.t >= self.failure.time_s - 1e-9

    @property
    def max_position_error_m(self) -> float:
        """Largest distance between flown and desired COM from the failure on (m; up to the
        drift limit where the flight was stopped)."""
        e = self.run.position_error[self.after]
        return float(e.max(initial=0.0))

    @property
    def before_max_position_error_m(self) -> float:
        """Largest position error before the failure (m)."""
        return float(self.run.position_error[~self.after].max(initial=0.0))

    @property
    def max_attitude_error_rad(self) -> float:
        return float(self.run.attitude_error[self.after].max(initial=0.0))

    @property
    def saturated_fraction(self) -> float:
        """Share of the control steps from the failure on in which some working rotor is at 0
        or f_max."""
        sat = self.run.saturated[self.after]
        return float(sat.mean()) if len(sat) else 0.0

    @property
    def within_goal(self) -> bool:
        """Flown to the end and within :data:`GOAL_M` after the failure."""
        return self.run.diverged is None and self.max_position_error_m <= GOAL_M

    def failed_part(self) -> dict:
        """The failed module (index in the cells and its cell; a rotor+module failure's module)
        and, for a rotor failure, which of the module's rotors (0-based)."""
        starts = np.cumsum([0] + [m.n_rotors for m in self.structure.modules])
        first = self.failure.columns[0]
        module = int(np.searchsorted(starts, first, side="right") - 1)
        rotor = int(first - starts[module]) if "module" not in self.fault else None
        cell = list(self.structure.cells[module])
        return {"fault_failed_module": module, "fault_failed_cell": cell,
                "fault_failed_rotor_in_module": rotor}  # fmt: skip

    def summary(self) -> dict:
        """The ``fault_*`` keys of a validation record (JSON-ready; None for a number that is
        not finite, e.g. a margin of -inf: a wrench off the span of the working rotors):

        ``fault`` (kind), ``fault_flight`` (``"hover"`` or ``"trajectory"``), ``fault_tolerates``
        (every wrench feasible after every failure of that kind), ``fault_worst_margin`` (the
        smallest margin over the task after the failure flown, the worst one),
        ``fault_failed_rotors`` (columns of A), ``fault_failed_module`` (index in the cells),
        ``fault_failed_cell``, ``fault_failed_rotor_in_module`` (rotor failures),
        ``fault_time_s``, ``fault_detection_delay_s`` (the delay flown; None with a detector,
        whose ``fault_detected_after_s`` says when it decided), ``fault_seconds`` (flight length),
        ``fault_hardest_row`` (the task row, wrench or trajectory sample, of that margin; the
        wrench a hover holds), ``fault_max_position_error_m`` and ``fault_saturated_fraction``
        (from the failure on), ``fault_max_attitude_error_rad``,
        ``fault_before_max_position_error_m``, ``fault_diverged`` (why the flight was stopped,
        or None) and ``fault_within_5cm``."""
        return {
            "fault": self.fault,
            "fault_flight": self.flight,
            "fault_tolerates": self.worst.tolerates,
            "fault_worst_margin": finite_or_none(self.worst.margin),
            "fault_failed_rotors": list(self.failure.columns),
            **self.failed_part(),
            "fault_time_s": self.failure.time_s,
            "fault_detection_delay_s": None if self.detection() else self.failure.detection_delay_s,
            "fault_seconds": float(self.run.t[-1]) if len(self.run.t) else 0.0,
            "fault_hardest_row": self.worst.row,
            "fault_max_position_error_m": finite_or_none(self.max_position_error_m),
            "fault_saturated_fraction": self.saturated_fraction,
            "fault_max_attitude_error_rad": finite_or_none(self.max_attitude_error_rad),
            "fault_before_max_position_error_m": finite_or_none(self.before_max_position_error_m),
            "fault_diverged": self.run.diverged,
            "fault_within_5cm": self.within_goal,
            **self.detection(),
        }

    def detection(self) -> dict:
        """With a detector: how long after the failure it first decided (None: never), the
        rotors it named last, and each decision [seconds after the failure, rotors] in order
        (more than one where it revised a wrong isolation)."""
        watch = getattr(self.run, "detector", None)
        if watch is None:
            return {}
        made = [[float(t - self.failure.time_s), [int(c) for c in S]] for t, S in watch.decisions]
        return {"fault_detected_after_s": made[0][0] if made else None,
                "fault_detected_rotors": made[-1][1] if made else None,
                "fault_detector_decisions": made}  # fmt: skip


def hover_with_failure(
    structure: Structure,
    w: np.ndarray,
    failure: Failure,
    seconds: float = FAULT_HOVER_SECONDS,
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


def _rotor_wrenches(structure: Structure, task, f_max, seconds) -> tuple[np.ndarray, float]:
    """(rotor wrenches, f_max) of a task object (its own f_max; options that do not apply
    refused) or of a (t, 6) array of total wrenches (``f_max``, default 1)."""
    from modquad_gym.sim.failure import refuse_unflown

    if hasattr(task, "rotor_wrenches"):
        refuse_unflown(task, f_max, seconds)
        task, f_max = task.rotor_wrenches(structure), task.f_max
    f_max = check_f_max(1.0 if f_max is None else f_max)
    return check_task_scale(task, f_max), f_max  # the searches' scale, as validate's


def fly_with_failure(
    structure: Structure,
    task: object,
    fault: str = "rotor",
    *,
    seconds: float | None = None,
    detection_delay_s: float | None = None,
    f_max: float | None = None,
    track_config: TrackConfig | None = None,
    detector: object = None,
) -> FaultFlight:
    """Fly ``structure`` on ``task`` through its worst single failure of kind ``fault``.

    Args:
        structure: the structure to fly.
        task: a task (:class:`~modquad_gym.tasks.TaskRequirement`, a
            :class:`~modquad_gym.dynamics.DynamicTask`, anything with ``rotor_wrenches`` and
            ``f_max``) or a (t, 6) array of total rotor wrenches.
        fault: ``"rotor"`` or ``"module"``.
        seconds: static task or array: how long the hover lasts (the failure strikes at
            half; default :data:`FAULT_HOVER_SECONDS`). Refused with a dynamic task.
        detection_delay_s: seconds before the controller knows (:mod:`~modquad_gym.sim.failure`;
            default :data:`DETECTION_DELAY_S`). Not with a ``detector``, which decides that.
        f_max: the thrust limit of an array task (default 1); refused with a task object,
            which carries its own (``task.with_f_max``).
        track_config: dynamic task: how to fly the trajectory.
        detector: a :class:`~modquad_gym.sim.detector.DetectorConfig` (or a
            (config, :class:`~modquad_gym.sim.detector.SensorNoise`) pair): the controller is
            not told of the failure, the detector decides when and which rotors (a
            ``detection_delay_s`` beside it is refused: it would not be flown); the summary's
            ``fault_detection_delay_s`` is then None and it adds ``fault_detected_after_s`` (the
            delay flown), ``fault_detected_rotors`` and ``fault_detector_decisions``.

    Returns:
        A :class:`FaultFlight`; ``summary()`` is its record (``fault_max_position_error_m``,
        ``fault_saturated_fraction``, ``fault_failed_rotors``, ``fault_time_s``, ...).
    """
    from modquad_gym.dynamics import DynamicTask

    if not isinstance(structure, Structure):
        raise ValueError(f"structure must be a Structure, got {type(structure).__name__}")
    check_simulable(structure)  # before the worst failure's search
    fault = check_fault(fault)
    detection_delay_s = flown_delay(detection_delay_s, detector)
    W, fm = _rotor_wrenches(structure, task, f_max, seconds)
    worst = worst_failure(structure, W, fm, fault)
    name = getattr(task, "name", "") or ""
    if isinstance(task, DynamicTask):
        from modquad_gym.sim.track import fly_trajectory

        traj = task.trajectory
        hardest = float(traj.t[worst.row] - traj.t[0])
        at = min(traj.duration / 2.0, max(0.0, hardest - LEAD_S))
        failure = Failure(tuple(worst.columns), at, detection_delay_s, fault)
        run = fly_trajectory(structure, task, track_config, failure=failure, detector=detector)
        return FaultFlight(structure, "trajectory", fault, failure, worst, run, name)
    seconds = FAULT_HOVER_SECONDS if seconds is None else seconds  # read at the call
    seconds = check_real(seconds, "seconds", positive=True)
    failure = Failure(tuple(worst.columns), seconds / 2.0, detection_delay_s, fault)
    run = hover_with_failure(structure, W[worst.row], failure, seconds, fm, detector=detector)
    return FaultFlight(structure, "hover", fault, failure, worst, run, name)
