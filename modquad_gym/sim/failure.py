"""A failure during a flight: some rotors stop, and the controller learns it a little later.

At ``time_s`` the rotors ``columns`` (columns of A, actuators of the MuJoCo model) stop: their
thrust is forced to 0 in the actuators from then on, whatever the controller commands. From
``time_s + detection_delay_s`` the controller knows it: it allocates on A without those columns
(:meth:`Failure.plant`) and designs its gains on that matrix; the structure's mass and inertia
do not change (a failed module stays docked). Between the two the controller still allocates on
the intact A, so the failed rotors' share of the wrench is missing: the transient a real failure
detector's latency causes.

The flights that take a :class:`Failure` are the trajectory flight
(:func:`modquad_gym.sim.track.fly_trajectory`) and the hover through a failure
(:func:`modquad_gym.sim.fault_flight.hover_with_failure`); which rotors to stop is chosen by
:func:`modquad_gym.sim.fault_flight.worst_failure`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from modquad_gym.core.validation import check_real
from modquad_gym.sim.hover.linearization import Plant

DETECTION_DELAY_S = 0.02
"""Seconds between the failure and the controller knowing it (default; 10 control steps at
500 Hz): meanwhile it allocates on the intact A and misses the failed rotors' share."""


FAILURE_KINDS = ("rotor", "module", "rotor2", "rotor+module")
"""What can fail (:data:`modquad_gym.oracle.faults` kinds; ``Failure.kind``, for the reports)."""


@dataclass(frozen=True)
class Failure:
    """Rotors ``columns`` stop at ``time_s`` seconds; the controller knows from ``detected_s``.

    Attributes:
        columns: the failed rotors (columns of A, in the structure's order: module-major, cells
            order).
        time_s: when they stop, seconds from the start of the flight.
        detection_delay_s: how long the controller keeps allocating on the intact A (>= 0).
        kind: one of :data:`FAILURE_KINDS` (what failed; for the reports).

    Every field is checked (a one-line ValueError naming it): columns distinct ints from 0
    (each below the structure's rotor count, checked where it is flown), times finite and
    >= 0 (a delay of -0 is 0).
    """

    columns: tuple[int, ...]
    time_s: float
    detection_delay_s: float = 0.0
    kind: str = "rotor"

    def __post_init__(self) -> None:
        cols = tuple(self.columns) if isinstance(self.columns, (tuple, list, np.ndarray)) else None
        if cols is None:
            raise ValueError(f"columns must be a sequence of rotor indices, got {self.columns!r}")
        if not cols:
            raise ValueError("a failure stops at least one rotor (columns is empty)")
        for c in cols:
            if isinstance(c, (bool, np.bool_)) or not isinstance(c, (int, np.integer)) or c < 0:
                raise ValueError(f"columns: each must be an int rotor index from 0 (a column of "
                                 f"A), got {c!r} in {cols!r}")  # fmt: skip
        if len(set(cols)) != len(cols):
            raise ValueError(f"columns: a rotor given twice in {cols!r}")
        object.__setattr__(self, "columns", tuple(int(c) for c in cols))
        check_real(self.time_s, "time_s", low=0.0)
        delay = check_real(self.detection_delay_s, "detection_delay_s", low=0.0) + 0.0  # no -0
        object.__setattr__(self, "detection_delay_s", delay)
        if self.kind not in FAILURE_KINDS:
            raise ValueError(f"kind must be one of {', '.join(FAILURE_KINDS)}, got {self.kind!r}")

    def check_rotors(self, n_rotors: int) -> None:
        """A ValueError naming ``columns`` when one is not a rotor of an ``n_rotors``-rotor
        structure (0..n_rotors-1)."""
        bad = [c for c in self.columns if c >= n_rotors]
        if bad:
            raise ValueError(f"columns: rotor {bad[0]} is not one of the structure's {n_rotors} "
                             f"rotors (0..{n_rotors - 1})")  # fmt: skip

    @property
    def detected_s(self) -> float:
        """When the controller starts allocating without the failed rotors."""
        return self.time_s + self.detection_delay_s

    def working(self, n_rotors: int) -> np.ndarray:
        """bool (n_rotors,): the rotors that still work after the failure."""
        keep = np.ones(n_rotors, dtype=bool)
        keep[list(self.columns)] = False
        return keep

    def plant(self, plant: Plant) -> Plant | None:
        """The controller's model once it knows: A without the failed columns, the same mass,
        inertia and f_max (None when no rotor is left)."""
        keep = self.working(plant.A.shape[1])
        if not keep.any():
            return None
        return Plant.build(plant.A[:, keep], plant.f_max, plant.mass, plant.J)


def flown_delay(detection_delay_s: float | None, detector) -> float:
    """The delay the controller is told of the failure after: ``detection_delay_s`` (default
    :data:`DETECTION_DELAY_S`), or 0 with a ``detector``, whose decision is the switch (the
    :class:`~modquad_gym.sim.failure.Failure`'s delay is then unused). A delay given beside a
    detector is a ValueError: it would be reported but not flown."""
    if detector is None:
        delay = DETECTION_DELAY_S if detection_delay_s is None else detection_delay_s
        return check_real(delay, "detection_delay_s", low=0.0) + 0.0  # -0 flown and shown as 0
    if detection_delay_s is not None:
        raise ValueError(
            f"detection_delay_s = {detection_delay_s!r}: not flown with a detector, which decides "
            "when the controller learns of the failure; give one or the other"
        )
    return 0.0


def refuse_unflown(task, f_max: float | None) -> None:
    """A ValueError naming ``f_max`` given beside a task object (it carries its own): an
    option of a flight through a failure that would be ignored."""
    what = type(task).__name__
    if f_max is not None:
        raise ValueError(
            f"f_max = {f_max!r}: applies to a wrench array only; a {what} has its own f_max "
            "(task.with_f_max)"
        )
