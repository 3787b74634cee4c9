"""Re-draw the committed figures from the committed reports, without re-running a benchmark.

Each figure is drawn by the plotting function of the command that made it, from that command's
own data in ``results/``: the agent benchmarks' ``benchmark_bars.png`` from ``benchmark.csv``
and ``learning_curve.png`` from the training run's ``evaluations.npz`` named in
``benchmark.md``; ``seeds.png`` from ``seeds.csv``; the scale benchmarks' ``gap_vs_size.png``
from ``rows.csv``. Writes ``results/figures.md`` listing every figure and its source.

    python -m benchmarks.figures --force
"""

from __future__ import annotations

import argparse
import re
from pathlib import Path

from modquad_gym.core.outputs import write_text

COMMAND = "python -m benchmarks.figures --force"


def training_run(report: str) -> Path | None:
    """The training run a benchmark report's learning curve came from: its ``--train-dir``,
    else the folder of the model it names (as ``modquad score`` chooses)."""
    found = re.search(r"--train-dir (\S+?)[` ]", report)
    if found:
        return Path(found.group(1))
    found = re.search(r"model: `([^`]+\.zip)`", report)
    return Path(found.group(1)).parent if found else None


def agent_figures(results: Path) -> list[tuple[Path, Path]]:
    """(figure, source) of every agent benchmark's bars and learning curve."""
    from benchmarks.leaderboard_entries import read_rows
    from modquad_gym.scoring.agents_figures import plot_bars, plot_learning_curve
    from modquad_gym.scoring.scores import summarise
    from modquad_gym.scoring.tiers import get_tier

    done = []
    for csv_path in sorted(results.rglob("benchmark.csv")):
        folder = csv_path.parent
        report = (folder / "benchmark.md").read_text()
        bars = folder / "benchmark_bars.png"
        if bars.is_file():
            tier = re.search(r"tier `([^`]+)`", report)
            n_max = get_tier(tier.group(1)).n_max if tier else 7
            rows = read_rows(csv_path)
            plot_bars(summarise(rows, list(dict.fromkeys(r.method for r in rows)), n_max), bars)
            done.append((bars, csv_path))
        curve = folder / "learning_curve.png"
        train_dir = training_run(report)
        if curve.is_file() and train_dir is not None:
            evals = train_dir / "evaluations.npz"
            if plot_learning_curve(evals, curve):  # None when the run is not at hand
                done.append((curve, evals))
    return done


def seed_figures(results: Path) -> list[tuple[Path, Path]]:
    """(figure, source) of every seeds report's interval plot."""
    from modquad_gym.scoring.seeds import plot, read_scores

    done = []
    for csv_path in sorted(results.glob("seeds_*/seeds.csv")):
        png = csv_path.with_name("seeds.png")
        plot(read_scores(csv_path), png)
        done.append((png, csv_path))
    return done


def scale_figures(results: Path) -> list[tuple[Path, Path]]:
    """(figure, source) of every scale benchmark's gap plot."""
    from benchmarks.scale import read_rows
    from benchmarks.scale_report import plot

    done = []
    for csv_path in sorted(results.glob("scale*/rows.csv")):
        png = csv_path.with_name("gap_vs_size.png")
        if png.is_file():
            plot(read_rows(csv_path), png)
            done.append((png, csv_path))
    return done


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        prog="python -m benchmarks.figures",
        description="Re-draw the committed figures of results/ from their reports' data (no "
        "benchmark is re-run) and list them in results/figures.md.",
    )
    parser.add_argument("--results", type=Path, default=Path("results"), help="the results folder")
    parser.add_argument("--force", action="store_true", help="replace the existing figures")
    args = parser.parse_args(argv)
    if not args.results.is_dir():
        parser.error(f"--results: no folder {args.results}")
    if not args.force:
        parser.error("the figures exist and would be replaced: give --force")
    done = agent_figures(args.results) + seed_figures(args.results) + scale_figures(args.results)
    lines = [
        "# Figures re-drawn from their reports",
        "",
        f"Made by `{COMMAND}`: each figure drawn by its benchmark's plotting function from the "
        "data below (no benchmark re-run).",
        "",
        "| figure | drawn from |",
        "|---|---|",
        *(f"| `{png.as_posix()}` | `{src.as_posix()}` |" for png, src in done),
        "",
    ]
    write_text(args.results / "figures.md", "\n".join(lines))
    for png, src in done:
        print(f"wrote {png} (from {src})")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
