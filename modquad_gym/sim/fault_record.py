"""The record of a flight through a failure: which failure, what it did, and the verdict.

:class:`FaultFlight` holds one flight (:func:`modquad_gym.sim.fault_flight.fly_with_failure`
returns the one that did worst of those it flew, the others summarised in ``each``);
:meth:`FaultFlight.summary` is its JSON record. The verdict ``fault_within_5cm`` is the flight
never stopped, kept within :data:`~modquad_gym.sim.fault_verdict.GOAL_M` from the failure on,
and settled at its end (:func:`~modquad_gym.sim.fault_verdict.settling`).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from modquad_gym.geometry.structure import Structure
from modquad_gym.sim.failure import Failure
from modquad_gym.sim.fault_verdict import GOAL_M, Settling, settling
from modquad_gym.sim.report import finite_or_none
from modquad_gym.sim.track import TrackResult


@dataclass(frozen=True)
class WorstFailure:
    """A failure and the margin it leaves over a task's rotor wrenches (the smallest-margin
    failure, :func:`~modquad_gym.sim.fault_flight.worst_failure`, or any one chosen).

    Attributes:
        index: its index among :func:`~modquad_gym.sim.fault_flight.failure_columns`.
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


@dataclass
class FaultFlight:
    """A flight through a failure and the failure it went through.

    Attributes:
        structure: the structure flown.
        flight: ``"hover"`` (static task) or ``"trajectory"`` (dynamic task).
        fault: ``"rotor"`` or ``"module"`` (or ``"rotor2"``, ``"rotor+module"``).
        failure: what stopped and when (:class:`~modquad_gym.sim.failure.Failure`).
        worst: this failure and its margin (:class:`WorstFailure`).
        run: the time series (:class:`~modquad_gym.sim.track.TrackResult`; for a hover the
            desired position is home throughout and ``wrench_ff`` the held wrench).
        task_name: for titles.
        choice: which failures were flown: ``"all"``, ``"worst"`` (the smallest-margin one
            only) or a 1-based number (a rotor, or a module for module failures).
        each: one short record per failure flown (:meth:`brief`), in the failures' order.
        smallest_margin: the smallest margin over every failure of the kind (None: this
            failure's ``worst.margin``, as for the smallest-margin failure flown alone).
    """

    structure: Structure
    flight: str
    fault: str
    failure: Failure
    worst: WorstFailure
    run: TrackResult
    task_name: str = ""
    choice: str | int = "worst"
    each: list = field(default_factory=list)
    smallest_margin: float | None = None

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
    def settling(self) -> Settling:
        """The settling test at the end of the flight (:mod:`~modquad_gym.sim.fault_verdict`)."""
        run = self.run
        return settling(run.t, run.position_error, run.saturated, self.failure.time_s)

    @property
    def within_goal(self) -> bool:
        """Flown to the end, within :data:`GOAL_M` after the failure, and settled at the end."""
        return (self.run.diverged is None and self.max_position_error_m <= GOAL_M
                and self.settling.settled)  # fmt: skip

    def verdict_words(self) -> str:
        """Why the flight did not hold (empty when it did): stopped, beyond 5 cm, not settled."""
        if self.run.diverged:
            return f"stopped: {self.run.diverged}"
        if self.max_position_error_m > GOAL_M:
            return f"beyond {100 * GOAL_M:g} cm"
        settle = self.settling
        if not settle.pinned_only:
            return settle.words()
        return settle.words() + "; a longer --fault-seconds (seconds=) may show it recover"

    def brief(self) -> dict:
        """The short record of this flight in ``fault_each``: the failed rotors (columns of A),
        the failure's margin, the largest error after it, the verdict and why it failed."""
        return {"rotors": [int(c) for c in self.failure.columns],
                "margin": finite_or_none(self.worst.margin),
                "max_position_error_m": finite_or_none(self.max_position_error_m),
                "within_5cm": self.within_goal,
                "why_not": self.verdict_words() or None}  # fmt: skip

    def failed_part(self) -> dict:
        """The failed module (index in the cells and its cell; a rotor+module failure's module)
        and, for a rotor failure, which of the module's rotors (0-based; a pair's first); for a
        pair of rotors or a module and a rotor, ``fault_failed_parts``: each failed rotor's
        module, cell and rotor in it."""
        starts = np.cumsum([0] + [m.n_rotors for m in self.structure.modules])

        def where(column) -> dict:
            module = int(np.searchsorted(starts, column, side="right") - 1)
            return {"module": module, "cell": list(self.structure.cells[module]),
                    "rotor_in_module": int(column - starts[module])}  # fmt: skip

        first = where(self.failure.columns[0])
        rotor = first["rotor_in_module"] if "module" not in self.fault else None
        part = {"fault_failed_module": first["module"], "fault_failed_cell": first["cell"],
                "fault_failed_rotor_in_module": rotor}  # fmt: skip
        if self.fault in ("rotor2", "rotor+module"):
            part["fault_failed_parts"] = [where(c) for c in self.failure.columns]
        return part

    def summary(self) -> dict:
        """The ``fault_*`` keys of a validation record (JSON-ready; None for a number that is not
        finite, e.g. a margin of -inf: a wrench off the span of the working rotors):

        ``fault`` (kind), ``fault_flight`` (``"hover"`` or ``"trajectory"``), ``fault_tolerates``
        (every wrench feasible after every failure of that kind), ``fault_failure`` (which failures
        were flown: ``"all"``, ``"worst"`` or the 1-based number asked for),
        ``fault_failures_flown``, ``fault_worst_margin`` (the smallest margin over the task and
        every failure of the kind, as ``solve --json``'s ``worst_fault_margin``),
        ``fault_flown_margin`` (the margin after the failure reported), ``fault_failed_rotors``
        (columns of A, 0-based), ``fault_failed_module`` (index in the cells, 0-based),
        ``fault_failed_cell``, ``fault_failed_rotor_in_module`` (rotor failures, 0-based; a pair's
        first), ``fault_failed_parts`` (rotor2 and rotor+module: each failed rotor's module, cell
        and rotor in it), ``fault_time_s``, ``fault_detection_delay_s`` (the delay flown; None with
        a detector, whose ``fault_detected_after_s`` says when it decided), ``fault_seconds``
        (flown after the failure: ``--fault-seconds``; a trajectory's, to its end and its hold
        after it), ``fault_total_seconds`` (the whole flight,
        the hover before the failure included), ``fault_hardest_row`` (the task row, wrench or
        trajectory sample, of that margin; the wrench a hover holds),
        ``fault_max_position_error_m`` and ``fault_saturated_fraction`` (from the failure on),
        ``fault_max_attitude_error_rad``, ``fault_before_max_position_error_m``, ``fault_diverged``
        (why the flight was stopped, or None), the settling test (``fault_settled``,
        ``fault_last_window_error_m``, ``fault_window_before_error_m``,
        ``fault_last_window_saturated_fraction``), ``fault_within_5cm`` (never stopped, within 5 cm
        and settled), ``fault_why_not`` (why not, or None) and ``fault_each`` (:meth:`brief` of
        every failure flown)."""
        settle = self.settling
        end = float(self.run.t[-1]) if len(self.run.t) else 0.0
        return {
            "fault": self.fault,
            "fault_flight": self.flight,
            "fault_tolerates": self.worst.tolerates,
            "fault_failure": self.choice,
            "fault_failures_flown": max(1, len(self.each)),
            "fault_worst_margin": finite_or_none(
                self.worst.margin if self.smallest_margin is None else self.smallest_margin
            ),
            "fault_flown_margin": finite_or_none(self.worst.margin),
            "fault_failed_rotors": list(self.failure.columns),
            **self.failed_part(),
            "fault_time_s": self.failure.time_s,
            "fault_detection_delay_s": None if self.detection() else self.failure.detection_delay_s,
            "fault_seconds": max(0.0, end - self.failure.time_s),
            "fault_total_seconds": end,
            "fault_hardest_row": self.worst.row,
            "fault_max_position_error_m": finite_or_none(self.max_position_error_m),
            "fault_saturated_fraction": self.saturated_fraction,
            "fault_max_attitude_error_rad": finite_or_none(self.max_attitude_error_rad),
            "fault_before_max_position_error_m": finite_or_none(self.before_max_position_error_m),
            "fault_diverged": self.run.diverged,
            "fault_settled": settle.settled,
            "fault_last_window_error_m": finite_or_none(settle.last_m),
            "fault_window_before_error_m": (
                None if settle.before_m is None else finite_or_none(settle.before_m)
            ),  # fmt: skip
            "fault_last_window_saturated_fraction": settle.saturated_last,
            "fault_within_5cm": self.within_goal,
            "fault_why_not": self.verdict_words() or None,
            "fault_each": self.each or [self.brief()],
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
