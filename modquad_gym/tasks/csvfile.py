"""CSV task files: six comma-separated columns, one wrench per line, with an optional header and
``# key: value`` comments for the task's other fields (the format is described in
:mod:`modquad_gym.tasks`).

Read strictly: a header names the columns (honoured in any order, refused when it names others), a
first row that reads as column numbers is refused as ambiguous, a comment key that is a misspelt
field (``# fmax:``) or a field given twice is refused, numbers are plain decimals (``1_000`` is
not a number). :func:`csv_text` writes what :func:`read_csv` reads back identically: a name that
would not survive a line of its own (a newline, surrounding blanks, ...) is written as a JSON
string, ``meta`` as one line of JSON.
"""

from __future__ import annotations

import csv
import itertools
import json
import math
import re
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np

from modquad_gym.core.options import NUMBER_PATTERN
from modquad_gym.core.validation import check_f_max
from modquad_gym.tasks.files import (
    MAX_WRENCHES,
    TaskFileError,
    check_meta,
    close_key,
    decode_text,
    parse_json,
    read_bytes,
    unknown_key_message,
)
from modquad_gym.tasks.wrenches import COLUMNS, TASK_KINDS, check_kind

CSV_HEADER_MODES = ("auto", "yes", "no")
"""How a CSV's first row is read: ``auto`` (a row of names is a header; a row that reads as the
column numbers 0..5 or 1..6, as spreadsheets and pandas write them, is refused as ambiguous),
``yes`` (the first row is a header: the column names, or column numbers read positionally) or
``no`` (every row is a wrench)."""

CSV_COMMENT_KEYS = ("name", "f_max", "kind", "meta")
"""The fields ``# key: value`` comments set. Other comments are free text, except near misses,
which are refused (never read as free text, so the field would silently keep its default): a
key that is one of these misspelt (``# fmax: 2``, ``# Kind: external``, ``# f max: 2``: a key's
spaces count as misspellings of ``_``), and a comment that
sets one of these keys without the ``:``: with ``=`` (``# f_max = 2``, ``#f_max=2``, ``# fmax =
2``), or followed by a value of its kind (``# f_max 2``, ``# kind external``, ``# meta {...}``).
Free text that merely starts with such a word (``# name of the bench``) stays free text."""

_DECIMAL = re.compile(NUMBER_PATTERN, re.I)  # the --option rule: nan/inf refused naming the row
_COMMENT = re.compile(r"#\s*([A-Za-z][\w -]*?)\s*:(.*)", re.S)
_NEAR_MISS = re.compile(r"#\s*([A-Za-z][\w-]*)(\s*=|\s|$)(.*)", re.S)
_SPACED_SET = re.compile(r"#\s*([A-Za-z][\w -]*?)\s*=(.*)", re.S)
_LINE = re.compile(r"([^\r\n]*)(?:\r\n|\r|\n|\Z)")
_NUMBER_START = rb'[ \t]*"?[ \t]*[-+.0-9]'  # a line that starts as a number (maybe quoted)
_NUMERIC_LINE = re.compile(rb"(?:^|(?<=\r))" + _NUMBER_START, re.M)  # ends: \n, \r\n, \r
_NUMERIC_BOM_LINE = re.compile(rb"\xef\xbb\xbf" + _NUMBER_START)
_NUMERIC_FIRST_ROW = re.compile(  # blank lines, empty rows and comments, then a number; each
    rb"(?:\xef\xbb\xbf)?(?:[ \t,]*(?:#[^\r\n]*)?(?:\r?\n|\r(?!\n)))*" + _NUMBER_START
)  # line end reads one way only (\r\n is never \r then \n): no exponential backtracking
_COLUMN_NUMBERS = ([0.0, 1.0, 2.0, 3.0, 4.0, 5.0], [1.0, 2.0, 3.0, 4.0, 5.0, 6.0])
_CHUNK = 1 << 16


def _to_float(cell: str) -> float | None:
    """The number a CSV cell holds (plain decimal notation only: ``1_0`` is not ten)."""
    return float(cell) if _DECIMAL.fullmatch(cell) else None


def _comment(text: str, fields: dict[str, Any], seen: dict[str, int], where: str, lineno: int):
    """Read one ``#`` line into ``fields`` (module docstring)."""
    match = _COMMENT.fullmatch(text.strip())
    if match is None:
        _near_miss(text.strip(), where, lineno)
        return
    key, value = match.group(1), match.group(2).strip()
    if key not in CSV_COMMENT_KEYS:
        message = unknown_key_message(key, CSV_COMMENT_KEYS)
        if "did you mean" in message:
            raise TaskFileError(f"{where}: line {lineno}: comment with an {message}")
        return  # free text such as "# note: measured on the bench"
    if key in seen:
        raise TaskFileError(
            f"{where}: line {lineno}: a second '# {key}' comment (the first is on line {seen[key]})"
        )
    seen[key] = lineno
    at = f"{where}: line {lineno}"
    try:
        if key == "name":
            fields["name"] = _name_value(value, at)
        elif key == "f_max":
            number = _to_float(value)
            if number is None:
                raise ValueError(f"f_max comment {value!r} is not a number")
            fields["f_max"] = check_f_max(number)
        elif key == "kind":
            fields["kind"] = check_kind(value, "kind comment")
        else:
            meta = parse_json(value, "meta comment")
            if not isinstance(meta, dict):
                raise ValueError(f"the meta comment must be a JSON object, got {value:.60}")
            fields["meta"] = check_meta(meta)
    except ValueError as exc:
        raise TaskFileError(f"{at}: {exc}") from None


def _near_miss(text: str, where: str, lineno: int) -> None:
    """A TaskFileError for a comment that reads as setting a field without the ``:``
    (:data:`CSV_COMMENT_KEYS`): the field would otherwise silently keep its default."""
    match = _SPACED_SET.fullmatch(text) or _NEAR_MISS.fullmatch(text)
    if match is None:
        return
    if match.re is _SPACED_SET:  # "# f max = 2": a key (spaces and all), then "="
        key, separator, rest = match.group(1), "=", match.group(2).strip()
    else:
        key, separator, rest = match.group(1), match.group(2).strip(), match.group(3).strip()
    if separator == "=":
        field = key if key in CSV_COMMENT_KEYS else close_key(key, CSV_COMMENT_KEYS)
    else:  # a key, then a value of its kind: a number, a task kind, a JSON object
        first = rest.split()[0] if rest else ""
        values = {"f_max": _to_float(first) is not None, "kind": first in TASK_KINDS,
                  "meta": rest.startswith("{")}  # fmt: skip
        field = key if values.get(key) else None
    if field is not None:
        raise TaskFileError(
            f"{where}: line {lineno}: comment {text[:60]!r} does not set {field}: write "
            f"'# {field}: VALUE' (the key, then ':')"
        )


def _name_value(value: str, at: str) -> str:
    if not value:
        raise ValueError("'# name:' without a name")
    if not value.startswith('"'):
        return value
    name = parse_json(value, "name comment")
    if not isinstance(name, str):
        raise ValueError(f"the name comment {value!r} is not a JSON string")
    if not name:
        raise ValueError("'# name: \"\"' without a name")
    return name


def _header(cells: list[str], parsed: list, where: str) -> list[int] | None:
    """The column order a header row gives (None: positional), or a TaskFileError."""
    if all(v is not None for v in parsed):
        if parsed in _COLUMN_NUMBERS:
            return None
        raise TaskFileError(
            f"{where}: the header row {','.join(cells)} is a wrench, not column names "
            "(--csv-header yes: the first row names the columns)"
        )
    names = [c.lower() for c in cells]
    if sorted(names) != sorted(COLUMNS):
        unknown = [c for c in cells if c.lower() not in COLUMNS] or ["(a column given twice)"]
        raise TaskFileError(
            f"{where}: the header {','.join(cells)} names {unknown[0]!r}; a header names the six "
            f"columns {', '.join(COLUMNS)} (any order)"
        )
    return [names.index(c) for c in COLUMNS]


def _check_separator(line: str, cells: list[str], where: str) -> None:
    if len(cells) == 1:
        for sep, name in ((";", "semicolons"), ("\t", "tabs")):
            if sep in line:
                raise TaskFileError(
                    f"{where}: columns separated by {name}; a CSV task file separates its "
                    "six columns by commas"
                )


def check_csv_header(header: object, path: Path) -> str:
    """``header`` (one of :data:`CSV_HEADER_MODES`) for reading the task file ``path``, or a
    ValueError naming ``csv_header``: an unknown mode, or a mode other than ``auto`` for a file
    that is not a CSV file (it has no first row to read either way: the option would be
    dropped)."""
    if not isinstance(header, str) or header not in CSV_HEADER_MODES:
        raise ValueError(f"csv_header must be one of {', '.join(CSV_HEADER_MODES)}, got {header!r}")
    if header != "auto" and Path(path).suffix.lower() != ".csv":
        raise ValueError(
            f"csv_header={header!r} says how a CSV file's first row reads; {path} is not a "
            "CSV file (leave csv_header at 'auto')"
        )
    return header


def read_csv(path: Path, header: str = "auto") -> tuple[np.ndarray, dict[str, Any]]:
    """The wrenches of a CSV task file and the fields its comments set (``name``, ``f_max``,
    ``kind``, ``meta``); a bad file is a TaskFileError naming the file, the 1-based row and the
    line. Rows are parsed as a stream, refused past :data:`MAX_WRENCHES`."""
    check_csv_header(header, path)
    data = read_bytes(path)
    if csv_rows_at_most(data, header, MAX_WRENCHES) > MAX_WRENCHES:
        raise TaskFileError(
            f"{path}: more than the {MAX_WRENCHES:,} wrenches a task holds (lines of numbers); "
            "refused before parsing"
        )
    text = decode_text(data, path)
    del data
    fields: dict[str, Any] = {}
    seen: dict[str, int] = {}
    chunks: list[np.ndarray] = []
    rows: list[list[float]] = []
    n_rows = 0
    order: list[int] | None = None
    first = header != "no"
    for lineno, line in enumerate(_lines(text), 1):
        if line.lstrip().startswith("#"):
            _comment(line.lstrip(), fields, seen, str(path), lineno)
            continue
        try:
            cells = [c.strip() for c in next(csv.reader([line]), [])]
        except csv.Error as exc:
            raise TaskFileError(f"{path}: line {lineno}: {exc}") from None
        if not any(cells):
            continue
        where = f"{path}: row {n_rows + 1} (line {lineno})"
        _check_separator(line, cells, f"{path}: line {lineno}")
        parsed = [_to_float(c) for c in cells]
        if first:
            first = False
            if header == "yes" or all(v is None for v in parsed):
                order = _header(cells, parsed, f"{path}: line {lineno}")
                continue
            if parsed in _COLUMN_NUMBERS:
                raise TaskFileError(
                    f"{path}: line {lineno}: the first row {','.join(cells)} looks like column "
                    "numbers (spreadsheets and pandas write them as a header); say how to read "
                    "it with --csv-header yes (a header) or --csv-header no (a wrench)"
                )
        rows.append(_row(cells, parsed, where))
        n_rows += 1
        if n_rows > MAX_WRENCHES:
            raise TaskFileError(f"{path}: more than the {MAX_WRENCHES:,} wrenches a task holds")
        if len(rows) == _CHUNK:
            chunks.append(np.array(rows))
            rows = []
    if not n_rows:
        raise TaskFileError(f"{path}: no wrenches (the file is empty or has only a header)")
    W = np.concatenate([*chunks, np.array(rows).reshape(-1, 6)])
    return (W if order is None else W[:, order]), fields


def csv_rows_at_most(data: bytes, header: str, most: int) -> int:
    """How many wrench rows the CSV file's bytes ``data`` hold at most, counted up to
    ``most + 1`` (enough to refuse a file beyond ``most`` at C speed, before parsing): the
    lines that start as a number (after blanks), less a first row that ``header`` ``yes`` reads
    as column numbers. Every other line is a comment, blank, a header of names or an error."""
    header_row = header == "yes" and _NUMERIC_FIRST_ROW.match(data) is not None
    stop = most + 1 + header_row
    n = bool(_NUMERIC_BOM_LINE.match(data))
    n += sum(1 for _ in itertools.islice(_NUMERIC_LINE.finditer(data), stop - n))
    return n - header_row


def _lines(text: str) -> Iterator[str]:
    """The lines of ``text`` without their ends (``\\n``, ``\\r\\n`` or ``\\r``), one at a time
    (a list of millions of lines would cost far more than the text)."""
    for match in _LINE.finditer(text):
        if match.end() == match.start():  # the empty match at the very end
            return
        yield match.group(1)


def _row(cells: list[str], parsed: list, where: str) -> list[float]:
    if len(cells) != 6:
        raise TaskFileError(
            f"{where}: expected 6 columns (fx, fy, fz, tx, ty, tz), got {len(cells)}"
        )
    for j, (cell, v) in enumerate(zip(cells, parsed, strict=True)):
        if v is None:
            raise TaskFileError(f"{where}: {COLUMNS[j]} = {cell!r} is not a number")
        if not math.isfinite(v):
            raise TaskFileError(f"{where}: {COLUMNS[j]} is {cell!r} (wrenches must be finite)")
    return parsed


def _plain(name: str) -> bool:
    """A name written as it is: one line of printable text, no surrounding blanks."""
    return bool(name) and name == name.strip() and name.isprintable() and name[0] != '"'


def csv_text(wrenches: np.ndarray, name: str, f_max: float, kind: str, meta: dict) -> str:
    """A task as CSV text that :func:`read_csv` reads back identically."""
    lines = [f"# name: {name if _plain(name) else json.dumps(name)}", f"# f_max: {f_max!r}"]
    if kind != "total":
        lines.append(f"# kind: {kind}")
    if meta:
        lines.append(f"# meta: {json.dumps(meta)}")
    lines.append(",".join(COLUMNS))
    lines += [",".join(repr(float(v)) for v in row) for row in wrenches]
    return "\n".join(lines) + "\n"
