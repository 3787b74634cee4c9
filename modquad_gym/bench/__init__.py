"""Benchmarks: scripts that measure speed and write reports to ``results/``.

Every report states the machine it ran on and compares methods as ratios within one run.
"""

from __future__ import annotations

import argparse
import os
import platform
from pathlib import Path

from ..outputs import OutputError, check_output_dir, write_csv, write_text

__all__ = [
    "int_option",
    "machine_description",
    "markdown_table",
    "parse_bench_args",
    "seed_option",
    "write_csv",
    "write_text",
]

MAX_COUNT = 1_000_000
"""Largest count (tasks, seeds, structures, steps, ...) a benchmark option accepts."""

MAX_SEED = 2**63 - 1


def int_option(low: int, high: int = MAX_COUNT):
    """An argparse ``type`` for an integer option within [low, high], so that a bad count (0, -1,
    nan, 1e400, '') is an argparse error (exit 2) before any work starts."""

    def parse(text: str) -> int:
        try:
            value = int(text.strip())
        except ValueError:
            raise argparse.ArgumentTypeError(f"expected an integer, got {text!r}") from None
        if not low <= value <= high:
            raise argparse.ArgumentTypeError(f"must be in {low}..{high}, got {value}")
        return value

    parse.__name__ = "integer"  # argparse names the type in its messages
    return parse


def seed_option(text: str) -> int:
    """An argparse ``type`` for a random seed: an integer in 0..2**63-1 (what NumPy accepts)."""
    return int_option(0, MAX_SEED)(text)


def parse_bench_args(parser: argparse.ArgumentParser, argv: list[str] | None):
    """Parse ``argv``; when the benchmark has ``--out``, check that it is (or can become) a
    writable folder before any work starts (an argparse error otherwise)."""
    args = parser.parse_args(argv)
    out = getattr(args, "out", None)
    if out is not None:
        try:
            check_output_dir(out, force=True)
        except OutputError as exc:
            parser.error(str(exc))
    return args


def machine_description() -> str:
    """One line naming the CPU, its core count and the absence of a GPU."""
    model = platform.processor() or "unknown CPU"
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                model = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    return f"{model}, {os.cpu_count()} cores, no GPU, Python {platform.python_version()}"


def markdown_table(rows: list[dict], floatfmt: str = ".3g") -> str:
    """A GitHub markdown table of dict rows."""
    keys = list(rows[0])

    def fmt(v):
        return format(v, floatfmt) if isinstance(v, float) else str(v)

    lines = ["| " + " | ".join(keys) + " |", "|" + "---|" * len(keys)]
    lines += ["| " + " | ".join(fmt(r[k]) for k in keys) + " |" for r in rows]
    return "\n".join(lines)
