"""Fly a structure through its single failures (a rotor, or a module's rotors, stop).

:func:`fly_with_failure` flies, in MuJoCo, every failure of kind ``fault`` (default), the one
that leaves the smallest margin over the task's rotor wrenches only (:func:`worst_failure`, the
oracle's :meth:`~modquad_gym.oracle.faults.FaultTolerance.worst_failure`), or one numbered
failure (:mod:`modquad_gym.sim.failure`: the failed rotors' thrust is 0 from the failure on;
after a detection delay the allocator and the gains work on A without them):

* a **static task** (wrenches): the structure starts at rest at home, level, holding the task
  wrench with the smallest margin under that failure (the hover's load convention,
  :mod:`modquad_gym.sim.hover.load`: the external load is ``-(w + gravity wrench)``, so the
  rotors must produce w, with the load known to the controller) for :data:`FAULT_BEFORE_S`, then
  the failure strikes and it flies ``seconds`` more (:func:`~.fault_hover.hover_with_failure`);
* a **dynamic task**: the flight along its trajectory (:func:`modquad_gym.sim.track.fly_trajectory`)
  with the failure halfway through the trajectory's duration, or :data:`LEAD_S` before the
  moment the failure hurts most (the sample with the smallest margin after it) when that moment
  comes earlier; after the trajectory's end the motion goes on as it ended (at rest at its last
  point for a trajectory that ends at rest, as every generated motion does; at its final
  velocity otherwise; its final exerted wrench still applied) until ``seconds`` after the
  failure and at least two settling windows after the end (:func:`hold_seconds`), so that the
  verdict judges a steady reference with time to recover.

Reported (:meth:`~.fault_record.FaultFlight.summary`), for the flight that did worst: from the
failure on, the largest distance between the flown and desired COM
(``fault_max_position_error_m``), the share of steps with a working rotor at 0 or f_max
(``fault_saturated_fraction``); which rotors failed (module, cell) and when; the failure's margin
and whether every such failure is tolerated (``oracle.faults.tolerates``); the verdict
``fault_within_5cm``: never stopped, within :data:`GOAL_M` and settled at the end
(:mod:`~modquad_gym.sim.fault_verdict`). ``modquad validate --fault`` (:mod:`.validate_fault`)
flies it and the intact minimum, with pictures.
"""

from __future__ import annotations

import os

os.environ.setdefault("MUJOCO_GL", "egl")  # before mujoco is first imported: headless rendering

import numpy as np  # noqa: E402

from modquad_gym.core.bars import progress_bar  # noqa: E402
from modquad_gym.core.validation import check_real, check_wrenches  # noqa: E402
from modquad_gym.geometry.structure import Structure  # noqa: E402
from modquad_gym.oracle import TOL, check_f_max, check_task_scale, margin  # noqa: E402
from modquad_gym.oracle.failures import module_failures  # noqa: E402
from modquad_gym.oracle.faults import FaultTolerance, check_fault, failure_sets  # noqa: E402
from modquad_gym.search.checker import LP_ROTORS  # noqa: E402
from modquad_gym.sim.failure import DETECTION_DELAY_S, Failure, flown_delay  # noqa: E402, F401
from modquad_gym.sim.fault_hover import hover_with_failure  # noqa: E402, F401
from modquad_gym.sim.fault_record import FaultFlight, WorstFailure  # noqa: E402, F401
from modquad_gym.sim.fault_verdict import GOAL_M, SETTLE_WINDOW_S  # noqa: E402, F401
from modquad_gym.sim.inertial import check_simulable  # noqa: E402
from modquad_gym.sim.track import TrackConfig  # noqa: E402

FAULT_SECONDS = 3.0
"""Simulated seconds a flight goes on after the failure (``seconds`` of :func:`fly_with_failure`,
``--fault-seconds``; a trajectory at least to its end and a hold after it, :func:`hold_seconds`):
long enough for the settling test
(:mod:`~modquad_gym.sim.fault_verdict`) to see most recovered flights settle (measured: most
left saturation within 1 s of the failure, the slowest seen 5.5 s after it, which 3 s judges "not
settled") and a diverging one still saturated and drifting (measured: saturated through every
window from 0.5 s on, falling 3.2 to 5.4 s after it): it errs on the safe side
(docs/faults.md, "The verdict")."""

FAULT_BEFORE_S = 1.0
"""Simulated seconds the hover holds its wrench before the failure (it starts at rest there)."""

MAX_FAULT_SECONDS = 60.0
"""Longest flight after the failure ``seconds`` takes."""

FAILURE_CHOICES = ("all", "worst")
"""Which failures :func:`fly_with_failure` flies, besides one numbered failure: every one, or
the smallest-margin one only."""

LEAD_S = 0.5
"""Dynamic task: the failure strikes halfway through the trajectory, or this many seconds before
the moment it hurts most (its sample of smallest margin) when that moment comes earlier, so that
the flight after the failure always passes it."""


def failure_columns(structure: Structure, fault: str) -> list[np.ndarray]:
    """The column sets of A that one failure of kind ``fault`` removes: each rotor, each
    module's rotors (its own rotor count) or each pair of rotors, in the order of
    :meth:`~modquad_gym.geometry.structure.Structure.configuration_matrix`."""
    fault = check_fault(fault)
    starts = np.cumsum([0] + [m.n_rotors for m in structure.modules])
    if fault not in ("module", "rotor+module"):  # each rotor, or each pair of rotors
        return failure_sets(int(starts[-1]), fault)
    return module_failures(starts, fault)


def _failure_problem(structure: Structure, W, f_max, fault: str) -> tuple:
    """(W, f_max) checked, A, the failures' column sets, their :class:`FaultTolerance` and the
    margin method (an LP up to :data:`LP_ROTORS` rotors, else compiled, as the searches decide):
    what :func:`worst_failure` and :func:`failure_cases` both ask."""
    W, f_max = check_wrenches(W), check_f_max(f_max)
    A = np.array(structure.configuration_matrix())
    sets = failure_columns(structure, fault)
    method = "daqp" if A.shape[1] <= LP_ROTORS else "compiled"
    return W, f_max, A, sets, FaultTolerance(A, f_max, sets), method


def worst_failure(structure: Structure, W: np.ndarray, f_max: float, fault: str) -> WorstFailure:
    """The failure of kind ``fault`` that leaves the smallest margin over the rotor wrenches W
    (rows of a (t, 6) array), and the wrench nearest the boundary after it."""
    W, f_max, A, sets, tol, method = _failure_problem(structure, W, f_max, fault)
    i, worst = tol.worst_failure(W, method)
    tolerates = bool(tol.decide(W, method).all())
    keep = np.ones(A.shape[1], dtype=bool)
    keep[sets[i]] = False
    if keep.any():
        row = int(np.argmin(margin(A[:, keep], W, f_max, method)))
    else:  # a one-module structure without its module: nothing is left
        row = int(np.argmax(np.linalg.norm(W, axis=1)))
    return WorstFailure(i, sets[i], _signed(float(worst), tolerates), row, tolerates)


def _rotor_wrenches(structure: Structure, task, f_max) -> tuple[np.ndarray, float]:
    """(rotor wrenches, f_max) of a task object (its own f_max; an ``f_max`` beside it
    refused) or of a (t, 6) array of total wrenches (``f_max``, default 1)."""
    from modquad_gym.sim.failure import refuse_unflown

    if hasattr(task, "rotor_wrenches"):
        refuse_unflown(task, f_max)
        task, f_max = task.rotor_wrenches(structure), task.f_max
    f_max = check_f_max(1.0 if f_max is None else f_max)
    return check_task_scale(task, f_max), f_max  # the searches' scale, as validate's


def failure_cases(structure: Structure, W: np.ndarray, f_max: float, fault: str) -> list:
    """Every failure of kind ``fault`` (:func:`failure_columns`' order) as a
    :class:`WorstFailure`: its margin over the rotor wrenches W and the wrench of that margin
    (the one a hover holds), and whether the structure tolerates every such failure."""
    W, f_max, A, sets, tol, method = _failure_problem(structure, W, f_max, fault)
    tolerates = bool(tol.decide(W, method).all())
    cases = []
    for i, S in enumerate(sets):
        keep = np.ones(A.shape[1], dtype=bool)
        keep[S] = False
        if keep.any():
            m = margin(A[:, keep], W, f_max, method)
            row, low = int(np.argmin(m)), float(np.min(m))
        else:  # a one-module structure without its module: nothing is left
            row, low = int(np.argmax(np.linalg.norm(W, axis=1))), float("-inf")
        cases.append(WorstFailure(i, S, low, row, tolerates))
    return cases


def check_failure_choice(failure: object, fault: str, n_failures: int) -> str | int:
    """``failure`` checked: ``"all"``, ``"worst"`` or a number K from 1 (a rotor's number,
    1..4n, for rotor failures; a module's, 1..n, for module failures; the numbering of the
    console and the pictures). A ValueError naming ``failure`` otherwise."""
    if isinstance(failure, str) and failure in FAILURE_CHOICES:
        return failure
    what = {"rotor": "rotor", "module": "module"}.get(fault)
    if isinstance(failure, (int, np.integer)) and not isinstance(failure, bool) and what:
        if 1 <= int(failure) <= n_failures:
            return int(failure)
        raise ValueError(f"failure = {failure!r}: a {what} number must lie in 1..{n_failures} "
                         f"(the structure has {n_failures} {what}s, numbered from 1)")  # fmt: skip
    numbered = f" or a {what} number 1..{n_failures}" if what else ""
    raise ValueError(f"failure = {failure!r}: must be 'all', 'worst'{numbered} "
                     f"(fault={fault!r})")  # fmt: skip


def check_fault_seconds(seconds: float | None, delay: float) -> float:
    """``seconds`` of flight after the failure (default :data:`FAULT_SECONDS`), checked: within
    :data:`MAX_FAULT_SECONDS`, and long enough for the detection ``delay`` and two windows of the
    settling test after it (a shorter flight would judge a failure it has not flown)."""
    seconds = FAULT_SECONDS if seconds is None else seconds  # read at the call
    seconds = check_real(seconds, "seconds", high=MAX_FAULT_SECONDS, positive=True)
    least = delay + 2 * SETTLE_WINDOW_S
    if seconds < least - 1e-9:
        raise ValueError(
            f"seconds = {seconds!r}: the flight after the failure must last at least {least:g} s "
            f"(the detection delay {delay:g} s, then two {SETTLE_WINDOW_S:g} s windows of the "
            "settling test)"
        )
    return seconds


def hold_seconds(duration: float, at: float, seconds: float) -> float:
    """How long a trajectory flight through a failure at ``at`` s goes on after the trajectory's
    end (``duration`` s), as it ended (:func:`~modquad_gym.sim.track.reference`: at rest at its
    last point for a trajectory that ends at rest): until ``seconds`` after the failure, and at
    least two settling windows, so that the verdict's windows lie in the hold (the trajectory's own
    tracking error, changing along it, is not judged as a recovery)."""
    return max(at + seconds - duration, 2 * SETTLE_WINDOW_S)


def flight_seconds(task, seconds: float) -> float:
    """Simulated seconds of one flight through a failure with ``seconds`` after it: a hover's
    :data:`FAULT_BEFORE_S` and ``seconds``; a trajectory's duration and its hold
    (:func:`hold_seconds`) with the failure at its latest, halfway: an upper bound."""
    if getattr(task, "kind", None) != "dynamic":
        return FAULT_BEFORE_S + seconds
    duration = float(task.trajectory.duration)
    return duration + hold_seconds(duration, duration / 2.0, seconds)


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
    failure: str | int = "all",
    progress: bool = False,
) -> FaultFlight:
    """Fly ``structure`` on ``task`` through its single failures of kind ``fault``.

    Args:
        structure: the structure to fly.
        task: a task (:class:`~modquad_gym.tasks.TaskRequirement`, a
            :class:`~modquad_gym.dynamics.DynamicTask`, anything with ``rotor_wrenches`` and
            ``f_max``) or a (t, 6) array of total rotor wrenches.
        fault: ``"rotor"`` or ``"module"`` (or ``"rotor2"``, ``"rotor+module"``).
        seconds: how long the flight goes on after the failure (default
            :data:`FAULT_SECONDS`, at most :data:`MAX_FAULT_SECONDS`, at least the detection
            delay and two settling windows): a hover (static task or array) holds
            :data:`FAULT_BEFORE_S` before; a trajectory flies to its end, then goes on as it
            ended until ``seconds`` after the failure and at least 1 s (two settling windows)
            after its end (:func:`hold_seconds`).
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
        failure: which failures to fly: ``"all"`` (default: every one, each under its own
            hardest wrench; the flight returned is the one that did worst, failing the verdict
            first, then by largest error), ``"worst"`` (the smallest-margin failure only) or a
            number from 1 (a rotor, 1..4n, or a module, 1..n).
        progress: a bar on stderr over the failures flown.

    Returns:
        A :class:`FaultFlight`; ``summary()`` is its record (``fault_max_position_error_m``,
        ``fault_within_5cm``, ``fault_failed_rotors``, ``fault_each``, ...).
    """
    if not isinstance(structure, Structure):
        raise ValueError(f"structure must be a Structure, got {type(structure).__name__}")
    check_simulable(structure)  # before the worst failure's search
    fault = check_fault(fault)
    detection_delay_s = flown_delay(detection_delay_s, detector)
    choice = check_failure_choice(failure, fault, len(failure_columns(structure, fault)))
    W, fm = _rotor_wrenches(structure, task, f_max)
    seconds = check_fault_seconds(seconds, detection_delay_s)
    if choice == "worst":
        cases = [worst_failure(structure, W, fm, fault)]
        smallest = cases[0].margin
    else:
        cases = failure_cases(structure, W, fm, fault)
        smallest = _smallest_margin(cases)
        cases = cases if choice == "all" else [cases[choice - 1]]
    flights = []
    for case in progress_bar(progress, "fault flights", "failure", items=cases):
        flights.append(_fly_one(structure, task, fault, case, W, fm, seconds, detection_delay_s,
                                track_config, detector))  # fmt: skip
        flights[-1].choice, flights[-1].smallest_margin = choice, smallest
    flown = min(flights, key=lambda f: (f.within_goal, -f.max_position_error_m))
    flown.each = [f.brief() for f in flights]
    return flown


def _smallest_margin(cases: list) -> float:
    """The smallest margin over every failure (:func:`failure_cases`), signed as
    :func:`worst_failure`'s (:func:`_signed`; ``solve --json``'s ``worst_fault_margin``)."""
    return _signed(min(c.margin for c in cases), cases[0].tolerates)


def _signed(margin: float, tolerates: bool) -> float:
    """``margin`` with the sign of the exact decision (the LP's round-off against it): 0 where
    every failure is tolerated and the margin came out below 0, just below -TOL where one is
    not and it came out at 0 or above."""
    if tolerates and margin < 0:
        return 0.0
    if not tolerates and margin >= 0:
        return float(np.nextafter(-TOL, -np.inf))
    return margin


def _fly_one(structure, task, fault, case, W, fm, seconds, delay, track_config, detector):
    """One flight through the failure ``case`` (:class:`WorstFailure`)."""
    name = getattr(task, "name", "") or ""
    if getattr(task, "kind", None) == "dynamic":
        from modquad_gym.sim.track import fly_trajectory

        traj = task.trajectory
        hardest = float(traj.t[case.row] - traj.t[0])
        at = min(traj.duration / 2.0, max(0.0, hardest - LEAD_S))
        failure = Failure(tuple(case.columns), at, delay, fault)
        run = fly_trajectory(structure, task, track_config, failure=failure, detector=detector,
                             hold_s=hold_seconds(traj.duration, at, seconds))  # fmt: skip
        return FaultFlight(structure, "trajectory", fault, failure, case, run, name)
    failure = Failure(tuple(case.columns), FAULT_BEFORE_S, delay, fault)
    run = hover_with_failure(structure, W[case.row], failure, FAULT_BEFORE_S + seconds, fm,
                             detector=detector)  # fmt: skip
    return FaultFlight(structure, "hover", fault, failure, case, run, name)
