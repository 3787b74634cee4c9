"""Task requirements (paper Def. 3): the wrenches a structure must be able to exert.

A :class:`TaskRequirement` is a (t, 6) array of wrenches ``[fx, fy, fz, tx, ty, tz]`` in the
structure frame {S} (torques about the COM), with the per-rotor thrust limit ``f_max``, and a
*kind* (:data:`TASK_KINDS`) that says what the wrenches are:

``total`` (the default, the paper's)
    the total wrench the rotors must produce; gravity compensation is folded into ``fz``, the
    same for every structure. Units are those of ``f_max`` (normalised to 1 in the paper).
``external``
    the wrench the structure must apply to the environment or a payload, in {S} at hover
    attitude (level). The rotors must produce it *plus* the structure's own weight:
    ``w + m_total g e_z`` (:func:`rotor_wrenches`; weight acts at the COM, so it adds no
    torque), so the answer depends on the structure's mass and bigger structures must lift
    more. Units are SI: newtons, newton-metres, ``f_max`` in newtons, module masses in kg,
    g = :data:`~modquad_gym.module.GRAVITY`.

Task files:

``.json``
    ``{"wrenches": [[fx, fy, fz, tx, ty, tz], ...], "f_max": 1.0, "name": "..."}``; only
    ``wrenches`` is required (``name`` defaults to the file stem, ``f_max`` to 1, ``kind`` to
    ``"total"``, so every file written before kinds existed means what it meant). An optional
    ``meta`` object carries extra information (e.g. a planted structure, a known optimum).
``.csv``
    Six comma-separated columns, one wrench per line. An optional first line of non-numbers is a
    header; blank lines are ignored; lines starting with ``#`` are comments, and the comments
    ``# name: ...``, ``# f_max: ...`` and ``# kind: ...`` (written by :meth:`TaskRequirement.save`)
    set those fields.
``.npy``
    A float array of shape (t, 6) (``f_max`` = 1, kind ``total``, name = file stem).

A bad file raises :class:`TaskFileError` (a ValueError) naming the file and, where it applies,
the 1-based data row (header, blank and comment lines are not counted; the line number is given
too). Files are parsed completely before a task is built: nothing is ever half-loaded.

Seeded task generators share one interface, :class:`TaskGenerator` (``name`` and
``__call__(rng) -> TaskRequirement``): :class:`PaperTasks` (paper Sec. VI, errata 2),
:class:`PlantedTasks` (wrenches inside a hidden structure's zonotope, so the optimum is bounded),
:class:`ScrewdriverTask` (paper Fig. 1), :class:`MixedTasks` and :class:`FixedTasks`.
:func:`make_generator` turns a spec (a name, a file, tasks) into a generator; a *suite* is a JSON
file of several tasks (:func:`load_suite`, :func:`save_suite`).
"""

from __future__ import annotations

import csv
import json
import math
import os
import re
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Protocol, runtime_checkable

import numpy as np

from .module import GRAVITY, ModuleType
from .outputs import atomic_write, write_text
from .structure import Cell, Structure, free_neighbours
from .validation import check_f_max

SUFFIXES = (".json", ".csv", ".npy")
"""Task file formats understood by :meth:`TaskRequirement.load`."""

COLUMNS = ("fx", "fy", "fz", "tx", "ty", "tz")
"""Wrench components, in order (the CSV header written by :meth:`TaskRequirement.save`)."""

PathLike = str | os.PathLike

MAX_FILE_BYTES = 100 * 2**20
"""Largest task or suite file read (100 MiB): a larger one is refused before reading."""

MAX_WRENCHES = 1_000_000
"""Most wrenches in one task."""

TASK_KINDS = ("total", "external")
"""What a task's wrenches are (module docstring): the rotors' total wrench, or the wrench applied
to the environment, to which the rotors add the structure's weight."""

CSV_HEADER_MODES = ("auto", "yes", "no")
"""How a CSV's first row is read: ``auto`` (a row of non-numbers is a header; a row that reads
as the column numbers 0..5 that pandas writes, is refused as ambiguous), ``yes`` (the
first row is a header whatever it holds) or ``no`` (every row is a wrench)."""

_DECIMAL = re.compile(r"[+-]?(\d+\.?\d*|\.\d+)([eE][+-]?\d+)?|[+-]?(nan|inf|infinity)", re.I)


class TaskFileError(ValueError):
    """A task or suite file that cannot be read; the message names the file (and row)."""


# --------------------------------------------------------------------------------------------
# validation helpers
# --------------------------------------------------------------------------------------------
def _is_number(v: object) -> bool:
    return isinstance(v, (int, float, np.integer, np.floating)) and not isinstance(
        v, (bool, np.bool_)
    )


def _check_wrench_array(wrenches: object) -> np.ndarray:
    """A float (t, 6) copy of ``wrenches``; errors name the shape or the 1-based row."""
    try:
        arr = np.array(wrenches, dtype=float)
    except (TypeError, ValueError, OverflowError) as exc:
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


def _rows_to_array(rows: object) -> np.ndarray:
    """Parse a JSON-like list of 6-number rows, naming the first bad row (1-based)."""
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
        for j, v in enumerate(row):
            if not _is_number(v):
                raise ValueError(f"row {i}: {COLUMNS[j]} = {v!r} is not a number")
    return _check_wrench_array(rows)


def check_kind(kind: object, what: str = "kind") -> str:
    """``kind`` if it is one of :data:`TASK_KINDS`, else a ValueError naming ``what``."""
    if not isinstance(kind, str) or kind not in TASK_KINDS:
        raise ValueError(f"{what} must be one of {', '.join(TASK_KINDS)}, got {kind!r}")
    return kind


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


# --------------------------------------------------------------------------------------------
# the task requirement
# --------------------------------------------------------------------------------------------
@dataclass(frozen=True, eq=False)
class TaskRequirement:
    """A set of wrenches a structure must be able to exert (paper Def. 3).

    Args:
        wrenches: (t, 6) rows ``[fx, fy, fz, tx, ty, tz]`` in {S}, t >= 1, finite. Stored as a
            read-only float copy.
        name: a label for reports and file names.
        f_max: maximum thrust per rotor (> 0; normalised to 1 in the paper).
        meta: free-form JSON-serialisable extras (generator, planted cells, known optimum...);
            not part of equality.
        kind: ``"total"`` (default) or ``"external"`` (module docstring).

    Raises:
        ValueError: for a wrong shape, no wrenches, a non-finite value (naming the 1-based row),
            f_max <= 0 or an unknown kind.
    """

    wrenches: np.ndarray
    name: str = "task"
    f_max: float = 1.0
    meta: dict = field(default_factory=dict)
    kind: str = "total"

    def __post_init__(self) -> None:
        arr = _check_wrench_array(self.wrenches)
        arr.setflags(write=False)
        object.__setattr__(self, "wrenches", arr)
        object.__setattr__(self, "f_max", check_f_max(self.f_max))
        if not isinstance(self.name, str):
            raise ValueError(f"name must be a string, got {self.name!r}")
        if not isinstance(self.meta, dict):
            raise ValueError(f"meta must be a dict, got {type(self.meta).__name__}")
        object.__setattr__(self, "meta", dict(self.meta))
        object.__setattr__(self, "kind", check_kind(self.kind))

    def __setstate__(self, state: dict[str, Any]) -> None:
        """Unpickling (e.g. into vectorised-env workers) keeps the wrenches read-only."""
        object.__setattr__(self, "kind", "total")  # pickles from before kinds existed
        for key, value in state.items():
            object.__setattr__(self, key, value)
        self.wrenches.setflags(write=False)

    # --- identity -------------------------------------------------------------------------
    @property
    def n_wrenches(self) -> int:
        return self.wrenches.shape[0]

    def __len__(self) -> int:
        return self.n_wrenches

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, TaskRequirement):
            return NotImplemented
        return (
            self.name == other.name
            and self.f_max == other.f_max
            and self.kind == other.kind
            and np.array_equal(self.wrenches, other.wrenches)
        )

    def __hash__(self) -> int:
        return hash((self.name, self.f_max, self.kind, self.wrenches.tobytes()))

    def __repr__(self) -> str:
        kind = "" if self.kind == "total" else f", kind={self.kind!r}"
        return (
            f"TaskRequirement(name={self.name!r}, n_wrenches={self.n_wrenches}, "
            f"f_max={self.f_max:g}{kind})"
        )

    def rotor_wrenches(self, mass: float = 0.0) -> np.ndarray:
        """(t, 6) what the rotors must produce for a structure of ``mass`` kg: the wrenches
        themselves for a ``total`` task, plus the weight for an ``external`` one."""
        return rotor_wrenches(self.wrenches, self.kind, mass)

    # --- dicts ----------------------------------------------------------------------------
    def to_dict(self) -> dict[str, Any]:
        """``{"name", "f_max", "wrenches"}`` (plus ``"kind"`` when not ``total`` and ``"meta"``
        when not empty), JSON-ready."""
        out: dict[str, Any] = {"name": self.name, "f_max": self.f_max}
        if self.kind != "total":
            out["kind"] = self.kind
        out["wrenches"] = self.wrenches.tolist()
        if self.meta:
            out["meta"] = _jsonable(self.meta)
        return out

    @classmethod
    def from_dict(cls, data: dict[str, Any], default_name: str = "task") -> TaskRequirement:
        """Build from a dict as written by :meth:`to_dict`. Only ``"wrenches"`` is required;
        keys other than name, f_max, wrenches and meta are kept in ``meta`` (e.g. ``"optimum"``).
        Raises ValueError naming the missing key or bad row."""
        if not isinstance(data, dict):
            raise ValueError(f"a task must be a JSON object with a 'wrenches' list, got {data!r}")
        if "wrenches" not in data:
            hint = " (this looks like a suite: use load_suite)" if "tasks" in data else ""
            raise ValueError(f"no 'wrenches' key{hint}; keys present: {sorted(data)}")
        wrenches = _rows_to_array(data["wrenches"])
        name = data.get("name", default_name)
        if not isinstance(name, str):
            raise ValueError(f"'name' must be a string, got {name!r}")
        f_max = check_f_max(data.get("f_max", 1.0))
        kind = check_kind(data.get("kind", "total"), "'kind'")
        meta = data.get("meta", {})
        if not isinstance(meta, dict):
            raise ValueError(f"'meta' must be an object, got {meta!r}")
        known = ("name", "f_max", "wrenches", "meta", "kind")
        extra = {k: v for k, v in data.items() if k not in known}
        return cls(wrenches, name=name, f_max=f_max, meta={**meta, **extra}, kind=kind)

    # --- files ----------------------------------------------------------------------------
    @classmethod
    def load(cls, path: PathLike, csv_header: str = "auto") -> TaskRequirement:
        """Read a ``.json``, ``.csv`` or ``.npy`` task file (formats in the module docstring;
        ``csv_header`` as in :data:`CSV_HEADER_MODES`).

        Raises:
            FileNotFoundError: naming the path, when there is no such file.
            TaskFileError: naming the file (and 1-based row) for anything wrong in it.
        """
        path = Path(path)
        suffix = path.suffix.lower()
        if suffix not in SUFFIXES:
            raise TaskFileError(
                f"{path}: unknown task file type {path.suffix!r}; use one of {', '.join(SUFFIXES)}"
            )
        if not path.exists():
            raise FileNotFoundError(f"task file not found: {path}")
        if not path.is_file():
            raise TaskFileError(f"{path}: not a regular file")
        try:
            if suffix == ".json":
                return cls.from_dict(_read_json(path), default_name=path.stem)
            if suffix == ".csv":
                return _load_csv(path, csv_header)
            return _load_npy(path)
        except TaskFileError:
            raise
        except ValueError as exc:
            raise TaskFileError(f"{path}: {exc}") from None

    def save(self, path: PathLike) -> Path:
        """Write the task as ``.json`` (name, f_max, kind, wrenches, meta), ``.csv`` (header and
        ``# name`` / ``# f_max`` / ``# kind`` comments) or ``.npy`` (wrenches only; needs
        f_max == 1 and kind ``total``, since the format cannot hold them). Floats are written
        exactly (shortest round-trip repr)."""
        path = Path(path)
        suffix = path.suffix.lower()
        if suffix not in SUFFIXES:
            raise ValueError(
                f"{path}: unknown task file type {path.suffix!r}; use one of {', '.join(SUFFIXES)}"
            )
        if suffix == ".json":
            write_text(path, _task_json(self.to_dict()) + "\n")
        elif suffix == ".csv":
            lines = [f"# name: {self.name}", f"# f_max: {self.f_max!r}"]
            if self.kind != "total":
                lines.append(f"# kind: {self.kind}")
            lines.append(",".join(COLUMNS))
            lines += [",".join(repr(float(v)) for v in row) for row in self.wrenches]
            write_text(path, "\n".join(lines) + "\n")
        else:
            if self.f_max != 1.0 or self.kind != "total":
                what = f"f_max={self.f_max:g}" if self.f_max != 1.0 else f"kind={self.kind}"
                raise ValueError(f"{path}: .npy holds only the wrenches, not {what}; save as .json")
            data = np.asarray(self.wrenches, dtype=float)
            atomic_write(path, lambda tmp: np.save(tmp.open("wb"), data))
        return path


def task_files(specs: Sequence[PathLike], what: str = "--task") -> list[Path]:
    """Task file paths from ``specs``: a file (kept as given, checked when loaded), a folder
    (its task files, by name) or a glob pattern (its matches, by name); in order, each path once.
    A folder without task files or a pattern that matches nothing is a ValueError."""
    import glob

    out: dict[Path, None] = {}
    for spec in specs:
        text = str(spec)
        path = Path(text)
        if path.is_dir():
            found = sorted(
                p for p in path.iterdir() if p.is_file() and p.suffix.lower() in SUFFIXES
            )
            if not found:
                raise ValueError(
                    f"{what}: folder {path} holds no task file ({', '.join(SUFFIXES)})"
                )
        elif glob.has_magic(text) and not path.exists():
            found = sorted(Path(p) for p in glob.glob(text) if Path(p).is_file())
            if not found:
                raise ValueError(f"{what}: no file matches {text!r}")
        else:
            found = [path]
        out.update(dict.fromkeys(found))
    return list(out)


def _jsonable(obj: Any) -> Any:
    """Numpy scalars/arrays and tuples turned into plain JSON types."""
    if isinstance(obj, dict):
        return {str(k): _jsonable(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_jsonable(v) for v in obj]
    if isinstance(obj, np.ndarray):
        return _jsonable(obj.tolist())
    if isinstance(obj, np.generic):
        return obj.item()
    return obj


def _task_json(d: dict[str, Any], indent: str = "") -> str:
    """A task dict as JSON with one wrench row per line (readable and diff-friendly)."""
    inner = indent + "  "
    parts = []
    for key, value in d.items():
        if key == "wrenches":
            rows = (inner + "  " + json.dumps(row) for row in value)
            parts.append(f'{inner}"wrenches": [\n' + ",\n".join(rows) + f"\n{inner}]")
        else:
            parts.append(f"{inner}{json.dumps(key)}: {json.dumps(value)}")
    return "{\n" + ",\n".join(parts) + f"\n{indent}}}"


def _read_text(path: Path) -> str:
    """The file's text (UTF-8, with or without a byte-order mark), refusing huge files."""
    size = path.stat().st_size
    if size > MAX_FILE_BYTES:
        raise TaskFileError(f"{path}: {size:,} bytes, more than the {MAX_FILE_BYTES:,} read")
    try:
        return path.read_text(encoding="utf-8-sig")
    except UnicodeDecodeError as exc:
        raise TaskFileError(f"{path}: not UTF-8 text ({exc.reason} at byte {exc.start})") from None


def _json_int(text: str) -> int | float:
    """JSON integers as ints, except absurdly long ones, which become (infinite) floats and
    are then refused by the checks with the row they are in."""
    return int(text) if len(text) <= 300 else float("inf")


def _read_json(path: Path) -> Any:
    text = _read_text(path)
    if not text.strip():
        raise TaskFileError(f"{path}: the file is empty")
    try:
        return json.loads(text, parse_int=_json_int)
    except json.JSONDecodeError as exc:
        raise TaskFileError(
            f"{path}: not valid JSON: {exc.msg} at line {exc.lineno}, column {exc.colno} "
            f"(char {exc.pos})"
        ) from None
    except RecursionError:
        raise TaskFileError(f"{path}: JSON nested too deeply") from None


def _looks_like_column_numbers(values: list[float | None]) -> bool:
    return values == [0.0, 1.0, 2.0, 3.0, 4.0, 5.0]


def _load_csv(path: Path, header: str = "auto") -> TaskRequirement:
    if header not in CSV_HEADER_MODES:
        raise ValueError(f"csv_header must be one of {', '.join(CSV_HEADER_MODES)}, got {header!r}")
    text = _read_text(path)
    name, f_max, kind = path.stem, 1.0, "total"
    rows: list[list[float]] = []
    header_allowed = header != "no"
    for lineno, cells in enumerate(csv.reader(text.splitlines()), 1):
        cells = [c.strip() for c in cells]
        if not any(cells):
            continue
        if cells[0].startswith("#"):
            comment = ",".join(cells).lstrip("#").strip()
            key, _, value = comment.partition(":")
            if key.strip() == "name" and value.strip():
                name = value.strip()
            elif key.strip() == "f_max":
                try:
                    f_max = float(value)
                except ValueError:
                    raise TaskFileError(
                        f"{path}: line {lineno}: f_max comment {value.strip()!r} is not a number"
                    ) from None
            elif key.strip() == "kind":
                try:
                    kind = check_kind(value.strip(), "kind comment")
                except ValueError as exc:
                    raise TaskFileError(f"{path}: line {lineno}: {exc}") from None
            continue
        parsed = [_to_float(c) for c in cells]
        if header_allowed and (header == "yes" or all(v is None for v in parsed)):
            header_allowed = False  # the header line
            continue
        if header_allowed and header == "auto" and _looks_like_column_numbers(parsed):
            raise TaskFileError(
                f"{path}: line {lineno}: the first row {','.join(cells)} looks like column "
                "numbers (pandas writes them as a header); say how to read it with "
                "--csv-header yes (skip it) or --csv-header no (a wrench)"
            )
        header_allowed = False
        row = len(rows) + 1
        where = f"{path}: row {row} (line {lineno})"
        if len(cells) != 6:
            raise TaskFileError(
                f"{where}: expected 6 columns (fx, fy, fz, tx, ty, tz), got {len(cells)}"
            )
        for j, (cell, v) in enumerate(zip(cells, parsed, strict=True)):
            if v is None:
                raise TaskFileError(f"{where}: {COLUMNS[j]} = {cell!r} is not a number")
            if not math.isfinite(v):
                raise TaskFileError(f"{where}: {COLUMNS[j]} is {cell!r} (wrenches must be finite)")
        rows.append(parsed)  # type: ignore[arg-type]
    if not rows:
        raise TaskFileError(f"{path}: no wrenches (the file is empty or has only a header)")
    try:
        return TaskRequirement(np.array(rows), name=name, f_max=f_max, kind=kind)
    except ValueError as exc:
        raise TaskFileError(f"{path}: {exc}") from None


def _to_float(cell: str) -> float | None:
    """The number a CSV cell holds (plain decimal notation only: ``1_0`` is not ten)."""
    return float(cell) if _DECIMAL.fullmatch(cell) else None


def _load_npy(path: Path) -> TaskRequirement:
    try:
        arr = np.load(path, allow_pickle=False)
    except (ValueError, OSError, EOFError) as exc:
        raise TaskFileError(f"{path}: not a readable .npy array: {exc}") from None
    if not isinstance(arr, np.ndarray):
        raise TaskFileError(f"{path}: an .npz archive, not an .npy array of shape (t, 6)")
    if arr.dtype.kind not in "iuf":
        raise TaskFileError(f"{path}: expected a numeric array of shape (t, 6), got {arr.dtype}")
    if arr.ndim != 2 or arr.shape[1] != 6 or arr.shape[0] == 0:
        raise TaskFileError(
            f"{path}: expected an array of shape (t, 6) with t >= 1, got {arr.shape}"
        )
    return TaskRequirement(arr, name=path.stem)


# --------------------------------------------------------------------------------------------
# suites
# --------------------------------------------------------------------------------------------
def load_suite(path: PathLike) -> list[TaskRequirement]:
    """Read a suite: a JSON file ``{"name": ..., "tasks": [task dicts...]}`` (task dicts as in
    :meth:`TaskRequirement.to_dict`, extra keys such as ``"optimum"`` kept in ``meta``).
    Raises TaskFileError naming the file and the 1-based task (and row)."""
    path = Path(path)
    if not path.exists():
        raise FileNotFoundError(f"suite file not found: {path}")
    data = _read_json(path)
    if not isinstance(data, dict) or not isinstance(data.get("tasks"), list):
        raise TaskFileError(f'{path}: a suite is a JSON object with a "tasks" list')
    if not data["tasks"]:
        raise TaskFileError(f"{path}: the suite has no tasks")
    tasks = []
    for i, item in enumerate(data["tasks"], 1):
        try:
            tasks.append(TaskRequirement.from_dict(item, default_name=f"{path.stem}-{i}"))
        except ValueError as exc:
            raise TaskFileError(f"{path}: task {i}: {exc}") from None
    return tasks


def save_suite(tasks: Sequence[TaskRequirement], path: PathLike, name: str | None = None) -> Path:
    """Write ``tasks`` as a suite JSON file (see :func:`load_suite`); name defaults to the stem."""
    path = Path(path)
    tasks = list(tasks)
    if not tasks or not all(isinstance(t, TaskRequirement) for t in tasks):
        raise ValueError("save_suite needs a non-empty sequence of TaskRequirement")
    body = ",\n".join("    " + _task_json(t.to_dict(), indent="    ") for t in tasks)
    head = json.dumps(name if name is not None else path.stem)
    write_text(path, f'{{\n  "name": {head},\n  "tasks": [\n{body}\n  ]\n}}\n')
    return path


# --------------------------------------------------------------------------------------------
# generators
# --------------------------------------------------------------------------------------------
@runtime_checkable
class TaskGenerator(Protocol):
    """Anything with a ``name`` that draws a task from a numpy Generator (deterministic under
    the generator's seed)."""

    name: str

    def __call__(self, rng: np.random.Generator) -> TaskRequirement: ...


Count = int | tuple[int, int]


def _check_count(value: Count, what: str, low: int = 1) -> None:
    lo, hi = (value, value) if isinstance(value, (int, np.integer)) else tuple(value)
    if not all(isinstance(v, (int, np.integer)) and not isinstance(v, bool) for v in (lo, hi)):
        raise ValueError(f"{what} must be an int or an inclusive (lo, hi) pair, got {value!r}")
    if not low <= lo <= hi:
        raise ValueError(f"{what} must satisfy {low} <= lo <= hi, got {value!r}")


def _draw_count(rng: np.random.Generator, value: Count) -> int:
    if isinstance(value, (int, np.integer)):
        return int(value)
    lo, hi = value
    return int(rng.integers(lo, hi + 1))


FZ_READINGS = ("abs", "shift", "literal")


@dataclass(frozen=True)
class PaperTasks:
    """Random tasks as in the paper's Sec. VI, with errata 2 resolved.

    The paper draws every component from U(-0.5, 0.5) and multiplies f_z by 30. Read literally
    half the wrenches have f_z < 0, which upward rotors never produce. Each component here is
    u ~ U(-scale, scale); f_x, f_y and the torques are u, and f_z is, by ``fz_reading``:

    ``"abs"`` (default)
        f_z = fz_offset + fz_gain * |u|, uniform on [fz_offset, fz_offset + fz_gain * scale].
    ``"shift"``
        f_z = fz_offset + fz_gain * (u + scale), uniform on [fz_offset, fz_offset + 2 fz_gain
        scale].
    ``"literal"``
        f_z = fz_offset + fz_gain * u (as written; mostly infeasible, for completeness).

    Why the defaults are not the paper's numbers (fz_offset=0, fz_gain=30): a wrench with small
    f_z cannot carry the lateral force and torque the other components ask for. For a T-module
    (eta = pi/4) every rotor's horizontal thrust is at most its vertical thrust / sqrt(2), so
    |f_x|, |f_y| <= f_z / sqrt(2) for *every* structure. With f_z = 30 |u| about 2.4 % of
    wrenches violate this, so a task of 80 wrenches is infeasible for every structure with
    probability about 98 %; the f_z = 15 wrenches alone also need >= 6 modules of lift
    (4 n cos(pi/4) = 2.83 n). The defaults ``fz_offset=3, fz_gain=12`` keep the paper's spirit
    (a gravity offset plus uniform noise, f_z on [3, 9]) and give exhaustive optima of 4-5
    modules (the paper reports 4). ``PaperTasks(fz_offset=0, fz_gain=30)`` is the literal paper.

    ``kind="external"`` labels the same wrenches as external (the rotors add the structure's
    weight; SI units, so choose ``f_max`` in newtons, e.g. 2.0).
    """

    n_wrenches: Count = 80
    scale: float = 0.5
    fz_gain: float = 12.0
    fz_reading: str = "abs"
    fz_offset: float = 3.0
    f_max: float = 1.0
    name: str = "paper"
    kind: str = "total"

    def __post_init__(self) -> None:
        _check_count(self.n_wrenches, "n_wrenches")
        if not (self.scale > 0 and math.isfinite(self.scale)):
            raise ValueError(f"scale must be positive and finite, got {self.scale!r}")
        if not (self.fz_gain > 0 and math.isfinite(self.fz_gain)):
            raise ValueError(f"fz_gain must be positive and finite, got {self.fz_gain!r}")
        if not (self.fz_offset >= 0 and math.isfinite(self.fz_offset)):
            raise ValueError(f"fz_offset must be >= 0 and finite, got {self.fz_offset!r}")
        if self.fz_reading not in FZ_READINGS:
            raise ValueError(
                f"fz_reading must be one of {', '.join(FZ_READINGS)}, got {self.fz_reading!r}"
            )
        check_f_max(self.f_max)
        check_kind(self.kind)

    def __call__(self, rng: np.random.Generator) -> TaskRequirement:
        t = _draw_count(rng, self.n_wrenches)
        W = rng.uniform(-self.scale, self.scale, size=(t, 6))
        u = W[:, 2]
        if self.fz_reading == "abs":
            W[:, 2] = self.fz_offset + self.fz_gain * np.abs(u)
        elif self.fz_reading == "shift":
            W[:, 2] = self.fz_offset + self.fz_gain * (u + self.scale)
        else:
            W[:, 2] = self.fz_offset + self.fz_gain * u
        meta = {"generator": "paper", "fz_reading": self.fz_reading}
        return TaskRequirement(
            W, name=f"{self.name}-{self.fz_reading}", f_max=self.f_max, meta=meta, kind=self.kind
        )


def random_cells(rng: np.random.Generator, n: int) -> list[Cell]:
    """A random connected structure of ``n`` modules grown from (0, 0): each new module docks at
    a uniformly chosen free neighbour. Cells in growth order (the first is the initial module)."""
    if n < 1:
        raise ValueError(f"a structure needs n >= 1 modules, got {n}")
    cells: list[Cell] = [(0, 0)]
    while len(cells) < n:
        free = free_neighbours(cells)
        cells.append(free[int(rng.integers(len(free)))])
    return cells


@dataclass(frozen=True)
class PlantedTasks:
    """Tasks with a known feasible structure: wrenches drawn inside a hidden structure's zonotope.

    A random connected structure of n modules (n uniform in ``n_modules``, grown by
    :func:`random_cells`) is drawn; each wrench is ``A u``. Interior wrenches use
    u ~ U(0, f_max)^m. A ``boundary_fraction`` of them start from the support point of a random
    direction d (u_j = f_max where d . a_j > 0, else 0: the vertex of W that maximises d . w) and
    keep each entry with probability ``p_extreme`` (else redraw it uniformly), which lands on or
    near vertices and faces of W. (A random 0/f_max input would not do: with 4n > 6 rotors most
    such inputs map to interior wrenches.)
    Every entry is then clipped to [slack, 1 - slack] * f_max, so the hidden structure's margin
    (:func:`modquad_gym.oracle.margin`) is >= 2 * slack: feasible beyond any solver tolerance.
    Hence the optimum is <= n. ``meta`` holds ``planted_cells`` (growth order) and
    ``optimum_upper_bound``; see :func:`planted_structure`.

    With ``kind="external"`` the hidden structure's weight is subtracted (w = A u - m g e_z), so
    it still produces exactly the rotor wrenches A u and the optimum stays <= n.
    """

    n_modules: Count = (2, 6)
    n_wrenches: Count = (8, 80)
    boundary_fraction: float = 0.5
    module: ModuleType | None = None
    f_max: float = 1.0
    p_extreme: float = 0.8
    slack: float = 1e-3
    name: str = "planted"
    kind: str = "total"

    def __post_init__(self) -> None:
        _check_count(self.n_modules, "n_modules")
        _check_count(self.n_wrenches, "n_wrenches")
        for what, v in (
            ("boundary_fraction", self.boundary_fraction),
            ("p_extreme", self.p_extreme),
        ):
            if not 0.0 <= v <= 1.0:
                raise ValueError(f"{what} must lie in [0, 1], got {v!r}")
        if not 0.0 <= self.slack < 0.5:
            raise ValueError(f"slack must lie in [0, 0.5), got {self.slack!r}")
        check_f_max(self.f_max)
        check_kind(self.kind)

    def __call__(self, rng: np.random.Generator) -> TaskRequirement:
        n = _draw_count(rng, self.n_modules)
        t = _draw_count(rng, self.n_wrenches)
        cells = random_cells(rng, n)
        hidden = Structure(cells, module=self.module)
        A = hidden.configuration_matrix()
        m = A.shape[1]
        U = rng.uniform(0.0, 1.0, size=(t, m))
        boundary = rng.random(t) < self.boundary_fraction
        # support points: u_j = 1 where d . a_j > 0 maximises d . w over W, a vertex of W
        D = rng.normal(size=(t, 6))
        vertex = (D @ A > 0).astype(float)
        extreme = boundary[:, None] & (rng.random((t, m)) < self.p_extreme)
        U = np.where(extreme, vertex, U)
        U = np.clip(U, self.slack, 1.0 - self.slack) * self.f_max
        W = U @ A.T
        if self.kind == "external":
            W[:, 2] -= hidden.mass * GRAVITY
        text = ";".join(f"{x},{y}" for x, y in cells)
        meta = {
            "generator": "planted",
            "planted_cells": [list(c) for c in cells],
            "optimum_upper_bound": n,
            "n_boundary": int(boundary.sum()),
        }
        return TaskRequirement(
            W, name=f"{self.name}[{text}]", f_max=self.f_max, meta=meta, kind=self.kind
        )


def planted_structure(task: TaskRequirement, module: ModuleType | None = None) -> Structure | None:
    """The hidden structure of a planted task (from ``meta["planted_cells"]``), else None."""
    cells = task.meta.get("planted_cells")
    return None if cells is None else Structure([tuple(c) for c in cells], module=module)


@dataclass(frozen=True)
class ScrewdriverTask:
    """The paper's Fig. 1 task: hold a screwdriver, align it, then drive a screw about z.

    Two wrenches (normalised units, f_max = 1 per rotor, newtons and newton-metres):

    * w1, translation and alignment: ``[push, 0, lift, 0, align, 0]`` - a forward force that
      moves the tool tip onto the screw head, the hover lift, and a small pitch torque that
      keeps the shaft aligned against the tool's offset weight;
    * w2, driving: ``[0, 0, lift + press, 0, 0, torque]`` - the driving torque about the
      vertical screw axis, while pressing the bit onto the screw with ``press`` extra lift.

    Defaults (lift 3.0 = hover of a small structure and tool, push 0.8, align 0.1, torque 0.5,
    press 0.5) are feasible for a few modules and for no single module; the optimum, by
    exhaustive search, is small (see ``examples/README.md``). ``__call__`` ignores the rng.
    ``kind="external"`` labels the wrenches as applied to the tool (SI units; the rotors add the
    structure's weight), with ``lift`` then the tool's weight and the press.
    """

    push: float = 0.8
    torque: float = 0.5
    lift: float = 3.0
    align: float = 0.1
    press: float = 0.5
    f_max: float = 1.0
    name: str = "screwdriver"
    kind: str = "total"

    def __post_init__(self) -> None:
        for what in ("push", "torque", "lift", "align", "press"):
            v = getattr(self, what)
            if not math.isfinite(v):
                raise ValueError(f"{what} must be finite, got {v!r}")
        if self.lift <= 0 or self.lift + self.press <= 0:
            raise ValueError(f"lift must be positive (rotors push up), got {self.lift!r}")
        check_f_max(self.f_max)
        check_kind(self.kind)

    def task(self) -> TaskRequirement:
        W = np.array(
            [
                [self.push, 0.0, self.lift, 0.0, self.align, 0.0],
                [0.0, 0.0, self.lift + self.press, 0.0, 0.0, self.torque],
            ]
        )
        return TaskRequirement(
            W, name=self.name, f_max=self.f_max, meta={"generator": "screwdriver"}, kind=self.kind
        )

    def __call__(self, rng: np.random.Generator) -> TaskRequirement:
        return self.task()


@dataclass(frozen=True)
class FixedTasks:
    """Given tasks, one drawn uniformly at random per call (deterministic under the seed)."""

    tasks: tuple[TaskRequirement, ...]
    name: str = "fixed"

    def __post_init__(self) -> None:
        object.__setattr__(self, "tasks", tuple(self.tasks))
        if not self.tasks or not all(isinstance(t, TaskRequirement) for t in self.tasks):
            raise ValueError("FixedTasks needs a non-empty sequence of TaskRequirement")

    def __call__(self, rng: np.random.Generator) -> TaskRequirement:
        if len(self.tasks) == 1:
            return self.tasks[0]
        return self.tasks[int(rng.integers(len(self.tasks)))]


@dataclass(frozen=True)
class MixedTasks:
    """Draws a generator (by ``weights``, uniform by default), then a task from it."""

    generators: tuple[TaskGenerator, ...]
    weights: tuple[float, ...] | None = None
    name: str = "mixed"

    def __post_init__(self) -> None:
        gens = tuple(self.generators)
        object.__setattr__(self, "generators", gens)
        if not gens or not all(isinstance(g, TaskGenerator) for g in gens):
            raise ValueError("MixedTasks needs a non-empty sequence of task generators")
        if self.weights is not None:
            w = tuple(float(x) for x in self.weights)
            if len(w) != len(gens):
                raise ValueError(f"got {len(w)} weights for {len(gens)} generators")
            if not all(x >= 0 and math.isfinite(x) for x in w) or sum(w) <= 0:
                raise ValueError(f"weights must be >= 0, finite and not all zero, got {w}")
            object.__setattr__(self, "weights", w)

    def __call__(self, rng: np.random.Generator) -> TaskRequirement:
        if self.weights is None:
            k = int(rng.integers(len(self.generators)))
        else:
            p = np.asarray(self.weights) / sum(self.weights)
            k = int(rng.choice(len(self.generators), p=p))
        return self.generators[k](rng)


@dataclass(frozen=True)
class PlantedMixedTasks:
    """Tasks planted in a random mixed structure: ``n_modules`` cells (uniform in the range),
    each of a module type drawn uniformly from ``modules`` (stock names, comma-separated); 40
    wrenches ``A u`` with half the entries of u near 0 or f_max (vertex-like) and the rest
    uniform in [0.02, 0.98] f_max. An ``external`` task has the hidden structure's weight
    subtracted from f_z, so that structure still satisfies it: the palette's optimum is at most
    the hidden size."""

    modules: str = "t45,t45m,flat"
    n_modules: Count = (3, 6)
    n_wrenches: int = 40
    kind: str = "total"
    f_max: float = 1.0
    name: str = "planted-mixed"

    def __post_init__(self) -> None:
        _check_count(self.n_modules, "n_modules")
        check_kind(self.kind)
        check_f_max(self.f_max)

    def __call__(self, rng: np.random.Generator) -> TaskRequirement:
        from .module import palette

        types = palette(self.modules)
        lo, hi = (
            (self.n_modules, self.n_modules) if isinstance(self.n_modules, int) else self.n_modules
        )
        n = int(rng.integers(lo, hi + 1))
        cells = random_cells(rng, n)
        hidden = Structure(cells, modules=[types[int(rng.integers(len(types)))] for _ in cells])
        A = hidden.configuration_matrix()
        U = rng.uniform(0.02, 0.98, size=(self.n_wrenches, A.shape[1]))
        vertex = rng.random(U.shape) < 0.5
        U[vertex] = np.where(rng.random(int(vertex.sum())) < 0.5, 0.02, 0.98)
        W = (U * self.f_max) @ A.T
        if self.kind == "external":
            W[:, 2] -= hidden.mass * GRAVITY
        meta = {
            "hidden_cells": [list(c) for c in cells],
            "hidden_modules": [m.name for m in hidden.modules],
            "optimum_upper_bound": n,
        }
        return TaskRequirement(W, name=self.name, f_max=self.f_max, kind=self.kind, meta=meta)


NAMED_GENERATORS: dict[str, Callable[[], TaskGenerator]] = {
    "paper": PaperTasks,
    "planted": PlantedTasks,
    "screwdriver": ScrewdriverTask,
    "mixed": lambda: MixedTasks((PlantedTasks(), PaperTasks())),
    "planted-large": lambda: PlantedTasks(n_modules=(6, 12), name="planted-large"),
    "paper-external": lambda: PaperTasks(n_wrenches=40, kind="external", f_max=2.0,
                                         fz_offset=1.0, fz_gain=8.0, name="paper-external"),
    "planted-mixed-external": lambda: PlantedMixedTasks(kind="external", f_max=2.0,
                                                        name="planted-mixed-external"),
}  # fmt: skip
"""The task sources by name (each call makes a fresh generator)."""
GENERATORS = tuple(NAMED_GENERATORS)
"""Names understood by :func:`make_generator`."""


def make_generator(spec: Any) -> TaskGenerator:
    """A task generator from a spec:

    * ``"paper"``, ``"planted"``, ``"screwdriver"``, ``"mixed"`` (planted and paper, equal odds);
      ``"planted-large"`` (planted in 6-12 modules: the large tier), ``"paper-external"``
      (paper-like wrenches on the environment, kind ``external``, f_max 2 N) and
      ``"planted-mixed-external"`` (:class:`PlantedMixedTasks`, external, f_max 2 N: the mixed
      tier);
    * a path to a task file (``.json``/``.csv``/``.npy``) or a suite JSON: those fixed tasks;
    * a :class:`TaskRequirement`: always that task; a :class:`TaskGenerator` (``name`` and
      ``__call__(rng)``): itself;
    * any other callable ``gen(rng)`` (a function, a lambda, a bound method): wrapped as a
      generator named after it; each result must be a :class:`TaskRequirement` or a (t, 6)
      wrench array (made a TaskRequirement), anything else raises ValueError when drawn. The
      wrapper pickles when ``gen`` does;
    * a list or tuple of any of these: tasks are pooled into one :class:`FixedTasks` (uniform
      over tasks); if any element is a random generator, a :class:`MixedTasks` (uniform over
      elements).

    Raises ValueError naming the spec (TaskFileError for a bad file).
    """
    if isinstance(spec, TaskRequirement):
        return FixedTasks((spec,), name=spec.name)
    if isinstance(spec, (list, tuple)):
        if not spec:
            raise ValueError("an empty list is not a task spec")
        gens = [make_generator(s) for s in spec]
        if all(isinstance(g, FixedTasks) for g in gens):
            pooled = tuple(t for g in gens for t in g.tasks)  # type: ignore[attr-defined]
            return FixedTasks(pooled, name="+".join(g.name for g in gens))
        return MixedTasks(tuple(gens), name="+".join(g.name for g in gens))
    if isinstance(spec, (str, os.PathLike)):
        key = os.fspath(spec)
        if key in NAMED_GENERATORS:
            return NAMED_GENERATORS[key]()
        path = Path(key)
        if path.is_file():
            if path.suffix.lower() == ".json" and "tasks" in _json_keys(path):
                return FixedTasks(tuple(load_suite(path)), name=path.stem)
            return FixedTasks((TaskRequirement.load(path),), name=path.stem)
        raise ValueError(
            f"unknown task spec {key!r}: not one of {', '.join(GENERATORS)} and not an existing "
            f"task file ({', '.join(SUFFIXES)})"
        )
    if isinstance(spec, type):  # before the protocol check: a class has name and __call__
        raise ValueError(
            f"cannot make a task generator from the class {spec.__name__}; pass an instance "
            f"(e.g. {spec.__name__}()) or a function gen(rng) -> TaskRequirement"
        )
    if isinstance(spec, TaskGenerator):
        return spec
    if callable(spec):

        class CallableTasks:
            """A callable ``gen(rng)`` as a TaskGenerator; its results are checked."""

            def __init__(self, fn: Any) -> None:
                self.fn = fn
                self.name = str(getattr(fn, "__name__", None) or type(fn).__name__)

            def __call__(self, rng: np.random.Generator) -> TaskRequirement:
                task = self.fn(rng)
                if isinstance(task, TaskRequirement):
                    return task
                what = f"task generator {self.name!r} returned"
                if not isinstance(task, (np.ndarray, list, tuple)):
                    raise ValueError(
                        f"{what} {type(task).__name__}; it must return a TaskRequirement or a "
                        f"(t, 6) wrench array"
                    )
                try:
                    return TaskRequirement(task, name=self.name)
                except ValueError as exc:
                    raise ValueError(f"{what} a bad wrench array: {exc}") from None

            def __reduce__(self) -> tuple:  # pickles as make_generator(fn)
                return (make_generator, (self.fn,))

            def __repr__(self) -> str:
                return f"make_generator({self.fn!r})"

        return CallableTasks(spec)
    raise ValueError(
        f"cannot make a task generator from {type(spec).__name__} {spec!r}; give a name "
        f"({', '.join(GENERATORS)}), a task file, a TaskRequirement, a generator (any "
        f"callable gen(rng) -> TaskRequirement) or a list"
    )


def _json_keys(path: Path) -> set[str]:
    data = _read_json(path)
    return set(data) if isinstance(data, dict) else set()
