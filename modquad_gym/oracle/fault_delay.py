"""How much worst-case margin after a failure a design needs when its controller learns of the
failure late: the rule calibrated on MuJoCo flights (``python -m benchmarks.fault_delay``;
docs/faults.md)."""

from __future__ import annotations

import numbers

import numpy as np

from modquad_gym.oracle.failures import check_fault

DELAY_SLOPES = {"rotor": 2.05, "module": 3.35, "rotor2": 3.35, "rotor+module": 3.35}
"""mu per second of detection delay, per fault kind (:func:`margin_for_delay`): 1.25 times the
fit (rotor 1.63 / s, module 2.67 / s), rounded up to 0.05, on 379 MuJoCo flights of 85 designs
for 18 generated tasks (paper-like, planted, random motions; the calibration's own seeds, no
suite's) at 10-50 ms, each judged settled or not, a trajectory's flight held at its end point
until it can settle (results/fault_delay). Both fits are set by one trajectory's designs
(motions-cal-3) leaving 5 cm; designs that fail with the failure known at once are left out (none
now). A module failure loses up to four rotors' thrust at once and needs the steeper line; two
rotor failures and a module with a rotor (neither calibrated on its own) take the module's."""

MAX_DELAY_S = 0.05
"""The longest detection delay the rule was calibrated for (s)."""


def check_delay(delay_s: object, name: str = "detection delay") -> float:
    """``delay_s`` as seconds in [0, :data:`MAX_DELAY_S`] (the rule's calibrated range), else a
    one-line ValueError naming ``name``: a string or a bool is not a delay (as
    ``fly_with_failure`` refuses them)."""
    if isinstance(delay_s, (bool, np.bool_)) or not isinstance(delay_s, numbers.Real):
        raise ValueError(f"{name} must be a number of seconds, got {delay_s!r}")
    d = float(delay_s)
    if not 0.0 <= d <= MAX_DELAY_S:
        shown = f"{d:g}" if float(f"{d:g}") == d else repr(d)  # 2, not 2.0; 0.0500001 in full
        raise ValueError(
            f"{name} must lie in [0, {MAX_DELAY_S:g}] s (the rule's calibrated range), got {shown}"
        )
    return d


def margin_for_delay(delay_s: object, fault: str = "rotor") -> float:
    """The worst fault margin a design needs so that it stays within 5 cm through its worst
    failure of kind ``fault`` when the controller learns of it ``delay_s`` seconds late:
    ``DELAY_SLOPES[fault] * delay_s``, fitted on MuJoCo flights of generated tasks' designs
    (``python -m benchmarks.fault_delay``; docs/faults.md). ValueError outside [0,
    :data:`MAX_DELAY_S`], where it was not calibrated (:func:`check_delay`), or for an unknown
    fault."""
    d = check_delay(delay_s)
    return DELAY_SLOPES[check_fault(fault)] * d
