"""Re-draw the committed figures from the committed reports, without re-running a benchmark.

Each figure is drawn by the plotting function of the command that made it, from that command's
own data in ``results/``: the agent benchmarks' ``benchmark_bars.png`` and ``structures.png``
(each answer drawn from its cells and, on a tier of several module types, their types) from
``benchmark.csv`` and ``learning_curve.png`` from the training run's ``evaluations.npz`` named in
``benchmark.md``; ``seeds.png`` from ``seeds.csv``; the scale benchmarks' ``gap_vs_size.png``
from ``rows.csv``; ``heterogeneous.png`` from ``heterogeneous.csv`` (its tasks drawn again from
the options of its report's Made-by line, read by that script's own parser; the one-type optima
beside the mixed ones searched again: a few exhaustive searches of at most ``--n-max`` modules).
Writes ``results/figures.md`` listing every figure and its source. Every source is read and
checked before any figure is drawn; an existing figure or figures.md is replaced only with
``--force``.

    python -m benchmarks.figures --force
"""

from __future__ import annotations

import argparse
import dataclasses
import re
import shlex
from collections.abc import Callable
from functools import partial
from pathlib import Path

from benchmarks.common import HelpFormatter, read_input_text, read_rows_csv, run_main
from modquad_gym.core.options import OneLineParser, path_option
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
    """Every agent benchmark's bars, structures and learning curve (the curve where its
    training run is at hand), their data read and checked now."""
    from modquad_gym.geometry.module import palette
    from modquad_gym.scoring.agents_figures import plot_bars, plot_learning_curve, plot_structures
    from modquad_gym.scoring.scores import summarise
    from modquad_gym.scoring.tiers import get_tier

    done: list[Figure] = []
    for csv_path in sorted(results.rglob("benchmark.csv")):
        folder = csv_path.parent
        bars, curve = folder / "benchmark_bars.png", folder / "learning_curve.png"
        structures = folder / "structures.png"
        if not (bars.is_file() or curve.is_file() or structures.is_file()):
            continue
        report = read_input_text(folder / "benchmark.md")  # names its tier, run
        found = re.search(r"tier `([^`]+)`", report)
        tier = get_tier(found.group(1)) if found else get_tier("current")
        rows = benchmark_rows(csv_path)
        if bars.is_file():
            table = summarise(rows, list(dict.fromkeys(r.method for r in rows)), tier.n_max)
            done.append((bars, csv_path, partial(plot_bars, table, bars)))
        if structures.is_file():
            types = palette(tier.modules) if tier.modules else None
            done.append((structures, csv_path,
                         partial(plot_structures, rows, structures, modules=types)))  # fmt: skip
        train_dir = training_run(report)
        evals = None if train_dir is None else train_dir / "evaluations.npz"
        if curve.is_file() and evals is not None and evals.is_file():  # the run is at hand
            done.append((curve, evals, partial(plot_learning_curve, evals, curve)))
    return done


def benchmark_rows(csv_path: Path) -> list:
    """The rows of ``modquad score``'s ``benchmark.csv``, each with its answer's cells."""
    from benchmarks.leaderboard_entries import BENCHMARK_COLUMNS, record_row
    from modquad_gym.scoring.agents_figures import cells_from_csv

    def typed(raw: dict):
        return dataclasses.replace(record_row(raw), cells=cells_from_csv(raw["cells"]))

    return read_rows_csv(csv_path, "", BENCHMARK_COLUMNS, typed, "modquad score's benchmark.csv")


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


def heterogeneous_figures(results: Path) -> list[Figure]:
    """The heterogeneous benchmark's examples, its ``heterogeneous.csv`` read and checked now and
    its task sets drawn again from the ``--tasks``, ``--seed`` and ``--n-max`` of the command
    its report names."""
    from benchmarks.heterogeneous_measure import task_sets
    from benchmarks.heterogeneous_report import figure

    csv_path, png = results / "heterogeneous.csv", results / "heterogeneous.png"
    if not (csv_path.is_file() and png.is_file()):
        return []
    made = made_by_options(results / "heterogeneous.md")
    n_tasks, seed, n_max = made.tasks, made.seed, made.n_max

    def typed(raw: dict) -> dict:
        saved = raw["saved"]
        return {**raw, "task": int(raw["task"]), "saved": int(saved) if saved.isdigit() else saved}

    columns = read_input_text(csv_path).splitlines()[0].split(",")  # the rows' own header
    rows = read_rows_csv(csv_path, "", columns, typed, "a heterogeneous.csv")
    draw = partial(lambda: figure(rows, task_sets(n_tasks, seed), n_max, png))
    return [(png, csv_path, draw)]


def made_by_options(report: Path) -> argparse.Namespace:
    """The options of the ``python -m benchmarks.heterogeneous`` command that ``report``'s
    Made-by line names, read by that script's own parser (every form it takes, ``--tasks=25``
    as ``--tasks 25``): a one-line ValueError naming the report and what is wrong when the line
    is missing or the script would not take it, never the defaults in its place."""
    from benchmarks.heterogeneous import parser

    made = re.search(r"Made by `([^`]+)`", read_input_text(report))
    prefix = ["python", "-m", "benchmarks.heterogeneous"]
    try:
        words = shlex.split(made.group(1)) if made else []
    except ValueError as exc:
        raise ValueError(f"{report}: its Made-by line cannot be split into words ({exc})") from None
    if words[:3] != prefix:
        raise ValueError(f"{report}: no Made-by line `{shlex.join(prefix)} ...` to read the "
                         "tasks from")  # fmt: skip
    script = parser()

    def refuse(message: str):
        raise ValueError(f"{report}: its Made-by line: {message}")

    script.error = refuse  # type: ignore[method-assign]
    return script.parse_args(words[3:])


def main(argv: list[str] | None = None) -> int:
    parser = OneLineParser(
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
    figures += scale_figures(args.results) + heterogeneous_figures(args.results)
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
