"""Benchmarks: scripts that measure speed and write reports to ``results/``.

Every report states the machine it ran on and compares methods as ratios within one run.
"""

from __future__ import annotations

import argparse
import os
import platform
from pathlib import Path

from ..options import int_option, seed_option
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
