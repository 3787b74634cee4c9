"""The records of an optima dataset (:mod:`modquad_gym.scoring.optima`): their keys and the check
of each key's type and range, so that a line that is not one of them is never taken for finished
work."""

from __future__ import annotations

import json
import math
import re
import reprlib

from modquad_gym.search.problem import EXACT_MODULES

KEYS = ("task", "name", "digest", "n_max", "optimum", "structures", "count", "evaluated",
        "oracle_calls", "seconds")  # fmt: skip
"""Keys every record has (``proof`` too when it applies)."""

OPTIONAL = ("path", "proof", "palette", "modules")
"""Keys a record has when they apply: ``path`` (the task file, resolved, relative to the
dataset's folder), ``proof``, and with module types ``palette`` and ``modules``."""


MAX_STRUCTURES = 10_000
"""Most structures a record lists (in canonical order); ``count`` counts them all. A level
where every structure is optimal (level 12 holds 505,861) would otherwise be a line of tens of
megabytes and a gigabyte of memory."""


DIGEST = re.compile(r"[0-9a-f]{16}")
"""A record's ``digest``: 16 lowercase hex digits
(:func:`~modquad_gym.scoring.optima.task_digest`)."""


def check_record(record: object) -> dict:
    """``record`` if it is a record as
    :func:`~modquad_gym.scoring.optima.optimum_record` writes it, else a ValueError
    naming the first key that is missing, unknown or of a wrong type or range: strings
    ``task`` (not empty), ``name`` and ``digest`` (16 hex digits), integers ``n_max`` (1 to
    EXACT_MODULES), ``optimum`` (1 to n_max, or null), ``count`` (0 exactly when optimum is
    null), ``evaluated`` and ``oracle_calls`` (>= 0), ``seconds`` (finite, >= 0),
    ``structures`` (each ``optimum`` distinct [x, y] cells of non-negative integers; ``count``
    of them, or the first MAX_STRUCTURES) and, when present, ``path`` and ``proof`` (non-empty
    strings), ``palette`` and ``modules`` (:func:`_check_types`)."""
    if not isinstance(record, dict):
        raise ValueError(f"a record is a JSON object, got {_shown(record)}")
    for key in record:
        if key not in (*KEYS, *OPTIONAL):
            raise ValueError(f"{_shown(key)}: unknown key (a record's keys: "
                             f"{', '.join((*KEYS, *OPTIONAL))})")  # fmt: skip
    for key in KEYS:
        if key not in record:
            raise ValueError(f"{key}: missing")
    for key in ("task", "name", "digest", "path", "proof"):
        if key not in record:
            continue
        if not isinstance(record[key], str):
            raise ValueError(f"{key} must be a string, got {_shown(record[key])}")
    for key in ("task", "path"):
        if key in record and (not record[key] or "\0" in record[key]):
            what = "a task file or SUITE#i" if key == "task" else "a task file"
            raise ValueError(f"{key} must name {what}, got {_shown(record[key])}")
    if not DIGEST.fullmatch(record["digest"]):
        raise ValueError(f"digest must be 16 hex digits, got {_shown(record['digest'])}")
    if record.get("proof") == "":
        raise ValueError("proof must not be empty (a record without one has no proof key)")
    n_max = _integer(record, "n_max", 1, EXACT_MODULES)
    optimum = None if record["optimum"] is None else _integer(record, "optimum", 1, n_max)
    if optimum is None and record["count"] != 0:
        raise ValueError(f"count must be 0 when optimum is null, got {_shown(record['count'])}")
    count = _integer(record, "count", 0 if optimum is None else 1)
    _integer(record, "evaluated", 0)
    _integer(record, "oracle_calls", 0)
    seconds = record["seconds"]
    if not _is_number(seconds) or not math.isfinite(seconds) or seconds < 0:
        raise ValueError(f"seconds must be a finite number >= 0, got {_shown(seconds)}")
    _check_structures(record["structures"], optimum or 0, count)
    _check_types(record)
    return record


def _check_types(record: dict) -> None:
    """``palette`` (type names) and ``modules`` (each listed structure's type names, one per
    cell, from the palette): both or neither."""
    if ("palette" in record) != ("modules" in record):
        raise ValueError("palette and modules: give both (a palette's record) or neither")
    if "palette" not in record:
        return
    palette, modules = record["palette"], record["modules"]
    if not (
        isinstance(palette, list) and palette and all(isinstance(n, str) and n for n in palette)
    ):
        raise ValueError(f"palette must be a list of type names, got {_shown(palette)}")
    sizes = [len(cells) for cells in record["structures"]]
    if not (isinstance(modules, list) and [len(m) if isinstance(m, list) else -1 for m in modules]
            == sizes and all(n in palette for m in modules for n in m)):  # fmt: skip
        raise ValueError(
            "modules must list each structure's type names (one per cell, from the palette), "
            f"got {_shown(modules)}"
        )


def _check_structures(structures: object, optimum: int, count: int) -> None:
    if not isinstance(structures, list):
        raise ValueError(f"structures must be a list, got {_shown(structures)}")
    listed = len(structures)
    if listed != count and not (listed == MAX_STRUCTURES < count):
        raise ValueError(f"structures lists {listed} structures, count says {count}")
    for i, cells in enumerate(structures, 1):
        if not (
            isinstance(cells, list)
            and len(cells) == optimum
            and all(
                isinstance(c, list) and len(c) == 2 and all(_is_integer(v) and v >= 0 for v in c)
                for c in cells
            )
            and len({tuple(c) for c in cells}) == optimum
        ):
            raise ValueError(
                f"structures: structure {i} must be {optimum} distinct [x, y] cells of "
                f"non-negative integers, got {_shown(cells)}"
            )


def _is_integer(value: object) -> bool:
    return isinstance(value, int) and not isinstance(value, bool)


def _is_number(value: object) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool)


def _integer(record: dict, key: str, low: int, high: int | None = None) -> int:
    value = record[key]
    if not _is_integer(value) or value < low or (high is not None and value > high):
        bounds = f"from {low} to {high}" if high is not None else f">= {low}"
        raise ValueError(f"{key} must be an integer {bounds}, got {_shown(value)}")
    return value


class _JsonRepr(reprlib.Repr):
    """Values of a JSON line as JSON writes them (null, true, "text"), shortened to a line."""

    def repr_NoneType(self, _value, _level) -> str:  # noqa: N802 (reprlib's names)
        return "null"

    def repr_bool(self, value, _level) -> str:
        return "true" if value else "false"

    def repr_float(self, value, _level) -> str:
        return json.dumps(value)  # NaN, Infinity

    def repr_str(self, value, _level) -> str:
        text = json.dumps(value[:40])
        return text if len(value) <= 40 else text[:-1] + '..."'


_shown = _JsonRepr().repr
