"""Benchmarks: scripts that measure speed and write reports to ``results/``.

Every report states the machine it ran on and compares methods as ratios within one run.
"""

from __future__ import annotations

import argparse
import contextlib
import os
import platform
from pathlib import Path

import numpy as np

from modquad_gym.core.options import int_option, seed_option
from modquad_gym.core.outputs import OutputError, check_output_dir, write_csv, write_text
from modquad_gym.geometry.structure import Structure

__all__ = [
    "add_force",
    "bench_args",
    "int_option",
    "machine_description",
    "markdown_table",
    "parse_bench_args",
    "random_structure",
    "run_as",
    "seed_option",
    "write_csv",
    "write_text",
]


def bench_args(
    argv: list[str] | None,
    prog: str,
    description: str,
    options: dict[str, dict],
    *,
    seed_help: str | None = "task seed (default 0)",
    out: str = "results",
    out_help: str = "report folder",
    force: bool = False,
    outputs: tuple[str, ...] = (),
    **parser_kwargs,
) -> argparse.Namespace:
    """The parsed options of one benchmark: ``options`` maps each flag to its
    ``add_argument`` keywords; every benchmark also takes ``--seed`` (unless ``seed_help`` is
    None), ``--out`` (default ``out``) and, with ``force`` or ``outputs`` (the files it writes
    into ``--out``, refused when they exist), ``--force``."""
    parser = argparse.ArgumentParser(prog=prog, description=description, **parser_kwargs)
    for flag, kwargs in options.items():
        parser.add_argument(flag, **kwargs)
    if seed_help is not None:
        parser.add_argument("--seed", type=seed_option, default=0, help=seed_help)
    parser.add_argument("--out", type=Path, default=Path(out), help=out_help)
    if force or outputs:
        add_force(parser)
    return parse_bench_args(parser, argv, outputs)


def add_force(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--force", action="store_true", help="replace existing reports (default: refuse)"
    )


_COMMAND: list[str] = []
"""The command the user typed to run a benchmark (``modquad bench NAME``), while it runs."""


@contextlib.contextmanager
def run_as(command: str):
    """Within this block a benchmark's usage and errors name ``command`` (``modquad bench X``
    runs it) instead of the ``python -m modquad_gym.bench.X`` its parser is written for."""
    _COMMAND.append(command)
    try:
        yield
    finally:
        _COMMAND.pop()


def parse_bench_args(
    parser: argparse.ArgumentParser, argv: list[str] | None, outputs: tuple[str, ...] = ()
):
    """Parse ``argv`` (usage and errors naming the command typed, :func:`run_as`); when the
    benchmark has ``--out``, check that it is (or can become) a writable folder holding none of
    ``outputs`` (unless ``--force``) before any work starts (an argparse error otherwise)."""
    if _COMMAND:
        parser.prog = _COMMAND[-1]
    args = parser.parse_args(argv)
    out = getattr(args, "out", None)
    if out is not None:
        try:
            check_output_dir(out, outputs, force=getattr(args, "force", False))
        except OutputError as exc:
            parser.error(str(exc))
    return args


def machine_description() -> str:
    """One line naming the CPU, its core count and the absence of a GPU: the machine line of
    every benchmark report (the agent benchmark's too)."""
    model = platform.processor() or "unknown CPU"
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                model = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    return f"{model}, {os.cpu_count()} cores, no GPU, Python {platform.python_version()}"


def random_structure(n: int, rng: np.random.Generator) -> Structure:
    """A random connected n-module structure (:func:`modquad_gym.tasks.random_cells`: grown one
    module at a time at a uniformly chosen free cell)."""
    from modquad_gym.tasks import random_cells

    return Structure(random_cells(rng, n))


def markdown_table(rows: list[dict], floatfmt: str = ".3g") -> str:
    """A GitHub markdown table of dict rows."""
    keys = list(rows[0])

    def fmt(v):
        return format(v, floatfmt) if isinstance(v, float) else str(v)

    lines = ["| " + " | ".join(keys) + " |", "|" + "---|" * len(keys)]
    lines += ["| " + " | ".join(fmt(r[k]) for k in keys) + " |" for r in rows]
    return "\n".join(lines)
