"""Learned agents over training seeds: interquartile mean with 95 % bootstrap intervals.

A single training seed is not a result (Henderson et al. 2018; Agarwal et al. 2021). ``python -m
modquad_gym.scoring.seeds RUNS --tier T`` scores the model of every ``RUNS/seed-*`` folder (from
``python train.py --seeds ...``) with each learned method on the tier's held-out suites, the
searches once as the reference, and writes to ``--out``:

* ``seeds.md``: per method and metric the IQM over seeds x suites and the mean, each with its
  95 % stratified bootstrap interval (percentile method, runs resampled within each suite, as in
  ``rliable``), per suite, the tier's goals (:attr:`.tiers.Tier.goals`) judged on the
  interval's pessimistic end (the lower end of a share, the upper end of configurations);
* ``seeds.csv``: one row per (seed, method, suite) with the suite-level figures (success,
  optimal share, configurations and seconds per task, mean modules over the solved tasks);
* ``seeds.png``: the intervals as bars.

Scores per run are suite-level rates (success, optimal share) and means (configurations
evaluated per task); the IQM is the 25 %-trimmed mean of the seeds x suites scores.
"""

from __future__ import annotations

import argparse
import sys
import time
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from modquad_gym.core.outputs import check_output_dir, save_figure, write_csv, write_text
from modquad_gym.scoring import machine_description
from modquad_gym.scoring.agents import SEARCH_METHODS, run_benchmark
from modquad_gym.scoring.scores import Row, config_limit, share_limit
from modquad_gym.scoring.seed_runs import LIMIT, check_limit, check_runs, find_runs, learned_methods
from modquad_gym.scoring.stats import interval, iqm, no_interval
from modquad_gym.scoring.tiers import TIERS, Tier, get_tier, honours_fault

METRICS = {"success": "success", "optimal": "optimal share", "evaluated": "configs / task"}
SEED_FILES = ("seeds.md", "seeds.csv", "seeds.png")


@dataclass
class SeedScore:
    """One seed's model with one method on one suite."""

    seed: str
    method: str
    suite: str
    tasks: int
    success: float
    optimal: float
    evaluated: float
    seconds: float
    modules: float | None = None
    """Mean module count over the solved tasks (None when none was solved)."""

    @classmethod
    def from_record(cls, r: dict) -> SeedScore:
        """The score of one record of a ``seeds.csv`` (:func:`write_report`; older files have no
        ``modules``), to re-draw its figure."""
        return cls(r["seed"], r["method"], r["suite"], int(r["tasks"]), float(r["success"]),
                   float(r["optimal"]), float(r["evaluated"]), float(r["seconds"]),
                   float(r["modules"]) if r.get("modules") else None)  # fmt: skip

    @classmethod
    def of(cls, seed: str, method: str, suite: str, rows: list[Row]) -> SeedScore:
        solved = [r.n_modules for r in rows if r.success]
        return cls(
            seed,
            method,
            suite,
            len(rows),
            float(np.mean([r.success for r in rows])),
            float(np.mean([r.optimal for r in rows])),
            float(np.mean([r.evaluated for r in rows])),
            float(np.mean([r.seconds for r in rows])),
            float(np.mean(solved)) if solved else None,
        )


def score_runs(
    runs: dict[str, Path],
    tier_name: str,
    methods: Sequence[str] | None = None,
    limit: int | None = None,
    progress: bool = True,
) -> list[SeedScore]:
    """Every run's model (``runs``: seed label -> model.zip) with every learned method (default
    the tier's), and the searches once (seed label ``-``), on the tier's held-out suites, scored
    per suite on the tasks whose certified optimum is within the tier's n_max. On a tier with a
    failure every method designs for it and a success survives it; the searches that cannot
    honour it are left out (:func:`~.tiers.honours_fault`). The methods, ``limit`` and every
    run are checked first, as the command line checks them (:mod:`.seed_runs`): a ValueError
    before any work."""
    tier = get_tier(tier_name)
    methods = learned_methods(methods, tier)
    check_limit(limit)
    check_runs(runs, methods, tier)
    return scored(runs, tier, methods, limit, progress)


def scored(
    runs: dict[str, Path], tier: Tier, methods: list[str], limit: int | None, progress: bool
) -> list[SeedScore]:
    """:func:`score_runs` on inputs it has checked."""
    suites = tier.load_suites(limit)
    scores: list[SeedScore] = []
    searches = [m for m in SEARCH_METHODS if tier.fault is None or honours_fault(m)]
    plan = [("-", None, searches)]
    plan += [(label, path, methods) for label, path in runs.items()]
    for label, model, ms in plan:
        rows = run_benchmark(suites, ms, tier.n_max, model, 0, progress, 1, tier.modules,
                             tier.name, tier.fault)  # fmt: skip
        for m in ms:
            for suite in suites:
                rs = [
                    r
                    for r in rows
                    if r.method == m
                    and r.suite == suite
                    and r.optimum is not None
                    and r.optimum <= tier.n_max
                ]
                if rs:
                    scores.append(SeedScore.of(label, m, suite, rs))
    return scores


def summary(scores: list[SeedScore], metric: str, method: str, suite: str | None = None) -> dict:
    """IQM and mean of ``metric`` over seeds (x suites), each with its 95 % interval."""
    mine = [s for s in scores if s.method == method and suite in (None, s.suite)]
    suites = sorted({s.suite for s in mine})
    cols = [np.array([getattr(s, metric) for s in mine if s.suite == x]) for x in suites]
    return {
        "seeds": len({s.seed for s in mine}),
        "iqm": interval(cols, iqm),
        "mean": interval(cols, lambda x: float(np.mean(x))),
    }


def _ci(v: tuple[float, float, float], pct: bool) -> str:
    f = (lambda x: f"{100 * x:.1f} %") if pct else (lambda x: f"{x:.1f}")
    if no_interval(v):  # one seed
        return f"{f(v[0])} n/a (1 seed)"
    return f"{f(v[0])} [{f(v[1])}, {f(v[2])}]"


def report_tables(scores: list[SeedScore], tier_name: str) -> list[str]:
    """The Markdown tables: overall, per suite, goals, searches for reference."""
    methods = [m for m in dict.fromkeys(s.method for s in scores) if m not in SEARCH_METHODS]
    suites = sorted({s.suite for s in scores})
    lines = [
        "| method | seeds | "
        + " | ".join(f"{t} IQM [95 % CI] | {t} mean [95 % CI]" for t in METRICS.values())
        + " |",
        "|---|---|" + "---|---|" * len(METRICS),
    ]
    per_suite = [
        "| suite | method | " + " | ".join(f"{t} IQM [95 % CI]" for t in METRICS.values()) + " |",
        "|---|---|" + "---|" * len(METRICS),
    ]
    for m in methods:
        cells = []
        for metric in METRICS:
            s = summary(scores, metric, m)
            pct = metric != "evaluated"
            cells += [_ci(s["iqm"], pct), _ci(s["mean"], pct)]
        n = len({s.seed for s in scores if s.method == m})
        lines.append(f"| {m} | {n} | " + " | ".join(cells) + " |")
        for suite in suites:
            cells = [_ci(summary(scores, k, m, suite)["iqm"], k != "evaluated") for k in METRICS]
            per_suite.append(f"| {suite} | {m} | " + " | ".join(cells) + " |")
    searches = ["| method | " + " | ".join(METRICS.values()) + " |", "|---|" + "---|" * 3]
    for m in SEARCH_METHODS:
        mine = [s for s in scores if s.method == m]
        if mine:
            w = np.array([s.tasks for s in mine], dtype=float)
            vals = [np.average([getattr(s, k) for s in mine], weights=w) for k in METRICS]
            searches.append(
                f"| {m} | {100 * vals[0]:.1f} % | {100 * vals[1]:.1f} % | {vals[2]:.1f} |"
            )
    return [
        *lines,
        "",
        "Per suite (IQM over seeds):",
        "",
        *per_suite,
        "",
        "The searches (deterministic; one run, all suites pooled):",
        "",
        *searches,
        "",
        *goal_lines(scores, tier_name),
    ]


def _configs_goal(scores: list[SeedScore], method: str, goal: Any, searches: dict) -> str:
    """The goal row on configurations per task (:func:`~.report.config_limit`)."""
    v = summary(scores, "evaluated", method)["iqm"]
    limit, words = config_limit(goal, searches)
    if limit is None:
        return f"| {method} | configs / task | - | {_ci(v, False)} | {words} |"
    verdict = "met" if v[2] <= limit else f"NOT met (upper end {v[2]:.1f})"
    verdict = "no verdict (no interval)" if no_interval(v) else verdict
    return f"| {method} | configs / task | {words} | {_ci(v, False)} | {verdict} |"


def share_goal(scores: list[SeedScore], metric: str, goal: float | str) -> tuple[float | None, str]:
    """(least share that meets ``goal``, the goal in words) (:func:`~.agents_report.share_limit`):
    a share, or a search's name (at least that search's share of ``metric`` on the same tasks,
    pooled over the suites); (None, why) when that search was not run."""
    rs = [s for s in scores if s.method == goal]
    shares = {}
    if rs:
        weights = [s.tasks for s in rs]
        shares[goal] = float(np.average([getattr(s, metric) for s in rs], weights=weights))
    return share_limit(goal, shares)


def goal_lines(scores: list[SeedScore], tier_name: str) -> list[str]:
    """The tier's goals against the pessimistic end of each 95 % interval (IQM): the lower
    end of a share, the upper end of configurations per task."""
    goals = get_tier(tier_name).goals
    out = (
        [
            "Goals, judged on the pessimistic end of the IQM's 95 % interval (the lower end of a "
            "share, the upper end of configurations per task):",
            "",
            "| method | metric | goal | IQM [95 % CI] | verdict |",
            "|---|---|---|---|---|",
        ]
        if goals
        else [f"The `{tier_name}` tier sets no goals for its learned methods."]
    )
    searches = {}  # configurations per task of each search, pooled over the suites
    for m in SEARCH_METHODS:
        rs = [s for s in scores if s.method == m]
        if rs:
            weights = [s.tasks for s in rs]
            searches[m] = float(np.average([s.evaluated for s in rs], weights=weights))
    for method, wanted in goals.items():
        if not any(s.method == method for s in scores):
            continue
        for metric, goal in {**wanted, "configs": wanted.get("configs")}.items():
            if metric == "configs":
                out.append(_configs_goal(scores, method, goal, searches))
                continue
            v = summary(scores, metric, method)["iqm"]
            goal, words = share_goal(scores, metric, goal)
            if goal is None:
                out.append(f"| {method} | {metric} | - | {_ci(v, True)} | {words} |")
                continue
            verdict = "met" if v[1] >= goal else f"NOT met (lower end {100 * (goal - v[1]):.1f} "
            verdict += "" if v[1] >= goal else "points short)"
            verdict = "no verdict (no interval)" if no_interval(v) else verdict
            out.append(f"| {method} | {metric} | {words} | {_ci(v, True)} | {verdict} |")
    exhaustive = [s for s in scores if s.method == "exhaustive"]
    guided_methods = dict.fromkeys(s.method for s in scores if s.method.startswith("ppo-guided"))
    if exhaustive and guided_methods:
        ref = np.average([s.evaluated for s in exhaustive], weights=[s.tasks for s in exhaustive])
        t_ref = np.average([s.seconds for s in exhaustive], weights=[s.tasks for s in exhaustive])
        out.append("")
        for method in guided_methods:
            g = summary(scores, "evaluated", method)["iqm"]
            secs = np.mean([s.seconds for s in scores if s.method == method])
            out.append(
                f"{method} evaluates {g[0]:.1f} configurations per task (IQM; 95 % CI "
                f"{g[1]:.1f}-{g[2]:.1f}), {100 * g[0] / ref:.1f} % of the exhaustive search's "
                f"{ref:.1f}, in {100 * secs / t_ref:.0f} % of its time ({secs:.3f} s vs "
                f"{t_ref:.3f} s per task, mean over seeds)."
            )
    return out


def plot(scores: list[SeedScore], path: Path) -> Path:
    """Each learned method's IQM (dot) with its 95 % interval (bar with caps), per metric, on
    axes from zero (shares from 0 to 100 %): a zero-width interval stays a visible dot."""
    import matplotlib.pyplot as plt

    methods = [m for m in dict.fromkeys(s.method for s in scores) if m not in SEARCH_METHODS]
    seeds = len({s.seed for s in scores if s.method in methods})
    suites = len({s.suite for s in scores if s.method in methods})
    fig, axes = plt.subplots(1, len(METRICS), figsize=(4 * len(METRICS), 0.6 * len(methods) + 1.8))
    for ax, (metric, title) in zip(axes, METRICS.items()):
        share = metric != "evaluated"
        k = 100.0 if share else 1.0
        points = []
        for i, m in enumerate(methods):
            point, low, high = (k * v for v in summary(scores, metric, m)["iqm"])
            ax.errorbar(point, i, xerr=[[point - low], [high - point]], fmt="o", color=f"C{i}",
                        capsize=5, markersize=7, elinewidth=2)  # fmt: skip
            points.append((i, point, low, high))
        ax.set_yticks(range(len(methods)), methods if ax is axes[0] else [""] * len(methods))
        ax.set_ylim(-0.6, len(methods) - 0.4)
        right = 105 if share else 1.15 * max(ax.get_xlim()[1], 1e-9)
        ax.set_xlim(0, right)
        for i, point, low, high in points:  # the numbers beside each dot: a narrow CI is read
            ax.text(point, i + 0.18, f"{point:.1f} [{low:.1f}, {high:.1f}]", fontsize="small",
                    ha="right" if point > 0.6 * right else "left", va="bottom")  # fmt: skip
        ax.set_xlabel(f"{title} (%)" if share else title)
        ax.set_title(f"{title}")
        ax.grid(axis="x", alpha=0.3)
    fig.suptitle(f"IQM over {seeds} seeds x {suites} suites, bars: 95 % bootstrap CI",
                 fontsize="medium")  # fmt: skip
    fig.tight_layout()
    return save_figure(fig, path)


def write_report(
    scores: list[SeedScore], tier_name: str, out: Path, runs: dict, command: str, wall: float
) -> Path:
    """``seeds.md``, ``seeds.csv`` and ``seeds.png`` in ``out``."""
    write_csv([vars(s) for s in scores], out / "seeds.csv")
    plot(scores, out / "seeds.png")
    tier = get_tier(tier_name)
    failure = []
    if tier.fault:
        failure = [
            "",
            f"Every method designs for a {tier.fault} failure; a success is an "
            "answer that survives any single one (the optima are the failure's).",
        ]
    text = [
        f"# Learned agents over {len(runs)} training seeds: tier `{tier_name}`",
        "",
        f"Made by `{command}`. Machine: {machine_description()}. Wall time {wall:.0f} s.",
        "",
        f"Runs: {', '.join(f'`{p.parent}`' for p in runs.values())}. Held-out suites: "
        f"{', '.join(f'`{s}`' for s in tier.suites)}; each task's certified optimum with "
        f"n_max = {tier.n_max}. Per run and suite the scores are the success rate, the share "
        "solved with the optimal module count and the mean configurations evaluated per task; "
        "IQM = 25 %-trimmed mean over the seeds x suites scores; intervals are 95 % stratified "
        "percentile bootstraps (2,000 resamples).",
        *failure,
        "",
        *report_tables(scores, tier_name),
        "",
        "![intervals](seeds.png)",
        "",
        "Per seed and suite: `seeds.csv`.",
        "",
    ]
    return write_text(out / "seeds.md", "\n".join(text))


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(
        prog="python -m modquad_gym.scoring.seeds",
        description="Score every seed's model of a `train.py --seeds` folder on a tier's "
        "held-out suites and report the IQM and mean with 95 % bootstrap intervals.",
    )
    p.add_argument("runs", type=Path, nargs="+", help="folders with seed-*/model.zip")
    p.add_argument("--tier", choices=tuple(TIERS), default="current", help="(default current)")
    p.add_argument(
        "--methods",
        nargs="+",
        default=None,
        help="learned methods (default the tier's: ppo ppo-k8 ppo-guided, and on the large "
        "tier also ppo-guided-b256-w8)",
    )
    p.add_argument("--out", type=Path, default=None, help="report folder (default RUNS/report)")
    p.add_argument("--limit", type=LIMIT, default=None, help="first N tasks per suite")
    p.add_argument("--force", action="store_true", help="replace an existing report")
    p.add_argument("--no-progress", action="store_true", help="no progress bars")
    args = p.parse_args(argv)
    try:  # everything the work needs, before it starts (a model that does not load included)
        tier = get_tier(args.tier)
        methods = learned_methods(args.methods, tier)
        runs = find_runs(args.runs)
        out = args.out or args.runs[0] / "report"
        check_output_dir(out, SEED_FILES, args.force, "--out")
        check_runs(runs, methods, tier)
    except ValueError as exc:
        p.error(str(exc))
    t0 = time.perf_counter()
    scores = scored(runs, tier, methods, args.limit, not args.no_progress)
    argv_text = " ".join(argv if argv is not None else sys.argv[1:])
    path = write_report(
        scores,
        args.tier,
        out,
        runs,
        f"python -m modquad_gym.scoring.seeds {argv_text}",
        time.perf_counter() - t0,
    )
    print(path.read_text())
    return 0


if __name__ == "__main__":
    from modquad_gym.core.interrupts import run_command

    raise SystemExit(run_command(main, "python -m modquad_gym.scoring.seeds"))
