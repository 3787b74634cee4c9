"""The export formats, their file suffixes, and the one rule that picks a format from a file's
suffix and a requested format: ``modquad export`` (``--out``, ``--format``) and
:func:`~modquad_gym.sim.export.save_structure` (``path``, ``fmt``) both call
:func:`export_format`, so the two doors accept and refuse the same pairs. Reading an export
back (:func:`read_export`) is checked here too."""

from __future__ import annotations

import os
from pathlib import Path

from modquad_gym.core.validation import check_path, read_regular_file

MAX_EXPORT_BYTES = 16 << 20
"""Most bytes of an export read back (a 16 x 8 block of 128 modules: 561,337 bytes as URDF,
196,888 as MJCF, by ``export_text``)."""

FORMATS = ("mjcf", "urdf", "json")
"""The export formats."""

SUFFIXES = {"mjcf": ".xml", "urdf": ".urdf", "json": ".json"}
"""The usual file suffix of each format."""

XML_FORMATS = ("mjcf", "urdf")
"""The formats written as XML: a file ending in .xml takes either."""


def export_format(
    path: str | os.PathLike, fmt: object = None, names: tuple[str, str] = ("path", "fmt")
) -> str:
    """``fmt``, else the format ``path``'s suffix names; a ValueError naming both when they
    disagree (JSON in b.xml), when neither names a format, or when ``fmt`` is not one of
    :data:`FORMATS`. ``names`` are what the caller calls the two (``("--out", "--format")`` on
    the command line)."""
    path_name, fmt_name = names
    option = path_name.startswith("--")

    def said(value: str) -> str:  # "--format mjcf" on the command line, "fmt='mjcf'" in Python
        return f"{fmt_name} {value}" if option else f"{fmt_name}={value!r}"

    suffix = Path(path).suffix.lower()
    named = {s: f for f, s in SUFFIXES.items()}.get(suffix)
    if fmt is None:
        if named is None:
            raise ValueError(
                f"{path_name} {path}: its suffix names no format; end it in "
                f"{', '.join(SUFFIXES.values())} or give {fmt_name} ({', '.join(FORMATS)})"
            )
        return named
    if not isinstance(fmt, str) or fmt not in FORMATS:
        raise ValueError(f"{fmt_name} must be one of {', '.join(FORMATS)}, got {fmt!r}")
    takes = XML_FORMATS if suffix == ".xml" else (named,)  # every format the suffix takes
    if named is not None and fmt not in takes:
        raise ValueError(
            f"{said(fmt)}: {path_name} {path} ends in {suffix}, the suffix of "
            f"{' and '.join(takes)}; end {path_name} in {SUFFIXES[fmt]} or give "
            f"{' or '.join(said(f) for f in takes)}"
        )
    return fmt


def is_path(source) -> bool:
    """A path (not the text of a file): a PathLike, or a one-line string not starting with <."""
    if isinstance(source, Path) or hasattr(source, "__fspath__"):
        return True
    return isinstance(source, str) and "\n" not in source and not source.lstrip().startswith("<")


def read_export(source: object, fmt: str) -> tuple[str, str]:
    """(text, where) of an export read back: ``source`` is a path (a regular file of at most
    :data:`MAX_EXPORT_BYTES` of UTF-8, ``where`` its name) or the text itself (``where``: "the
    MJCF text" for ``fmt`` "MJCF"). A ValueError names the file for anything else: an empty
    path, a folder, a pipe, a device, a file too large, not UTF-8, not there."""
    if not is_path(source):
        if not isinstance(source, str):
            raise ValueError(f"source must be a path or the {fmt} text, got {source!r:.60}")
        return source, f"the {fmt} text"
    check_path(source, "source")
    where = os.fspath(source)
    try:
        data = read_regular_file(source, MAX_EXPORT_BYTES)
    except OSError as exc:
        raise ValueError(f"{where}: cannot read the {fmt} file ({exc.strerror})") from None
    try:
        return data.decode("utf-8-sig"), where
    except UnicodeDecodeError as exc:
        raise ValueError(f"{where}: not UTF-8 text ({exc.reason} at byte {exc.start})") from None


def parse_export(parse, text: str, where: str):
    """``parse(text)`` (MuJoCo's reader of ``where``), its ValueError as one line naming
    ``where`` (MuJoCo's XML errors name only a line number)."""
    try:
        return parse(text)
    except ValueError as exc:
        raise ValueError(f"{where}: {' '.join(str(exc).split())}") from None
