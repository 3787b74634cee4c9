"""A trajectory's samples read from arrays or JSON lists: times, rows of numbers, unit
quaternions; each error names the field and the 1-based sample."""

from __future__ import annotations

import numpy as np

from modquad_gym.core.validation import float_array, refuse_non_numbers
from modquad_gym.dynamics import quaternions as quat

MAX_SAMPLES = 100_000
"""Most samples in one trajectory (100 s at 1 kHz); more is refused before any work."""

UNIT_TOL = 1e-6
"""How far a quaternion's norm may be from 1 (it is then normalised)."""


def row_problem(value: object, field: str, width: int) -> str | None:
    """What is wrong with the first bad row of a list of rows (``FIELD: sample 5 has 2
    entries, expected 3``), or None."""
    if not isinstance(value, (list, tuple)):
        return None
    for i, row in enumerate(value, 1):
        if not isinstance(row, (list, tuple, np.ndarray)):
            return f"{field}: sample {i} is {row!r:.40}, not a row of {width} numbers"
        if len(row) != width:
            return f"{field}: sample {i} has {len(row)} entries, expected {width}"
        for x in row:
            if isinstance(x, (complex, np.complexfloating)):
                continue  # refused by float_array, which says so
            try:
                float(x)
            except (TypeError, ValueError):
                return f"{field}: sample {i} holds {x!r:.40}, not a number"
    return None


def sample_array(value: object, field: str, k: int | None, width: int) -> np.ndarray:
    """A float (k, width) copy of ``value``; errors name the field and the 1-based sample."""
    refuse_non_numbers(value, field)
    try:
        arr = float_array(value, field, "an array of numbers")
    except ValueError:
        problem = row_problem(value, field, width)
        if problem is None:
            raise
        raise ValueError(problem) from None
    shape = (k if k is not None else "k", width)
    if arr.ndim != 2 or arr.shape[1] != width or (k is not None and arr.shape[0] != k):
        raise ValueError(
            row_problem(value, field, width)
            or f"{field} must have shape {shape} (one row per sample), got {arr.shape}"
        )
    bad = ~np.isfinite(arr)
    if bad.any():
        row, col = np.argwhere(bad)[0]
        raise ValueError(f"{field}: sample {row + 1} holds {arr[row, col]} (must be finite)")
    return arr


def check_times(t: object) -> np.ndarray:
    """The sample times as a float (k,) array, k in [2, MAX_SAMPLES], finite and strictly
    increasing; else a ValueError naming ``t`` and the first bad sample (1-based)."""
    refuse_non_numbers(t, "t")
    arr = float_array(t, "t", "a list of sample times in seconds")
    if arr.ndim != 1:
        raise ValueError(f"t must be a flat list of times, got shape {arr.shape}")
    if arr.size > MAX_SAMPLES:
        raise ValueError(f"t: {arr.size:,} samples, more than the {MAX_SAMPLES:,} allowed")
    if arr.size < 2:
        raise ValueError(f"t: a trajectory needs at least 2 samples, got {arr.size}")
    bad = ~np.isfinite(arr)
    if bad.any():
        i = int(np.argmax(bad))
        raise ValueError(f"t: sample {i + 1} is {arr[i]} (times must be finite)")
    step = np.diff(arr)
    if np.any(step <= 0):
        i = int(np.argmax(step <= 0))
        raise ValueError(
            f"t: not increasing at sample {i + 2} (t = {arr[i + 1]:g} s after {arr[i]:g} s)"
        )
    return arr


def check_quaternions(q: object, k: int) -> np.ndarray:
    """Unit (w, x, y, z) rows (normalised, signs made continuous); else a ValueError naming
    ``quaternion`` and the first sample whose norm is not 1 within :data:`UNIT_TOL`."""
    arr = sample_array(q, "quaternion", k, 4)
    norms = np.linalg.norm(arr, axis=1)
    bad = np.abs(norms - 1.0) > UNIT_TOL
    if bad.any():
        i = int(np.argmax(bad))
        raise ValueError(
            f"quaternion: sample {i + 1} has norm {norms[i]:.9g}, not 1 (unit quaternions "
            "w, x, y, z, world <- body)"
        )
    return quat.continuous(arr / norms[:, None])
