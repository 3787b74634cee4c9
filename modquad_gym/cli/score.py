"""``modquad score``: score agents (the searches, the learned methods, an outside agent) on a
benchmark tier's held-out suites against their certified optima (:mod:`modquad_gym.scoring`)."""

from __future__ import annotations

import argparse

from modquad_gym.core.options import DefaultsHelpFormatter
from modquad_gym.scoring.options import COMMAND, DESCRIPTION, add_options

ARGV = "command_argv"
"""The attribute of the parsed arguments that holds the command line after ``modquad``
(:func:`modquad_gym.cli.main` sets it): the report records the command that reproduces it."""


def add_score(sub) -> None:
    p = sub.add_parser(
        "score",
        help="score agents on a benchmark tier (writes benchmark.md, .csv and plots)",
        description=DESCRIPTION + " `modquad score --solver my_pkg.agent:Agent` scores your own "
        "agent (docs: benchmarks.md).",
        formatter_class=DefaultsHelpFormatter,
    )
    p.set_defaults(func=cmd_score)
    add_options(p)


def cmd_score(args: argparse.Namespace) -> int:
    from modquad_gym.scoring.agents import score

    typed = getattr(args, ARGV, None)
    rest = typed[1:] if typed else []  # what follows `score`
    return score(args, " ".join([COMMAND, *rest]))
