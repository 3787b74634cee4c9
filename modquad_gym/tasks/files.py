"""Task files on disk: reading and writing ``.json``, ``.csv`` and ``.npy`` (the formats are
described in the package docstring, :mod:`modquad_gym.tasks`), folders and globs of them.

A bad file raises :class:`TaskFileError` (a ValueError) naming the file and, where it applies,
the 1-based data row and the line. Files are parsed completely before a task is built: nothing is
ever half-loaded. ``TaskRequirement.load`` (:mod:`.requirement`) turns what these readers return
into a task.
"""

from __future__ import annotations

import csv
import json
import math
import os
import re
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from modquad_gym.tasks.wrenches import COLUMNS, check_kind

SUFFIXES = (".json", ".csv", ".npy")
"""Task file formats understood by :meth:`TaskRequirement.load`."""

PathLike = str | os.PathLike

MAX_FILE_BYTES = 100 * 2**20
"""Largest task or suite file read (100 MiB): a larger one is refused before reading."""

CSV_HEADER_MODES = ("auto", "yes", "no")
"""How a CSV's first row is read: ``auto`` (a row of non-numbers is a header; a row that reads
as the column numbers 0..5 that pandas writes, is refused as ambiguous), ``yes`` (the
first row is a header whatever it holds) or ``no`` (every row is a wrench)."""

_DECIMAL = re.compile(r"[+-]?(\d+\.?\d*|\.\d+)([eE][+-]?\d+)?|[+-]?(nan|inf|infinity)", re.I)


class TaskFileError(ValueError):
    """A task or suite file that cannot be read; the message names the file (and row)."""


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


def jsonable(obj: Any) -> Any:
    """Numpy scalars/arrays and tuples turned into plain JSON types."""
    if isinstance(obj, dict):
        return {str(k): jsonable(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [jsonable(v) for v in obj]
    if isinstance(obj, np.ndarray):
        return jsonable(obj.tolist())
    if isinstance(obj, np.generic):
        return obj.item()
    return obj


def task_json(d: dict[str, Any], indent: str = "") -> str:
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


def read_text(path: Path) -> str:
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


def read_json(path: Path) -> Any:
    """A JSON file's data; a bad file is a TaskFileError naming the line and column."""
    text = read_text(path)
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


def read_csv(path: Path, header: str = "auto") -> tuple[np.ndarray, str, float, str]:
    """The wrenches, name, f_max and kind of a CSV task file (module docstring); a bad file
    is a TaskFileError naming the file, the 1-based row and the line."""
    if header not in CSV_HEADER_MODES:
        raise ValueError(f"csv_header must be one of {', '.join(CSV_HEADER_MODES)}, got {header!r}")
    text = read_text(path)
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
    return np.array(rows), name, f_max, kind


def _to_float(cell: str) -> float | None:
    """The number a CSV cell holds (plain decimal notation only: ``1_0`` is not ten)."""
    return float(cell) if _DECIMAL.fullmatch(cell) else None


def read_npy(path: Path) -> np.ndarray:
    """The (t, 6) array of an ``.npy`` task file; a bad file is a TaskFileError naming it."""
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
    return arr


def json_keys(path: Path) -> set[str]:
    """The top-level keys of a JSON file (none when it is not an object)."""
    data = read_json(path)
    return set(data) if isinstance(data, dict) else set()
