"""How much worst-case margin after a failure a design needs when its controller learns of the
failure late: the rule calibrated on MuJoCo flights (``python -m benchmarks.fault_delay``;
docs/faults.md)."""

from __future__ import annotations

DELAY_SLOPES = {"rotor": 2.05, "module": 3.35, "rotor2": 3.35, "rotor+module": 3.35}
"""mu per second of detection delay, per fault kind (:func:`margin_for_delay`): 1.25 times the
fit (rotor 1.63 / s, module 2.67 / s), rounded up to 0.05, on 287 MuJoCo flights of 83 designs
for 18 generated tasks (paper-like, planted, random motions; the calibration's own seeds, no
suite's) at 10-50 ms (results/fault_delay). A module failure loses up to four rotors' thrust at
once and needs the steeper line; two rotor failures and a module with a rotor (neither
calibrated on its own) take the module's."""

MAX_DELAY_S = 0.05
"""The longest detection delay the rule was calibrated for (s)."""


def margin_for_delay(delay_s: object, fault: str = "rotor") -> float:
    """The worst fault margin a design needs so that it stays within 5 cm through its worst
    failure of kind ``fault`` when the controller learns of it ``delay_s`` seconds late:
    ``DELAY_SLOPES[fault] * delay_s``, fitted on MuJoCo flights of generated tasks' designs
    (``python -m benchmarks.fault_delay``; docs/faults.md). ValueError outside [0,
    :data:`MAX_DELAY_S`], where it was not calibrated, or for an unknown fault."""
    try:
        d = float(delay_s)  # type: ignore[arg-type]
    except (TypeError, ValueError):
        raise ValueError(f"detection delay must be a number of seconds, got {delay_s!r}") from None
    if not 0.0 <= d <= MAX_DELAY_S:
        raise ValueError(
            f"detection delay must lie in [0, {MAX_DELAY_S:g}] s (the rule's calibrated range), "
            f"got {delay_s!r}"
        )
    if fault not in DELAY_SLOPES:
        raise ValueError(f"fault must be one of {', '.join(DELAY_SLOPES)}, got {fault!r}")
    return DELAY_SLOPES[fault] * d
