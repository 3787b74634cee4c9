"""``--quiet``, one definition for the commands that run a search (``solve``, ``show``,
``export``, ``validate``): no progress on stderr, the same words in each command's help."""

from __future__ import annotations

import argparse

QUIET_HELP = (
    "no progress on stderr (the exhaustive search shows a bar per level, the default search a "
    "line with the structure found and the proved bound{also})"
)
"""The help of ``--quiet``; ``{also}`` names a command's own progress beside the search's."""


def add_quiet(p: argparse.ArgumentParser, also: str = "") -> None:
    """``--quiet`` on ``p``; ``also`` (e.g. ``", validate's hover a bar ..."``) names what else
    the command shows on stderr that it silences."""
    p.add_argument("--quiet", action="store_true", help=QUIET_HELP.format(also=also))


def shows_progress(args: argparse.Namespace) -> bool:
    """Whether a search shows its progress: not with ``--quiet``, nor with ``--json`` (whose
    output is read by a program)."""
    return not (getattr(args, "json", False) or getattr(args, "quiet", False))
