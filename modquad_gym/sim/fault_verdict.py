"""Whether a flight through a failure held: within 5 cm, never stopped, and settled at the end.

A flight whose error is still growing, or whose working rotors sit at a limit through its last
stretch, has not recovered from the failure: measured on margin-free designs (docs/faults.md,
"Judged settled"), such flights stay within 5 cm for seconds and then fall. So the verdict
(:func:`settling`) splits the flight after the failure into windows of :data:`SETTLE_WINDOW_S`
and calls it **settled** when

* the largest error of the last window is not above the window before's by more than
  :data:`SETTLE_GROWTH` of it plus :data:`SETTLE_FLOOR_M` (the error is not growing), and
* the last window has at least one step in which no working rotor is at a limit (0 or
  f_max): the controller has authority left to correct.

Too short a flight after the failure for two windows is judged on the saturation alone.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

GOAL_M = 0.05
"""The position error a tolerant structure should keep within after the failure (5 cm)."""

SETTLE_WINDOW_S = 0.5
"""Seconds of each window the settling test compares (the last one and the one before)."""

SETTLE_GROWTH = 0.1
"""Relative growth of the largest error from one window to the next still called settled."""

SETTLE_FLOOR_M = 1e-4
"""Absolute growth still called settled (0.1 mm, the resolution the reports print)."""


@dataclass(frozen=True)
class Settling:
    """The settling test of a flight after its failure.

    Attributes:
        settled: the error is not growing and the working rotors are not at a limit through the
            last window.
        last_m: largest position error over the last window (m).
        before_m: over the window before it (m; None when the flight is too short for two).
        saturated_last: share of the last window's steps with a working rotor at a limit.
        after_s: seconds flown from the failure to the end (None: not known).
    """

    settled: bool
    last_m: float
    before_m: float | None
    saturated_last: float
    after_s: float | None = None

    @property
    def growing(self) -> bool:
        """The last window's largest error is above the window before's (beyond the slack)."""
        if self.before_m is None:
            return False
        return self.last_m > (1.0 + SETTLE_GROWTH) * self.before_m + SETTLE_FLOOR_M

    @property
    def pinned_only(self) -> bool:
        """Not settled only because a working rotor sat at a limit through the last window,
        the error not growing: a slow recovery may still be under way (a longer flight after the
        failure tells)."""
        return not self.settled and not self.growing and self.saturated_last >= 1.0

    def words(self) -> str:
        """Why not settled, in words (empty when settled)."""
        if self.settled:
            return ""
        why = []
        if self.growing:
            why.append(f"error rising {100 * self.before_m:.3g} -> {100 * self.last_m:.3g} cm "
                       f"over the last two {SETTLE_WINDOW_S:g} s windows")  # fmt: skip
        if self.saturated_last >= 1.0:
            why.append(f"a working rotor {'still ' if self.pinned_only else ''}at a limit "
                       f"through the last {SETTLE_WINDOW_S:g} s")  # fmt: skip
        if self.pinned_only:
            why[-1] += " (error not growing)"
        within = f" within {self.after_s:.3g} s" if self.after_s is not None else ""
        return f"not settled{within}: " + "; ".join(why)


def settling(t: np.ndarray, error: np.ndarray, saturated: np.ndarray, start: float) -> Settling:
    """The settling test (module docstring) of the flight from ``start`` (the failure) on:
    ``t`` (N,) control times, ``error`` (N,) position error, ``saturated`` (N,) bool."""
    after = t >= start - 1e-9
    t, error, saturated = t[after], error[after], saturated[after]
    if not len(t):
        return Settling(False, float("nan"), None, 1.0)
    end = t[-1]
    last = t > end - SETTLE_WINDOW_S + 1e-9
    before = (t > end - 2 * SETTLE_WINDOW_S + 1e-9) & ~last
    enough = end - t[0] >= 2 * SETTLE_WINDOW_S - 1e-6
    last_m = float(np.max(error[last]))
    before_m = float(np.max(error[before])) if enough and before.any() else None
    sat = float(np.mean(saturated[last]))
    probe = Settling(True, last_m, before_m, sat)
    ok = np.isfinite(last_m) and not probe.growing and sat < 1.0
    return Settling(bool(ok), last_m, before_m, sat, float(end - start))
