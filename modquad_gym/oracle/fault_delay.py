"""How much worst-case margin after a failure a design needs when its controller learns of the
failure late: the rule calibrated on MuJoCo flights (``python -m benchmarks.fault_delay``;
docs/faults.md)."""

from __future__ import annotations

DELAY_SLOPE = 1.2
"""mu per second of detection delay (:func:`margin_for_delay`): 1.25 times the fit 0.94 / s,
rounded up, on 152 MuJoCo flights of 38 designs for 9 generated tasks (paper-like, planted,
random motions; the calibration's own seeds, no suite's) at 10-50 ms (results/fault_delay)."""

MAX_DELAY_S = 0.05
"""The longest detection delay the rule was calibrated for (s)."""


def margin_for_delay(delay_s: object) -> float:
    """The worst fault margin a design needs so that it stays within 5 cm through its worst
    failure when the controller learns of it ``delay_s`` seconds late: ``DELAY_SLOPE *
    delay_s``, fitted on MuJoCo flights of generated tasks' designs
    (``python -m benchmarks.fault_delay``; docs/faults.md). ValueError outside [0,
    :data:`MAX_DELAY_S`], where it was not calibrated."""
    try:
        d = float(delay_s)  # type: ignore[arg-type]
    except (TypeError, ValueError):
        raise ValueError(f"detection delay must be a number of seconds, got {delay_s!r}") from None
    if not 0.0 <= d <= MAX_DELAY_S:
        raise ValueError(
            f"detection delay must lie in [0, {MAX_DELAY_S:g}] s (the rule's calibrated range), "
            f"got {delay_s!r}"
        )
    return DELAY_SLOPE * d
