"""``modquad bench agents``: the former name of ``modquad score`` (deprecated; kept for one
release). The project's other benchmarks left the package: they are the repository's
``benchmarks/`` scripts (``python -m benchmarks.NAME``)."""

from __future__ import annotations

import argparse
import sys

from modquad_gym.cli.common import add_command

REMOVED = (
    "oracle", "search", "scaling", "anytime", "scale", "level-bounds", "distributed",
    "heterogeneous", "env", "paper", "coldstart", "dynamics",
)  # fmt: skip
"""The other ``modquad bench`` names, removed: each is ``python -m benchmarks.NAME`` now."""


def add_bench(sub) -> None:
    p = add_command(
        sub,
        "bench",
        cmd_bench,
        help="deprecated: use modquad score",
        description="Deprecated: use `modquad score` (`modquad bench agents OPTIONS` runs "
        "`modquad score OPTIONS`). The other benchmarks are the repository's scripts: "
        "`python -m benchmarks.NAME` (docs: results.md).",
    )
    p.add_argument("what", metavar="agents", help="agents: the former name of modquad score")
    rest = p.add_argument(
        "rest",
        nargs=argparse.REMAINDER,
        metavar="OPTIONS",
        help="options of modquad score (see `modquad score --help`; without any, its defaults)",
    )
    rest.required = False  # argparse marks a REMAINDER required, yet takes none


def cmd_bench(args: argparse.Namespace) -> int:
    from modquad_gym.scoring.agents import main

    if args.what != "agents":
        name = args.what.replace("-", "_")
        where = (
            f"it moved out of the package: run `python -m benchmarks.{name}` in the repository"
            if args.what in REMOVED
            else "use `modquad score`"
        )
        raise ValueError(f"modquad bench {args.what}: no such command; {where}")
    print("modquad: `modquad bench agents` is deprecated: use `modquad score`", file=sys.stderr)
    return main(args.rest, prog="modquad bench agents")
