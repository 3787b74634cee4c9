"""The export formats, their file suffixes, and the one rule that picks a format from a file's
suffix and a requested format: ``modquad export`` (``--out``, ``--format``) and
:func:`~modquad_gym.sim.export.save_structure` (``path``, ``fmt``) both call
:func:`export_format`, so the two doors accept and refuse the same pairs."""

from __future__ import annotations

import os
from pathlib import Path

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
