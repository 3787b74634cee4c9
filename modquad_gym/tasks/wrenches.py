"""What a task's wrenches are: (t, 6) rows ``[fx, fy, fz, tx, ty, tz]`` in {S}, their checks, and
the task *kinds* (:data:`TASK_KINDS`): ``total`` (the rotors' wrench) or ``external`` (the wrench
on the environment, to which the rotors add the structure's weight, :func:`rotor_wrenches`)."""

from __future__ import annotations

import numpy as np

from modquad_gym.core.validation import WRENCH_COLUMNS, refuse_non_numbers
from modquad_gym.geometry.module import GRAVITY

COLUMNS = WRENCH_COLUMNS
"""Wrench components, in order (the CSV header written by :meth:`TaskRequirement.save`)."""

MAX_WRENCHES = 1_000_000
"""Most wrenches in one task."""

TASK_KINDS = ("total", "external")
"""What a task's wrenches are (module docstring): the rotors' total wrench, or the wrench applied
to the environment, to which the rotors add the structure's weight."""


def check_wrench_array(wrenches: object) -> np.ndarray:
    """A float (t, 6) copy of ``wrenches``; errors name the shape, or the 1-based row and the
    column of an entry that is not a number (a string or a boolean: the rule of every array,
    :func:`~modquad_gym.core.validation.refuse_non_numbers`) or not finite (complex numbers
    are refused, not cut to their real parts)."""
    from modquad_gym.core.validation import check_wrenches, float_array

    refuse_non_numbers(wrenches, "wrenches", "row", COLUMNS)
    try:
        arr = float_array(wrenches, "wrenches")
    except (TypeError, ValueError, OverflowError) as exc:
        check_wrenches(wrenches)  # names a ragged row, when that is what is wrong
        raise ValueError(f"wrenches must be a (t, 6) array of numbers: {exc}") from None
    if arr.ndim != 2 or arr.shape[1] != 6:
        raise ValueError(f"wrenches must have shape (t, 6), got {arr.shape}")
    if arr.shape[0] == 0:
        raise ValueError("a task needs at least one wrench, got none")
    if arr.shape[0] > MAX_WRENCHES:
        raise ValueError(f"a task holds at most {MAX_WRENCHES:,} wrenches, got {arr.shape[0]:,}")
    bad = ~np.isfinite(arr)
    if bad.any():
        row, col = np.argwhere(bad)[0]
        raise ValueError(
            f"row {row + 1}: {COLUMNS[col]} is {arr[row, col]} (wrenches must be finite)"
        )
    return arr


def rows_to_array(rows: object) -> np.ndarray:
    """Parse a JSON-like list of 6-number rows, naming the first bad row (1-based) and, for an
    entry that is not a number, its column (:func:`check_wrench_array`)."""
    if not isinstance(rows, (list, tuple)):
        raise ValueError(
            f'"wrenches" must be a list of [fx, fy, fz, tx, ty, tz] rows, got {rows!r}'
        )
    if not rows:
        raise ValueError('"wrenches" is empty: a task needs at least one wrench')
    for i, row in enumerate(rows, 1):
        if not isinstance(row, (list, tuple)):
            raise ValueError(f"row {i}: expected a list of 6 numbers, got {row!r}")
        if len(row) != 6:
            raise ValueError(
                f"row {i}: expected 6 columns (fx, fy, fz, tx, ty, tz), got {len(row)}"
            )
    return check_wrench_array(rows)


def check_kind(kind: object, what: str = "kind") -> str:
    """``kind`` if it is one of :data:`TASK_KINDS`, else a ValueError naming ``what``."""
    if not isinstance(kind, str) or kind not in TASK_KINDS:
        raise ValueError(f"{what} must be one of {', '.join(TASK_KINDS)}, got {kind!r}")
    return kind


DEFAULT_KIND = "total"
"""The kind a task has unless it says otherwise (the paper's), left out of files and records."""


def kind_entry(kind: str) -> dict[str, str]:
    """``{"kind": kind}`` for a record or a task file, ``{}`` for the default kind
    (:data:`DEFAULT_KIND`: what every record and file written before kinds existed means)."""
    return {} if kind == DEFAULT_KIND else {"kind": kind}


def kind_note(kind: str) -> str:
    """`` (kind)`` to follow a task's description, ``""`` for the default kind."""
    return "".join(f" ({v})" for v in kind_entry(kind).values())


def static_model(W: np.ndarray, kind: str):
    """The rotor wrenches of static task wrenches W (t, 6) of ``kind`` as a model linear in the
    structure's mass (:class:`~modquad_gym.dynamics.wrenches.LinearWrenches`): W itself, plus
    the structure's weight for ``external`` (:func:`rotor_wrenches`)."""
    from modquad_gym.dynamics.wrenches import LinearWrenches

    return LinearWrenches.of_static(W, carries_weight=check_kind(kind) == "external")


def rotor_wrenches(W: np.ndarray, kind: str, mass: float) -> np.ndarray:
    """What the rotors must produce for task wrenches W (t, 6) of ``kind`` on a structure of
    ``mass`` kg: W for ``total``; W + [0, 0, mass g, 0, 0, 0] for ``external`` (the weight acts
    at the COM, the origin of {S}, so it adds no torque)."""
    W = np.asarray(W, dtype=float)
    if check_kind(kind) == "total":
        return W
    out = W.copy()
    out[:, 2] += mass * GRAVITY
    return out
