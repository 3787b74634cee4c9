"""Heterogeneous modules: does mixing module types save modules, and what does the search cost?

    python -m benchmarks.heterogeneous [--tasks 12] [--seed 0] [--n-max 7] [--out results]

Writes ``results/heterogeneous.md``, ``.csv`` (one row per task and palette) and
``heterogeneous.png`` (examples). Everything in the report comes from this run:

* **Savings.** On the same tasks, the certified minimum (exhaustive search, n_max) with the
  palette {t45, t45m, flat} against each type alone. Four task sets, ``--tasks`` each:
  ``paper`` (the paper's random wrenches, kind ``total``, f_max = 1), ``paper external`` (the
  same generator as wrenches on the environment, kind ``external``, f_max = 2 N: the rotors also
  lift 0.3 kg per module), and ``planted`` / ``planted external`` (wrenches inside a random
  mixed structure of 3-6 modules of the palette, so some mix of at most 6 modules works).
* **Search cost.** For the same tasks, structures evaluated and seconds of the one-type search
  against the 2-type {t45, t45m} and 3-type searches; and the worst case of the issue's goals,
  a task that no structure of up to n_max modules satisfies (every level decided): the (shape,
  assignment) pairs of levels 1..n_max, how many the exact bounds skip, evaluated, seconds.
* **MuJoCo.** Mixed optima of external tasks validated in MuJoCo (bench and hover with their
  real module masses, unknown load).

This module is the entry point (``main``); the measurements are in
:mod:`.heterogeneous_measure`, the figure and the text in :mod:`.heterogeneous_report`.
"""

from __future__ import annotations

import argparse

import numpy as np

from benchmarks.common import (
    bench_parser,
    command_as_run,
    int_option,
    markdown_table,
    parse_bench_args,
    run_main,
    write_report,
)
from benchmarks.heterogeneous_measure import (
    EXTERNAL_F_MAX,
    GOALS,
    PAIR,
    PALETTE,
    compare,
    mujoco_rows,
    planted_mixed,
    refuting_task,
    summary,
    task_sets,
    worst_case,
)
from benchmarks.heterogeneous_report import COST_COLUMNS, SAVINGS_COLUMNS, figure, report
from modquad_gym.geometry.module import palette
from modquad_gym.search import exhaustive_search

__all__ = [
    "COST_COLUMNS",
    "EXTERNAL_F_MAX",
    "GOALS",
    "PAIR",
    "PALETTE",
    "SAVINGS_COLUMNS",
    "compare",
    "figure",
    "main",
    "mujoco_rows",
    "planted_mixed",
    "refuting_task",
    "report",
    "summary",
    "task_sets",
    "worst_case",
]


OUTPUTS = ("heterogeneous.md", "heterogeneous.csv", "heterogeneous.png")


def parser() -> argparse.ArgumentParser:
    """The script's options (also how :mod:`benchmarks.figures` reads its report's Made-by
    line back)."""
    options = {
        "--tasks": dict(type=int_option(1, 1000), default=12,
                        help="tasks per set (default 12); the draws depend on it: task #i of "
                        "a smaller run is another task than #i of a larger one"),
        "--n-max": dict(type=int_option(2, 8), default=7, help="module budget (default 7)"),
        "--mujoco": dict(type=int_option(0, 1000), default=3,
                         help="external optima validated in MuJoCo (default 3)"),
    }  # fmt: skip
    return bench_parser(
        "python -m benchmarks.heterogeneous",
        "Certified minima with a palette of module types against each type alone (total and "
        "external tasks), search cost, worst case, MuJoCo; writes "
        "results/heterogeneous.{md,csv,png}.",
        options,
        force=True,
    )


def main(argv: list[str] | None = None) -> None:
    args = parse_bench_args(parser(), argv, OUTPUTS)
    args.command = command_as_run("heterogeneous", argv)  # what the report says made it
    exhaustive_search(np.array([[0, 0, 1.0, 0, 0, 0]]), n_max=2, modules=palette("t45,flat"))
    sets = task_sets(args.tasks, args.seed)
    rows = compare(sets, args.n_max)
    summ = summary(rows, args.n_max)
    worst = worst_case(args.seed, args.n_max)
    sim = mujoco_rows(rows, sets, args.mujoco) if args.mujoco else []
    captions = figure(rows, sets, args.n_max, args.out / "heterogeneous.png")
    write_report(args.out, "heterogeneous", rows, report(args, rows, summ, worst, sim, captions))
    print(markdown_table(summ))


if __name__ == "__main__":
    raise SystemExit(run_main(main, "heterogeneous"))
