"""Re-draw the committed figures from the committed reports, without re-running a benchmark.

Each figure is drawn by the plotting function of the command that made it, from that command's
own data in ``results/``: the agent benchmarks' ``benchmark_bars.png`` from ``benchmark.csv``
and ``learning_curve.png`` from the training run's ``evaluations.npz`` named in
``benchmark.md``; ``seeds.png`` from ``seeds.csv``; the scale benchmarks' ``gap_vs_size.png``
from ``rows.csv``. Writes ``results/figures.md`` listing every figure and its source. Every
source is read and checked before any figure is drawn; an existing figure or figures.md is
replaced only with ``--force``.

    python -m benchmarks.figures --force
"""

from __future__ import annotations

import argparse
import dataclasses
import re
from collections.abc import Callable
from functools import partial
from pathlib import Path

from benchmarks.common import HelpFormatter, read_input_text, read_rows_csv, run_main
from modquad_gym.core.options import path_option
from modquad_gym.core.outputs import write_text

Figure = tuple[Path, Path, Callable[[], object]]
"""A figure to draw: (its file, the data it is drawn from, what draws it)."""


def training_run(report: str) -> Path | None:
    """The training run a benchmark report's learning curve came from: its ``--train-dir``,
    else the folder of the model it names (as ``modquad score`` chooses)."""
    found = re.search(r"--train-dir (\S+?)[` ]", report)
    if found:
        return Path(found.group(1))
    found = re.search(r"model: `([^`]+\.zip)`", report)
    return Path(found.group(1)).parent if found else None


def agent_figures(results: Path) -> list[Figure]:
    """Every agent benchmark's bars and learning curve (the curve where its training run is at
    hand), their data read and checked now."""
    from benchmarks.leaderboard_entries import BENCHMARK_COLUMNS, record_row
    from modquad_gym.scoring.agents_figures import plot_bars, plot_learning_curve
    from modquad_gym.scoring.scores import summarise
    from modquad_gym.scoring.tiers import get_tier

    done: list[Figure] = []
    for csv_path in sorted(results.rglob("benchmark.csv")):
        folder = csv_path.parent
        bars, curve = folder / "benchmark_bars.png", folder / "learning_curve.png"
        if not (bars.is_file() or curve.is_file()):
            continue
        report = read_input_text(folder / "benchmark.md")  # names its tier, run
        if bars.is_file():
            tier = re.search(r"tier `([^`]+)`", report)
            n_max = get_tier(tier.group(1)).n_max if tier else 7
            what = "modquad score's benchmark.csv"
            rows = read_rows_csv(csv_path, "", BENCHMARK_COLUMNS, record_row, what)
            table = summarise(rows, list(dict.fromkeys(r.method for r in rows)), n_max)
            done.append((bars, csv_path, partial(plot_bars, table, bars)))
        train_dir = training_run(report)
        evals = None if train_dir is None else train_dir / "evaluations.npz"
        if curve.is_file() and evals is not None and evals.is_file():  # the run is at hand
            done.append((curve, evals, partial(plot_learning_curve, evals, curve)))
    return done


def seed_figures(results: Path) -> list[Figure]:
    """Every seeds report's interval plot, its ``seeds.csv`` read and checked now."""
    from modquad_gym.scoring.seed_scores import SeedScore
    from modquad_gym.scoring.seeds_report import plot

    columns = [f.name for f in dataclasses.fields(SeedScore)]
    what = "a seeds.csv of python -m modquad_gym.scoring.seeds"
    done: list[Figure] = []
    for csv_path in sorted(results.glob("seeds_*/seeds.csv")):
        png = csv_path.with_name("seeds.png")
        scores = read_rows_csv(csv_path, "", columns, SeedScore.from_record, what,
                               older=(columns[:-1],))  # fmt: skip
        done.append((png, csv_path, partial(plot, scores, png)))
    return done


def scale_figures(results: Path) -> list[Figure]:
    """Every scale benchmark's gap plot, its ``rows.csv`` read and checked now."""
    from benchmarks.scale import read_rows
    from benchmarks.scale_report import plot

    done: list[Figure] = []
    for csv_path in sorted(results.glob("scale*/rows.csv")):
        png = csv_path.with_name("gap_vs_size.png")
        if png.is_file():
            done.append((png, csv_path, partial(plot, read_rows(csv_path, ""), png)))
    return done


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        prog="python -m benchmarks.figures",
        description="Re-draw the committed figures of results/ from their reports' data (no "
        "benchmark is re-run) and list them in results/figures.md.",
        formatter_class=HelpFormatter,
    )
    parser.add_argument(
        "--results", type=path_option, default=Path("results"), help="the results folder"
    )
    parser.add_argument("--force", action="store_true", help="replace the existing figures")
    args = parser.parse_args(argv)
    if not args.results.is_dir():
        parser.error(f"--results: no folder {args.results}")
    figures = agent_figures(args.results) + seed_figures(args.results)
    figures += scale_figures(args.results)
    if not figures:
        parser.error(
            f"--results {args.results}: no figure to draw (no benchmark.csv with its "
            "figures, seeds_*/seeds.csv or scale*/rows.csv with its gap_vs_size.png)"
        )
    listing = args.results / "figures.md"
    there = [png for png, _, _ in figures if png.exists()] + [listing] * listing.exists()
    if there and not args.force:
        more = f" (and {len(there) - 1} more)" if len(there) > 1 else ""
        parser.error(f"{there[0]}{more} would be replaced: give --force")
    for _, _, draw in figures:
        draw()
    command = "python -m benchmarks.figures" + (
        f" --results {args.results}" if args.results != Path("results") else ""
    )
    lines = [
        "# Figures re-drawn from their reports",
        "",
        f"Made by `{command} --force`: each figure drawn by its benchmark's plotting function "
        "from the data below (no benchmark re-run).",
        "",
        "| figure | drawn from |",
        "|---|---|",
        *(f"| `{png.as_posix()}` | `{src.as_posix()}` |" for png, src, _ in figures),
        "",
    ]
    write_text(listing, "\n".join(lines))
    for png, src, _ in figures:
        print(f"wrote {png} (from {src})")
    return 0


if __name__ == "__main__":
    raise SystemExit(run_main(main, "figures"))
