"""The seeds report (``seeds.md``, ``seeds.csv``, ``seeds.png``) of
``python -m modquad_gym.scoring.seeds``: per learned method and metric the IQM and the mean over
seeds of each seed's score on the tier's held-out tasks (:mod:`.seed_scores`), per suite, the
tier's goals judged on the interval's pessimistic end, and the searches for reference.
``python -m benchmarks.seeds_rerender`` re-renders a committed report from its ``seeds.csv``."""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any

import numpy as np

from modquad_gym.core.outputs import save_figure, write_csv, write_text
from modquad_gym.scoring import machine_description
from modquad_gym.scoring.agents import SEARCH_METHODS
from modquad_gym.scoring.scores import config_limit, share_limit
from modquad_gym.scoring.seed_scores import SeedScore, ci_text, per_seed, summary
from modquad_gym.scoring.stats import no_interval
from modquad_gym.scoring.tiers import get_tier

METRICS = {"success": "success", "optimal": "optimal share", "evaluated": "configs / task"}


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
            cells += [ci_text(s["iqm"], pct), ci_text(s["mean"], pct)]
        n = len({s.seed for s in scores if s.method == m})
        lines.append(f"| {m} | {n} | " + " | ".join(cells) + " |")
        for suite in suites:
            cells = [
                ci_text(summary(scores, k, m, suite)["iqm"], k != "evaluated") for k in METRICS
            ]
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
        return f"| {method} | configs / task | - | {ci_text(v, False)} | {words} |"
    verdict = "met" if v[2] <= limit else f"NOT met (upper end {v[2]:.1f})"
    verdict = "no verdict (no interval)" if no_interval(v) else verdict
    return f"| {method} | configs / task | {words} | {ci_text(v, False)} | {verdict} |"


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


def _share_goal_row(scores: list[SeedScore], method: str, metric: str, goal: Any) -> str:
    v = summary(scores, metric, method)["iqm"]
    goal, words = share_goal(scores, metric, goal)
    if goal is None:
        return f"| {method} | {metric} | - | {ci_text(v, True)} | {words} |"
    if no_interval(v):
        verdict = "no verdict (no interval)"
    elif v[1] >= goal:
        verdict = "met"
    else:
        verdict = f"NOT met (lower end {100 * (goal - v[1]):.1f} points short)"
    return f"| {method} | {metric} | {words} | {ci_text(v, True)} | {verdict} |"


def _pooled(scores: list[SeedScore], method: str, metric: str) -> float:
    """A deterministic search's ``metric`` over the tier's tasks (suites weighted by tasks)."""
    rs = [s for s in scores if s.method == method]
    return float(np.average([getattr(s, metric) for s in rs], weights=[s.tasks for s in rs]))


def goal_lines(scores: list[SeedScore], tier_name: str) -> list[str]:
    """The tier's goals against the pessimistic end of each 95 % interval (IQM): the lower
    end of a share, the upper end of configurations per task; no verdict without an interval
    (one seed). Then each guided method's configurations and seconds against the exhaustive
    search's, both per task over the tier's tasks."""
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
    searches = {  # configurations per task of each search, over the tier's tasks
        m: _pooled(scores, m, "evaluated")
        for m in SEARCH_METHODS
        if any(s.method == m for s in scores)
    }
    for method, wanted in goals.items():
        if not any(s.method == method for s in scores):
            continue
        for metric, goal in {**wanted, "configs": wanted.get("configs")}.items():
            if metric == "configs":
                out.append(_configs_goal(scores, method, goal, searches))
            else:
                out.append(_share_goal_row(scores, method, metric, goal))
    guided_methods = dict.fromkeys(s.method for s in scores if s.method.startswith("ppo-guided"))
    if "exhaustive" in searches and guided_methods:
        ref, t_ref = searches["exhaustive"], _pooled(scores, "exhaustive", "seconds")
        out.append("")
        for method in guided_methods:
            g = summary(scores, "evaluated", method)["iqm"]
            secs = float(np.mean(per_seed(scores, "seconds", method)))
            out.append(
                f"{method} evaluates {ci_text(g, False)} configurations per task (IQM over seeds, "
                f"95 % CI), {100 * g[0] / ref:.1f} % of the exhaustive search's {ref:.1f} on "
                f"the same tasks, in {100 * secs / t_ref:.0f} % of its time ({secs:.3f} s vs "
                f"{t_ref:.3f} s per task, mean over seeds)."
            )
    return out


def plot(scores: list[SeedScore], path: Path) -> Path:
    """Each learned method's IQM (dot) with its 95 % interval (bar with caps), per metric, on
    axes from zero (shares from 0 to 100 %): a zero-width interval stays a visible dot."""
    import matplotlib.pyplot as plt

    methods = [m for m in dict.fromkeys(s.method for s in scores) if m not in SEARCH_METHODS]
    seeds = len({s.seed for s in scores if s.method in methods})
    fig, axes = plt.subplots(1, len(METRICS), figsize=(4 * len(METRICS), 0.6 * len(methods) + 1.8))
    for ax, (metric, title) in zip(axes, METRICS.items()):
        share = metric != "evaluated"
        k = 100.0 if share else 1.0
        points = []
        for i, m in enumerate(methods):
            v = summary(scores, metric, m)["iqm"]
            point, low, high = (k * x for x in (v[:1] * 3 if no_interval(v) else v))
            ax.errorbar(point, i, xerr=[[point - low], [high - point]], fmt="o", color=f"C{i}",
                        capsize=5, markersize=7, elinewidth=2)  # fmt: skip
            label = f"{point:.1f} " + (
                "n/a (1 seed)" if no_interval(v) else f"[{low:.1f}, {high:.1f}]"
            )
            points.append((i, point, label))
        ax.set_yticks(range(len(methods)), methods if ax is axes[0] else [""] * len(methods))
        ax.set_ylim(-0.6, len(methods) - 0.4)
        right = 105 if share else 1.15 * max(ax.get_xlim()[1], 1e-9)
        ax.set_xlim(0, right)
        for i, point, label in points:  # the numbers beside each dot: a narrow CI is read
            ax.text(point, i + 0.18, label, fontsize="small",
                    ha="right" if point > 0.6 * right else "left", va="bottom")  # fmt: skip
        ax.set_xlabel(f"{title} (%)" if share else title)
        ax.set_title(f"{title}")
        ax.grid(axis="x", alpha=0.3)
    fig.suptitle(f"IQM over {seeds} seeds (each over the tier's held-out tasks), bars: 95 % "
                 "bootstrap CI over the seeds", fontsize="medium")  # fmt: skip
    fig.tight_layout()
    return save_figure(fig, path)


def made_by(command: str, wall: float) -> str:
    """The report's line on what made it."""
    return f"Made by `{command}`. Machine: {machine_description()}. Wall time {wall:.0f} s."


def report_text(scores: list[SeedScore], tier_name: str, made: str, runs: list[str]) -> str:
    """``seeds.md``: ``made`` (:func:`made_by`), the runs (their folders), the tables."""
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
        made,
        "",
        f"Runs: {', '.join(f'`{r}`' for r in runs)}. Held-out suites: "
        f"{', '.join(f'`{s}`' for s in tier.suites)}; each task's certified optimum with "
        f"n_max = {tier.n_max}. Per run and suite the scores are the success rate, the share "
        "solved with the optimal module count and the mean configurations evaluated per task; "
        "a seed's score is its mean over the tier's held-out tasks (the suites weighted by "
        "their task counts, as the leaderboard counts it). IQM = 25 %-trimmed mean over the "
        "seeds' scores (of 5 seeds: the mean of the middle 3); intervals are 95 % percentile "
        "bootstraps over the seeds (2,000 resamples), which over a handful of seeds cover less "
        "than 95 % (docs/benchmarks.md).",
        *failure,
        "",
        *report_tables(scores, tier_name),
        "",
        "![intervals](seeds.png)",
        "",
        "Per seed and suite: `seeds.csv`.",
        "",
    ]
    return "\n".join(text)


def write_report(
    scores: list[SeedScore], tier_name: str, out: Path, runs: dict, command: str, wall: float
) -> Path:
    """``seeds.md``, ``seeds.csv`` and ``seeds.png`` in ``out``."""
    write_csv([vars(s) for s in scores], out / "seeds.csv")
    plot(scores, out / "seeds.png")
    folders = [str(p.parent) for p in runs.values()]
    return write_text(
        out / "seeds.md", report_text(scores, tier_name, made_by(command, wall), folders)
    )


RERENDERED = " Re-rendered from its `seeds.csv` by `"


def rerendered(scores: list[SeedScore], old: str, command: str) -> str:
    """``seeds.md`` from ``scores`` (its ``seeds.csv``) as :func:`write_report` now writes it,
    keeping what the scoring run recorded in ``old`` (the old ``seeds.md``): its tier, its
    made-by paragraph and its runs, with ``command`` named as the re-rendering; a ValueError
    when ``old`` is not a seeds report."""
    tier = re.search(r"^# Learned agents over \d+ training seeds: tier `([^`]+)`", old, re.M)
    made = re.search(r"^Made by `.*$", old, re.M)
    runs = re.search(r"^Runs: (.*?)\. Held-out suites:", old, re.M)
    if not (tier and made and runs):
        raise ValueError("not a seeds report of python -m modquad_gym.scoring.seeds")
    paragraph = made.group(0).split(RERENDERED)[0]
    paragraph += f"{RERENDERED}{command}` (the scores unchanged)."
    folders = re.findall(r"`([^`]+)`", runs.group(1))
    return report_text(scores, tier.group(1), paragraph, folders)
