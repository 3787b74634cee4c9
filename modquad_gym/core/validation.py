"""Input checks shared by every layer: one place that decides what a valid integer, real number,
thrust limit, wrench array or configuration matrix is, so the API, the environment and the CLI
accept and reject the same values with the same one-line messages.

Every check raises ``ValueError`` whose message names the argument and the offending value.
Booleans and strings are never numbers here (``n_max=True`` and ``f_max='2'`` are errors).
"""

from __future__ import annotations

import math
import numbers
import os
import stat
import warnings

import numpy as np

__all__ = [
    "F_MAX_RANGE",
    "F_MAX_TEXT",
    "NOT_REGULAR",
    "check_f_max",
    "check_name",
    "check_path",
    "check_rng",
    "check_task_name",
    "float_array",
    "check_int",
    "check_matrix",
    "check_real",
    "check_wrenches",
    "read_regular_file",
    "refuse_complex",
    "refuse_non_numbers",
]


_ComplexWarning = getattr(np, "exceptions", np).ComplexWarning


def _is_bool(value: object) -> bool:
    return isinstance(value, (bool, np.bool_))


def check_flag(value: object, name: str) -> bool:
    """``value`` as a Python bool, or a ValueError naming ``name``: only True and False (and
    NumPy's), never a string or a number whose truth would be taken silently."""
    if not _is_bool(value):
        raise ValueError(f"{name} must be True or False, got {value!r}")
    return bool(value)


def check_rng(value: object, name: str = "rng") -> np.random.Generator:
    """``value`` when it is a ``numpy.random.Generator`` (``np.random.default_rng(seed)``), else
    a ValueError naming ``name``: what every seeded draw takes, never a seed or None in its
    place (which would fail later, naming an attribute)."""
    if not isinstance(value, np.random.Generator):
        raise ValueError(
            f"{name} must be a numpy.random.Generator (np.random.default_rng(seed)), got "
            f"{value!r:.60}"
        )
    return value


def check_path(path: object, what: str = "path") -> None:
    """A ValueError naming ``what`` unless ``path`` is a file path: a non-empty str or a
    PathLike (pathlib would raise its own TypeError, naming nothing)."""
    if not isinstance(path, (str, os.PathLike)) or not str(path).strip():
        raise ValueError(f"{what} must be a file path (a str or a PathLike), got {path!r}")


NOT_REGULAR = "not a regular file (a device, pipe or socket)"
"""What a path that exists but is neither a file nor a folder is told (inputs and outputs)."""


def read_regular_file(path: object, limit: int, error: type[ValueError] = ValueError) -> bytes:
    """The bytes of the regular file ``path``, at most ``limit`` of them; anything else (a
    folder, a pipe, a device such as /dev/zero, a larger file) is refused by ``error`` naming
    the path before it is read. The file is opened without blocking (a pipe's open would wait
    for a writer), then checked. OSError (no such file, no permission) passes to the caller."""
    nonblocking = getattr(os, "O_NONBLOCK", 0)  # POSIX
    fd = os.open(path, os.O_RDONLY | nonblocking)  # type: ignore[arg-type]
    try:
        info = os.fstat(fd)
        if not stat.S_ISREG(info.st_mode):
            raise error(f"{path}: not a regular file")
        if info.st_size > limit:
            raise error(f"{path}: {info.st_size:,} bytes, more than the {limit:,} read")
        if nonblocking:
            os.set_blocking(fd, True)
    except BaseException:
        os.close(fd)
        raise
    with os.fdopen(fd, "rb") as fh:
        data = fh.read(limit + 1)
    if len(data) > limit:  # it grew while we read it
        raise error(f"{path}: more than the {limit:,} bytes read")
    return data


def check_name(value: object, name: str = "name") -> str:
    """``value`` when it is a string, else a ValueError naming ``name``."""
    if not isinstance(value, str):
        raise ValueError(f"{name} must be a string, got {value!r:.60}")
    return value


def check_task_name(value: object, name: str = "name") -> str:
    """A task's name: a non-empty string (a file's task without one takes the file's name;
    an empty one would print as ``task ''``), else a ValueError naming ``name``."""
    if not isinstance(value, str) or not value:
        hint = " (leave it out for the file's name)" if name.startswith("'") else ""
        raise ValueError(f"{name} must be a non-empty string{hint}, got {value!r:.60}")
    return value


def check_int(value: object, name: str, low: int | None = None, high: int | None = None) -> int:
    """``value`` as a Python int within [low, high], or a ValueError naming ``name``.

    Accepts Python and NumPy integers only: ``2.0``, ``'2'`` and ``True`` are rejected.
    """
    if _is_bool(value) or not isinstance(value, numbers.Integral):
        raise ValueError(f"{name} must be an integer, got {value!r}")
    v = int(value)
    if low is not None and v < low:
        raise ValueError(f"{name} must be >= {low}, got {v}")
    if high is not None and v > high:
        raise ValueError(f"{name} must be <= {high}, got {v}")
    return v


def check_real(
    value: object,
    name: str,
    low: float | None = None,
    high: float | None = None,
    *,
    positive: bool = False,
) -> float:
    """``value`` as a finite float within [low, high] (and > 0 when ``positive``), or a
    ValueError naming ``name``. Booleans and strings are rejected."""
    if _is_bool(value) or not isinstance(value, numbers.Real):
        raise ValueError(f"{name} must be a real number, got {value!r}")
    v = float(value)
    if not math.isfinite(v):
        raise ValueError(f"{name} must be finite, got {value!r}")
    if positive and not v > 0:
        raise ValueError(f"{name} must be positive, got {_shown(v)}")
    if low is not None and v < low:
        raise ValueError(f"{name} must be >= {low:g}, got {_shown(v)}")
    if high is not None and v > high:
        raise ValueError(f"{name} must be <= {high:g}, got {_shown(v)}")
    return v


def _shown(v: float) -> str:
    """``v`` short (``:g``) where that is exact, else in full: 1.0000001 is not shown as 1."""
    short = f"{v:g}"
    return short if float(short) == v else repr(v)


F_MAX_RANGE = (1e-300, 1e12)
"""The rotor thrust limits (N) every door takes (:func:`check_f_max`): below, dividing wrenches
by f_max leaves the floating-point range; 1e12 N per rotor is far beyond any rotor, and the
environment's float32 features of wrenches over f_max stay finite up to it."""


def check_f_max(f_max: object) -> float:
    """The per-rotor thrust limit as a float: a real number in :data:`F_MAX_RANGE`, else a
    ValueError (``f_max must be positive, got 0``, ``f_max = 1e+30 is outside 1e-300..1e12
    (check the units)``): the one check of every f_max, each door's and each task's."""
    value = check_real(f_max, "f_max", positive=True)
    low, high = F_MAX_RANGE
    if not low <= value <= high:
        raise ValueError(f"f_max = {_shown(value)} is outside {F_MAX_TEXT} (check the units)")
    return value


F_MAX_TEXT = f"{F_MAX_RANGE[0]:g}..{F_MAX_RANGE[1]:g}".replace("e+", "e")
""":data:`F_MAX_RANGE` as messages and help write it: ``1e-300..1e12``."""


def _ragged_row(value: object) -> str:
    """Where a nested list is ragged: ``row 2 has 3 entries, row 1 has 6`` (1-based)."""
    try:
        lengths = [len(row) for row in value]  # type: ignore[union-attr]
    except TypeError:
        return "its rows are not all sequences of numbers"
    row = next((i for i, n in enumerate(lengths) if n != lengths[0]), None)
    if row is None:
        return "its entries are nested unevenly"
    return f"row {row + 1} has {lengths[row]} entries, row 1 has {lengths[0]}"


def _complex_message(name: str, dtype: object) -> str:
    return (
        f"{name} must hold real numbers, got complex values ({dtype}); pass the real part "
        "(np.real) if that is what you mean"
    )


def refuse_complex(value: object, name: str) -> None:
    """A ValueError naming ``name`` when ``value`` (an array, a NumPy scalar, a list or tuple of
    numbers) holds complex numbers: NumPy would drop their imaginary parts with only a
    ``ComplexWarning``. Anything else passes (the caller's own conversion judges it)."""
    dtype = getattr(value, "dtype", None)
    if dtype is None and isinstance(value, (list, tuple)):
        try:
            dtype = np.asarray(value).dtype
        except (ValueError, TypeError, OverflowError):
            return
    if getattr(dtype, "kind", "") == "c":
        raise ValueError(_complex_message(name, dtype))


def float_array(value: object, name: str, expected: str | None = None) -> np.ndarray:
    """``np.array(value, dtype=float)`` (a copy), except that complex numbers, which NumPy
    would cut to their real parts with only a warning, are a ValueError naming ``name``. Other
    conversion errors become ``ValueError(f"{name} must be {expected}")``, or pass to the caller
    (TypeError, ValueError, OverflowError) when ``expected`` is None."""
    dtype = getattr(value, "dtype", None)
    if getattr(dtype, "kind", "") == "c":
        raise ValueError(_complex_message(name, dtype))
    with warnings.catch_warnings():
        warnings.simplefilter("error", _ComplexWarning)
        try:
            return np.array(value, dtype=float)
        except _ComplexWarning:  # a list holding NumPy complex scalars
            raise ValueError(_complex_message(name, "complex")) from None
        except (TypeError, ValueError, OverflowError):
            refuse_complex(value, name)  # Python complex numbers in a list
            if expected is None:
                raise
    raise ValueError(f"{name} must be {expected}")


_BOOLS = (bool, np.bool_)
_PLAIN = frozenset((int, float))
_NESTED = (list, tuple)
_NOT_NUMBERS = "bOUSV"
"""The dtype kinds of arrays that hold no numbers: booleans, objects, strings, raw bytes."""

WRENCH_COLUMNS = ("fx", "fy", "fz", "tx", "ty", "tz")
"""The columns of a wrench, in order."""


def _not_number(x: object) -> bool:
    """True for a value that is not a real number where one is expected: a bool, a string,
    None, a list... Complex numbers are not flagged (:func:`float_array` refuses them, saying
    so), nor arrays (their shape and dtype are checked as the conversion's)."""
    if type(x) in _PLAIN:
        return False
    if isinstance(x, (*_BOOLS, str, bytes)):
        return True
    return not isinstance(x, (numbers.Number, np.ndarray))


def _shown_value(x: object) -> str:
    """A value as a message shows it: booleans as JSON writes them, the rest by repr."""
    if isinstance(x, _BOOLS):
        return str(bool(x)).lower()
    return f"{str(x)!r:.40}" if isinstance(x, str) else f"{x!r:.40}"  # np.str_ as a str


def refuse_non_numbers(
    value: object, name: str, unit: str = "sample", columns: tuple[str, ...] | None = None
) -> None:
    """The one rule for numbers in every array the package takes (wrenches, trajectories,
    payloads): a ValueError naming ``name`` when ``value`` holds something that is not a real
    number, which NumPy would convert silently (``true`` as 1, ``" 1_0 "`` as 10). ``value`` is
    an array (refused when of booleans, objects or strings), or a list or tuple of numbers or of
    rows of numbers, as JSON gives them (with ``columns``, a flat list is one row): the message
    names the 1-based ``unit`` and, in a row, its column (``t: sample 2 is '0.5', not a
    number``; ``wrenches: row 1 holds true, not a number (column 3, fz)`` with ``columns``).
    Anything else passes (the caller's conversion judges it)."""
    dtype = getattr(value, "dtype", None)
    if dtype is not None:
        if dtype.kind in _NOT_NUMBERS:
            raise ValueError(f"{name} must hold real numbers, got dtype {dtype}")
        return
    if not isinstance(value, _NESTED):  # a string here is no array: the shape check names it
        if isinstance(value, _BOOLS):
            raise ValueError(f"{name} is {_shown_value(value)}, not a number")
        return
    if columns and not any(isinstance(v, (*_NESTED, np.ndarray)) for v in value):
        value = [value]  # one row given flat
    for i, v in enumerate(value, 1):
        if type(v) in _PLAIN:
            continue
        if isinstance(v, np.ndarray):
            if v.dtype.kind in _NOT_NUMBERS:
                raise ValueError(f"{name}: {unit} {i} holds dtype {v.dtype}, not numbers")
        elif isinstance(v, _NESTED):
            for j, x in enumerate(v):
                if type(x) not in _PLAIN and _not_number(x):
                    col = f"{j + 1}, {columns[j]}" if columns and j < len(columns) else j + 1
                    raise ValueError(
                        f"{name}: {unit} {i} holds {_shown_value(x)}, not a number (column {col})"
                    )
        elif _not_number(v):  # (a list or tuple was a row, above)
            raise ValueError(f"{name}: {unit} {i} is {_shown_value(v)}, not a number")


def _float_array(value: object, name: str) -> np.ndarray:
    try:
        arr = np.asarray(value)
    except ValueError:  # a ragged nested list
        raise ValueError(f"{name} must be a rectangular array: {_ragged_row(value)}") from None
    refuse_complex(arr, name)
    if arr.dtype == object or arr.dtype.kind in "USVb":
        raise ValueError(f"{name} must hold real numbers, got dtype {arr.dtype}")
    return arr.astype(float, copy=False)


def check_wrenches(W: object, *, allow_empty: bool = True) -> np.ndarray:
    """W as a float (t, 6) array (a single 6-vector is promoted), or a ValueError naming the
    shape, the first entry that is not a number (:func:`refuse_non_numbers`) or the first
    non-finite row (1-based)."""
    refuse_non_numbers(W, "wrenches", "row", WRENCH_COLUMNS)
    arr = _float_array(W, "wrenches")
    if arr.ndim == 1:
        arr = arr[None, :]
    if arr.ndim != 2 or arr.shape[1] != 6:
        raise ValueError(f"wrenches must have shape (t, 6) or (6,), got {np.shape(W)}")
    if not allow_empty and arr.shape[0] == 0:
        raise ValueError("the task has no wrenches: expected at least one row of 6 numbers")
    if not np.isfinite(arr).all():
        row = int(np.argwhere(~np.isfinite(arr))[0, 0])
        raise ValueError(f"wrench row {row + 1} is not finite: {arr[row].tolist()}")
    return arr


def check_matrix(A: object) -> np.ndarray:
    """A as a float (6, m) array with m >= 1, or a ValueError naming what is wrong."""
    arr = _float_array(A, "A")
    if arr.ndim != 2 or arr.shape[0] != 6 or arr.shape[1] < 1:
        raise ValueError(
            f"A must be a 6 x m configuration matrix with m >= 1, got shape {arr.shape}"
        )
    if not np.isfinite(arr).all():
        bad = np.argwhere(~np.isfinite(arr))[0]
        raise ValueError(f"A has a non-finite entry at row {bad[0] + 1}, column {bad[1] + 1}")
    return arr
