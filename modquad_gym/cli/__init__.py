"""The ``modquad`` command line: solve tasks, generate task files, draw structures, validate in
MuJoCo, and score agents on the benchmark tiers. ``modquad COMMAND --help`` explains each
command.

Exit codes: 0 on success (an infeasible task is a result, not an error); 2 for every expected
failure (a task file that cannot be read, a bad option value, an output path that exists or
cannot be written, a missing optional dependency, a closed output pipe), reported as one line
``modquad: error: ...`` naming the file or option; 130 when interrupted (Ctrl-C), 143 on
SIGTERM (one line, ``modquad: interrupted`` or ``modquad: terminated``); 1 when ``modquad
check`` finds a certificate invalid.

One module per command, each with ``add_COMMAND(sub)`` (its parser) beside its handler
``cmd_COMMAND(args)``: :mod:`.solve`, :mod:`.optima`, :mod:`.task`, :mod:`.show`,
:mod:`.export`, :mod:`.validate`, :mod:`.score`, :mod:`.check` (and :mod:`.bench`, the deprecated
name of score); the
options they share are in :mod:`.common` (``--quiet`` of the commands that search in
:mod:`.quiet`).
A new command is a module with those two functions, its name added to :data:`COMMANDS`.
"""

from __future__ import annotations

import argparse
import importlib
import sys

from modquad_gym.core.interrupts import (
    interrupted,
    run_command,
    sigterm_as_interrupt,
    stopped,
)
from modquad_gym.core.options import OneLineParser

COMMANDS = ("solve", "optima", "task", "show", "export", "validate", "score", "check", "bench")
"""The commands, in the order ``modquad --help`` lists them: each the module of this package that
defines its ``add_NAME(sub)``, imported when its parser is built (not at this module's import:
see :func:`main`)."""


def _version() -> str:
    from modquad_gym import __version__  # the one source (pyproject reads it too)

    return __version__


def build_parser(argv: list[str] | None = None) -> argparse.ArgumentParser:
    """The parser of ``modquad``; given ``argv`` whose command is known, only that command's
    parser is built in full (the others are named, for the usage line): a command pays for
    its own options only."""
    parser = OneLineParser(
        prog="modquad",
        description="Find the smallest modular multirotor (H-ModQuad) whose feasible wrenches "
        'contain a task\'s wrenches. Task files: JSON {"wrenches": [[fx,fy,fz,tx,ty,tz], ...], '
        '"f_max": 1.0, "name": "..."}, CSV with 6 columns, or .npy of shape (t, 6).',
    )
    parser.add_argument("--version", action="version", version=f"%(prog)s {_version()}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    wanted = next((a for a in argv or () if not a.startswith("-")), None)
    for name in COMMANDS:
        if wanted in COMMANDS and wanted != name:
            sub.add_parser(name)
        else:
            getattr(importlib.import_module(f"{__name__}.{name}"), f"add_{name}")(sub)
    return parser


def main(argv: list[str] | None = None) -> int:
    """``modquad ARGV``, its exit status (the module's docstring lists them). This module imports
    little: the command's modules (numpy, the search) load in here, where a Ctrl-C or SIGTERM
    ends as one during the command does (one line, 130 or 143), not as a traceback."""
    try:
        with sigterm_as_interrupt():
            return _main(argv)
    except (KeyboardInterrupt, ImportError) as exc:  # loading, parsing (the command: run_command)
        if not interrupted(exc):
            raise
        return stopped("modquad", exc)


def _main(argv: list[str] | None) -> int:
    from modquad_gym.core.caches import setting_error

    typed = sys.argv[1:] if argv is None else list(argv)
    setting = setting_error()  # changed since the import (which stopped on it otherwise)
    if setting is not None:
        print(f"modquad: error: {setting}", file=sys.stderr)
        return 2
    parser = build_parser(typed)
    args = parser.parse_args(argv)  # argparse's own exit: --help (0), a refused option (2)
    if not getattr(args, "func", None):
        parser.print_help()
        return 0
    return run_command(lambda _: _run(parser, args, typed), "modquad")


def _run(parser: argparse.ArgumentParser, args: argparse.Namespace, typed: list[str]) -> int:
    """The command ``args`` names, after the refusals that need its typed options."""
    from modquad_gym.cli import given
    from modquad_gym.cli.score import ARGV

    setattr(args, ARGV, typed)
    setattr(args, given.TYPED, given.typed_options(parser, typed))
    given.refuse_ignored_method_options(args)  # before any file is read
    given.refuse_budget(args)
    given.refuse_ignored_csv_header(args)
    return args.func(args)
