"""Task files on disk: reading and writing ``.json``, ``.csv`` and ``.npy`` (the formats are
described in the package docstring, :mod:`modquad_gym.tasks`), folders and globs of them.

A bad file raises :class:`TaskFileError` (a ValueError) naming the file and, where it applies,
the 1-based data row and the line. Reading is strict: a key the format does not know, a key given
twice, a CSV header that names no column are refused, never guessed at. Sizes are checked before
the work that depends on them (bytes before reading, rows before parsing, an .npy header before its
data). Files are parsed completely before a task is built: nothing is ever half-loaded.
``TaskRequirement.load`` (:mod:`.requirement`) turns what these readers return into a task.
"""

from __future__ import annotations

import difflib
import json
import math
import os
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from modquad_gym.core.validation import (
    check_path,  # noqa: F401 (the tasks' check, named here)
    read_regular_file,
)
from modquad_gym.tasks.wrenches import MAX_WRENCHES

SUFFIXES = (".json", ".csv", ".npy")
"""Task file formats understood by :meth:`TaskRequirement.load`."""

PathLike = str | os.PathLike

MAX_FILE_BYTES = 100 * 2**20
"""Largest task or suite file read (100 MiB): a larger one is refused before reading."""

TASK_KEYS: dict[str, tuple[str, ...]] = {
    "wrenches": ("wrenches", "name", "f_max", "kind", "meta"),
    "trajectory": ("trajectory", "payload", "exerted", "f_max", "name", "kind", "meta"),
}
"""The keys a task JSON object may hold, by the key that marks its format: a static task holds
``"wrenches"``, a dynamic one (:class:`~modquad_gym.dynamics.DynamicTask`) ``"trajectory"``. Any
other key is refused with this list, so a misspelt ``"fmax"`` is never read as a default;
free-form extras go into ``"meta"``. A new format adds its row here."""

SUITE_KEYS = ("name", "tasks")
"""The keys a suite JSON object may hold."""

MAX_JSON_CONTAINERS = MAX_WRENCHES + 100_000
"""Most JSON arrays and objects (``[`` and ``{``, counted in the text, strings included) a task or
suite file may hold: every wrench is an array, so a file beyond this is refused before it is
parsed. Parsing builds a Python list or dict per container (56 to 64 bytes for an empty one out
of 2 bytes of text); with :data:`MAX_JSON_VALUES` this bounds what parsing a file of
:data:`MAX_FILE_BYTES` can cost."""

MAX_JSON_VALUES = 8 * MAX_WRENCHES
"""Most commas (separators of JSON values, counted in the text, strings included) a task or suite
file may hold: a wrench row of six numbers takes six, a trajectory sample at most 33, so a task
of :data:`MAX_WRENCHES` wrenches fits. Refused before parsing: a float costs 32 bytes parsed (4
bytes of text), a short string 58, and a file of 25 million values would take 1.5 GB."""


class TaskFileError(ValueError):
    """A task or suite file that cannot be read; the message names the file (and row)."""


def close_key(key: str, known: Sequence[str]) -> str | None:
    """The key of ``known`` that ``key`` misspells (``fmax``, ``F-Max``: ``f_max``), or None."""
    folded = {k.replace("_", "").replace("-", "").lower(): k for k in known}
    guess = folded.get(key.replace("_", "").replace("-", "").replace(" ", "").lower())
    return guess or next(iter(difflib.get_close_matches(key, known, n=1, cutoff=0.75)), None)


def unknown_key_message(key: str, known: Sequence[str]) -> str:
    """``unknown key 'fmax' (did you mean 'f_max'?)``: the close match, when there is one."""
    guess = close_key(key, known)
    return f"unknown key {key!r}" + (f" (did you mean {guess!r}?)" if guess else "")


STRUCTURE_FORMAT = "modquad_gym.structure"
"""The ``format`` of a structure export's JSON (:func:`modquad_gym.sim.export.structure_dict`),
named in the refusal of one read as a task."""


def task_format(data: object) -> str:
    """The key of :data:`TASK_KEYS` that marks the task object ``data``, after checking it holds
    no other keys; a ValueError names the unknown or missing key and lists the known ones."""
    if not isinstance(data, dict):
        raise ValueError(f"a task must be a JSON object with a 'wrenches' list, got {data!r:.80}")
    marks = [mark for mark in TASK_KEYS if mark in data]
    if not marks:
        hint = (" (this looks like a suite: read it with load_suite, or on the command line "
                "with `modquad score --suite FILE` or `modquad optima --suite FILE`)"
                if "tasks" in data else "")  # fmt: skip
        if data.get("format") == STRUCTURE_FORMAT:
            raise ValueError("this looks like a structure export (written by `modquad export`), "
                             "not a task: a task file holds 'wrenches'; give the task file the "
                             "structure was designed for")  # fmt: skip
        raise ValueError(f"no 'wrenches' key{hint}; keys present: {sorted(data)}")
    if len(marks) > 1:
        raise ValueError(f"a task holds one of {', '.join(map(repr, marks))}, not several")
    known = TASK_KEYS[marks[0]]
    for key in data:
        if key not in known:
            raise ValueError(
                f"{unknown_key_message(key, known)}; a task's keys are {', '.join(known)} "
                '(put free-form extras in "meta")'
            )
    return marks[0]


def task_files(specs: Sequence[PathLike], what: str = "--task") -> list[Path]:
    """Task file paths from ``specs``: a file (kept as given, checked when loaded), a folder
    (its task files, by name) or a glob pattern (its matches, by name); in order, each path once.
    A folder without task files or a pattern that matches nothing is a ValueError."""
    import glob

    out: dict[Path, None] = {}
    for spec in specs:
        text = str(spec)
        if not text.strip():
            raise ValueError(f"{what}: an empty path (give a file, a folder or a quoted glob)")
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


def jsonable(obj: Any, what: str = "meta") -> Any:
    """``obj`` as plain JSON data (NumPy scalars and arrays, tuples: numbers and lists; keys:
    strings), or a ValueError naming ``what`` and where in it a value lies that JSON cannot
    hold: a NaN or an infinity (``json`` would write the invalid ``NaN``), or an object."""
    return _jsonable(obj, what, ())


def check_meta(meta: object, what: str = "'meta'") -> dict:
    """``meta`` as read from a task file: a JSON object that JSON can hold, so that the task can
    be written back (Python's ``json`` reads ``NaN`` and ``Infinity``, which no writer
    writes); a ValueError names ``what``, or the entry (``meta['a'] is nan: ...``)."""
    if not isinstance(meta, dict):
        raise ValueError(f"{what} must be an object, got {meta!r:.60}")
    try:
        jsonable(meta)
    except RecursionError:
        raise ValueError(f"{what} is nested too deeply") from None
    return meta


def _jsonable(obj: Any, what: str, at: tuple) -> Any:
    if isinstance(obj, dict):
        return {str(k): _jsonable(v, what, (*at, k)) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_jsonable(v, what, (*at, i)) for i, v in enumerate(obj)]
    if isinstance(obj, np.ndarray):
        return _jsonable(obj.tolist(), what, at)
    if isinstance(obj, np.generic):
        obj = obj.item()
    if obj is None or isinstance(obj, (bool, int, str)):
        return obj
    where = what + "".join(f"[{k!r}]" for k in at)
    if isinstance(obj, float):
        if math.isfinite(obj):
            return obj
        raise ValueError(f"{where} is {obj}: JSON has no NaN or infinity (write it as a string)")
    raise ValueError(
        f"{where} is of type {type(obj).__name__}, which JSON cannot hold (numbers, strings, "
        "booleans, None, lists and dicts)"
    )


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


def read_bytes(path: Path, limit: int = MAX_FILE_BYTES) -> bytes:
    """The bytes of a regular file of at most ``limit`` bytes; anything else (a folder, a
    device such as /dev/zero, a pipe, a larger file) is a TaskFileError before it is read
    (:func:`~modquad_gym.core.validation.read_regular_file`)."""
    return read_regular_file(path, limit, TaskFileError)


def read_text(path: Path) -> str:
    """The file's text (UTF-8, with or without a byte-order mark), refusing huge files."""
    return decode_text(read_bytes(path), path)


def decode_text(data: bytes, path: Path) -> str:
    """``data`` as UTF-8 text (a byte-order mark dropped), or a TaskFileError naming ``path``."""
    try:
        return data.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        raise TaskFileError(f"{path}: not UTF-8 text ({exc.reason} at byte {exc.start})") from None


def _json_int(text: str) -> int | float:
    """JSON integers as ints, except absurdly long ones, which become (infinite) floats and
    are then refused by the checks with the row they are in."""
    return int(text) if len(text) <= 300 else float("inf")


class _DuplicateKeyError(Exception):
    pass


def _unique_keys(pairs: list[tuple[str, Any]]) -> dict[str, Any]:
    """A JSON object that holds no key twice (``json`` would keep the last silently)."""
    out: dict[str, Any] = {}
    for key, value in pairs:
        if key in out:
            raise _DuplicateKeyError(key)
        out[key] = value
    return out


def parse_json(text: str, where: str) -> Any:
    """JSON ``text`` (no key twice in an object); a ValueError names ``where``, the line and
    the column."""
    try:
        return json.loads(text, parse_int=_json_int, object_pairs_hook=_unique_keys)
    except _DuplicateKeyError as exc:
        raise TaskFileError(f"{where}: the key {exc.args[0]!r} is given twice") from None
    except json.JSONDecodeError as exc:
        raise TaskFileError(
            f"{where}: not valid JSON: {exc.msg} at line {exc.lineno}, column {exc.colno} "
            f"(char {exc.pos})"
        ) from None
    except RecursionError:
        raise TaskFileError(f"{where}: JSON nested too deeply") from None


def read_json(path: Path) -> Any:
    """A JSON file's data; a bad file (not JSON, a key given twice, more arrays and objects
    than :data:`MAX_JSON_CONTAINERS` or more values than :data:`MAX_JSON_VALUES`) is a
    TaskFileError naming the file, and the line where it applies."""
    text = read_text(path)
    if not text.strip():
        raise TaskFileError(f"{path}: the file is empty")
    containers = text.count("[") + text.count("{")
    if containers > MAX_JSON_CONTAINERS:
        raise TaskFileError(
            f"{path}: {containers:,} JSON arrays and objects, more than the "
            f"{MAX_JSON_CONTAINERS:,} read (a task holds at most {MAX_WRENCHES:,} wrenches); "
            "refused before parsing"
        )
    values = text.count(",")
    if values > MAX_JSON_VALUES:
        raise TaskFileError(
            f"{path}: {values:,} commas between JSON values, more than the {MAX_JSON_VALUES:,} "
            f"read (a task holds at most {MAX_WRENCHES:,} wrenches of 6 numbers); refused "
            "before parsing"
        )
    return parse_json(text, str(path))


def npy_rows(path: Path) -> int:
    """The wrench count of the ``.npy`` task file ``path``, read from its header (format, dtype
    and shape checked, the data not read); a bad file is a TaskFileError naming it."""
    return _npy_header(path)[0]


def _npy_header(path: Path) -> tuple[int, int, int]:
    """(rows, bytes of data in the file, bytes its header's array takes) of an .npy task file,
    its format, dtype and shape checked."""
    from numpy.lib import format as npy

    with open(path, "rb") as fh:
        magic = fh.read(6)
        fh.seek(0)
        if magic[:2] == b"PK":
            raise TaskFileError(f"{path}: an .npz archive, not an .npy array of shape (t, 6)")
        if magic != b"\x93NUMPY":
            raise TaskFileError(f"{path}: not an .npy file (it does not start as NumPy's do)")
        try:
            major, _ = npy.read_magic(fh)
            read_header = npy.read_array_header_1_0 if major == 1 else npy.read_array_header_2_0
            shape, _, dtype = read_header(fh, max_header_size=10_000)
        except (ValueError, OSError, EOFError) as exc:
            raise TaskFileError(f"{path}: not a readable .npy array: {exc}") from None
        data_bytes = os.fstat(fh.fileno()).st_size - fh.tell()
    if dtype.kind not in "iuf" or dtype.hasobject:
        raise TaskFileError(f"{path}: expected a numeric array of shape (t, 6), got {dtype}")
    if len(shape) != 2 or shape[1] != 6 or shape[0] == 0:
        raise TaskFileError(f"{path}: expected an array of shape (t, 6) with t >= 1, got {shape}")
    return shape[0], data_bytes, shape[0] * 6 * dtype.itemsize


def read_npy(path: Path) -> np.ndarray:
    """The (t, 6) array of an ``.npy`` task file; its header (format, dtype, shape, and that the
    file holds that array and nothing after it: ``np.load`` ignores what follows) is checked
    before the data is read, and a bad file is a TaskFileError naming it."""
    rows, data_bytes, expected = _npy_header(path)
    if rows > MAX_WRENCHES:
        raise TaskFileError(
            f"{path}: {rows:,} wrenches, more than the {MAX_WRENCHES:,} a task holds"
        )
    if data_bytes != expected:
        raise TaskFileError(
            f"{path}: {data_bytes:,} bytes of data where its header describes a {rows} x 6 "
            f"array of {expected:,} ({'bytes after it' if data_bytes > expected else 'cut short'}"
            "): not one .npy array"
        )
    try:
        return np.load(path, allow_pickle=False)
    except (ValueError, OSError, EOFError) as exc:
        raise TaskFileError(f"{path}: not a readable .npy array: {exc}") from None


def json_keys(path: Path) -> set[str]:
    """The top-level keys of a JSON file (none when it is not an object)."""
    data = read_json(path)
    return set(data) if isinstance(data, dict) else set()
