"""The leaderboard's entries (one method on one tier, each metric with its interval) and the
committed data they are read from: the tier reports' per-task rows, the rescored searches, the
five-seed reports, outside agents' submissions and the anytime search's history."""

from __future__ import annotations

import csv
import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
RESULTS = ROOT / "results"
COMMAND = "python -m benchmarks.leaderboard"
TIERS = ("current", "large", "mixed", "dynamic", "fault")
BUDGET = 1.0
"""Seconds per task at which every method is ranked: a task counts when the method's answer is
optimal and came within this wall time."""
RESCORED = "leaderboard_searches.csv"
"""The searches a tier report did not run, scored by ``--rescore-searches`` (in results/)."""
ANYTIME = "leaderboard_anytime.csv"
"""The anytime search's history per task, written by ``--anytime-history`` (in results/)."""
SUBMISSIONS = "submissions"
"""The folder of results/ that holds outside agents' submissions (``*.csv``)."""
SUBMISSION = "submission.csv"
"""What ``--solver`` writes beside its leaderboard: the file an outside agent submits."""
METRICS = ("success", "optimal", "budget", "evaluated", "oracle_calls", "seconds")
NA = (math.nan, math.nan, math.nan)
T3 = tuple[float, float, float]


@dataclass
class Entry:
    """One method on one tier: each metric of :data:`METRICS` as (point, low, high) (low = high
    = point for one run; NaN where not scored); ``budget`` the optimal share within
    :data:`BUDGET` seconds per task; ``modules`` the mean module count over the solved tasks;
    ``full`` the tier's task count (a row of fewer ``tasks`` is partial); ``status`` why the
    method has no scores here ("" when it has)."""

    tier: str
    method: str
    kind: str  # "search", "learned" or "outside"
    tasks: int
    seeds: int
    success: T3 = NA
    optimal: T3 = NA
    budget: T3 = NA
    evaluated: T3 = NA
    oracle_calls: T3 = NA
    seconds: T3 = NA
    modules: float | None = None
    source: str = ""
    notes: list[str] = field(default_factory=list)
    status: str = ""
    full: int = 0

    def as_csv(self) -> dict:
        out = {"tier": self.tier, "method": self.method, "kind": self.kind, "tasks": self.tasks,
               "tier_tasks": self.full, "seeds": self.seeds}  # fmt: skip
        for name in METRICS:
            point, low, high = getattr(self, name)
            out |= {name: _g(point), f"{name}_low": _g(low), f"{name}_high": _g(high)}
        out["modules"] = "" if self.modules is None else f"{self.modules:.6g}"
        out["status"] = self.status
        out["source"] = self.source
        out["notes"] = "; ".join(self.notes)
        return out


def _g(v: float) -> str:
    return "" if math.isnan(v) else f"{v:.6g}"


# --- reading the committed data ---------------------------------------------------------------
BENCHMARK_COLUMNS = ("suite", "task", "optimum", "method", "success", "n_modules", "gap",
                     "optimal", "evaluated", "oracle_calls", "seconds", "cells")  # fmt: skip
"""The columns of a benchmark CSV of ``modquad score`` (``benchmark.csv``), in order."""


def read_rows(path: Path):
    """The per-task rows (:class:`~modquad_gym.scoring.scores.Row`) of a benchmark CSV (rows
    with a ``status``, a submission's unscored tiers, are left out)."""
    with open(path, newline="") as fh:
        return [record_row(r) for r in csv.DictReader(fh) if not r.get("status")]


def record_row(r: dict):
    """The :class:`~modquad_gym.scoring.scores.Row` of one record of a benchmark or submission
    CSV."""
    from modquad_gym.scoring.scores import Row

    def num(v: str) -> int | None:
        return int(v) if v not in ("", None) else None

    return Row(r["suite"], r["task"], num(r["optimum"]), r["method"], r["success"] == "1",
               num(r["n_modules"]), int(r["evaluated"]), int(r["oracle_calls"]),
               float(r["seconds"]), None)  # fmt: skip


def in_scope(rows, n_max: int) -> list:
    """The rows of the tasks whose certified optimum is within n_max (every report's scope)."""
    return [r for r in rows if r.optimum is not None and r.optimum <= n_max]


def task_metrics(rows) -> dict[str, float]:
    """Each metric of :data:`METRICS` over one run's rows (of one method, in scope)."""
    return {
        "success": float(np.mean([r.success for r in rows])),
        "optimal": float(np.mean([r.optimal for r in rows])),
        "budget": float(np.mean([r.optimal and r.seconds <= BUDGET for r in rows])),
        "evaluated": float(np.mean([r.evaluated for r in rows])),
        "oracle_calls": float(np.mean([r.oracle_calls for r in rows])),
        "seconds": float(np.mean([r.seconds for r in rows])),
    }


def over_runs(tier, method: str, kind: str, runs: dict[str, list], source: str,
              full: int = 0) -> Entry:  # fmt: skip
    """The entry of ``method`` from its per-task rows of one or more seeded runs (seed ->
    rows): per seed each metric over the tier's tasks, then the mean over seeds with its 95 %
    percentile bootstrap interval (:func:`_intervals`; the point for one run)."""
    per_seed = {k: [] for k in METRICS}
    modules = []
    tasks = 0
    for rows in runs.values():
        rows = in_scope([r for r in rows if r.method == method], tier.n_max)
        tasks = len({(r.suite, r.task) for r in rows})  # tasks, not rows
        for k, v in task_metrics(rows).items():
            per_seed[k].append(v)
        solved = [r.n_modules for r in rows if r.success]
        if solved:
            modules.append(float(np.mean(solved)))
    stats = _intervals(per_seed)
    return Entry(tier.name, method, kind, tasks, len(runs), **stats,
                 modules=float(np.mean(modules)) if modules else None, source=source,
                 full=full or tasks)  # fmt: skip


def _intervals(per_seed: dict[str, list[float]]) -> dict[str, T3]:
    """Each metric's mean over seeds (its list of per-seed values) with its 95 % percentile
    bootstrap interval (:func:`modquad_gym.scoring.stats.interval`). One run has no interval:
    low = high = the point, as :class:`Entry` keeps it (the page prints the point alone, the
    row labelled one run); a metric not scored in some run is NaN."""
    from modquad_gym.scoring.stats import interval, mean, no_interval

    out = {}
    for k, v in per_seed.items():
        values = np.array(v, dtype=float)
        if not values.size or np.isnan(values).any():
            out[k] = NA
            continue
        t = interval([values], mean)
        out[k] = (t[0], t[0], t[0]) if no_interval(t) else t
    return out


def read_seeds(path: Path) -> list[dict]:
    with open(path, newline="") as fh:
        return list(csv.DictReader(fh))


def over_seeds(records: list[dict], tier, source: str, one_run: dict[str, Entry]) -> list[Entry]:
    """The learned methods of a five-seed report: per seed, each metric pooled over the tier's
    tasks (suites weighted by their task counts); the mean over seeds with its 95 % percentile
    bootstrap interval (:func:`_intervals`, seeds resampled). What the
    report does not hold (per-task seconds, so the optimal share within the budget; oracle
    calls; mean modules in older reports) comes from ``one_run`` (method -> the shipped
    model's entry in the tier report), with a note."""
    out = []
    methods = list(dict.fromkeys(r["method"] for r in records if r["seed"] != "-"))
    for method in methods:
        mine = [r for r in records if r["method"] == method]
        seeds = sorted({r["seed"] for r in mine}, key=lambda s: (len(s), s))
        pooled: dict[str, list[float]] = {k: [] for k in ("success", "optimal", "evaluated",
                                                         "seconds")}  # fmt: skip
        modules = []
        for seed in seeds:
            rs = [r for r in mine if r["seed"] == seed]
            w = np.array([float(r["tasks"]) for r in rs])
            for key in pooled:
                pooled[key].append(float(np.average([float(r[key]) for r in rs], weights=w)))
            if all(r.get("modules") not in (None, "") for r in rs):
                solved = w * np.array([float(r["success"]) for r in rs])
                modules.append(float(np.average([float(r["modules"]) for r in rs],
                                                weights=solved)))  # fmt: skip
        tasks = int(sum(float(r["tasks"]) for r in mine if r["seed"] == seeds[0]))
        stats = _intervals(pooled)
        single = one_run.get(method)
        notes = []
        mean_modules = float(np.mean(modules)) if len(modules) == len(seeds) else None
        if single is not None:
            stats |= {"budget": single.budget, "oracle_calls": single.oracle_calls}
            notes.append(f"one run: {single.source}")
            if mean_modules is None and single.modules is not None:
                mean_modules = single.modules
                notes.append(f"modules: {single.source}")
        out.append(Entry(tier.name, method, "learned", tasks, len(seeds), **stats,
                         modules=mean_modules, source=source, notes=notes,
                         full=tasks))  # fmt: skip
    return out


def unscored(tier, method: str, kind: str, why: str) -> Entry:
    """A method that has no scores on ``tier``, and why (shown in place of its numbers)."""
    return Entry(tier.name, method, kind, 0, 0, status=why)


FAULT_REFUSED = "refused: takes no fault="


def one_run_rows(
    tier, results: Path = RESULTS, rescored: Path | None = None
) -> dict[str, tuple[list, Path]]:
    """Per method, its per-task rows of one run on ``tier`` and their file: the tier report's,
    else (a search it did not run) the rescored searches' file (``rescored``, default
    ``results``' :data:`RESCORED`)."""
    report = results / f"tier_{tier.name}" / "benchmark.csv"
    out: dict[str, tuple[list, Path]] = {}
    for path in (report, results / RESCORED if rescored is None else rescored):
        if not path.is_file():
            continue
        for r in read_rows(path):
            if r.suite in tier.suites and (r.method not in out or out[r.method][1] == path):
                out.setdefault(r.method, ([], path))[0].append(r)
    return out


def tier_entries(tier_name: str, results: Path = RESULTS, submissions: Path | None = None,
                 rescored: Path | None = None) -> list[Entry]:  # fmt: skip
    """Every committed method on one tier: the searches, the learned methods, then the outside
    agents' submissions (``submissions``, default ``results/submissions``). On a fault tier the
    methods that cannot honour the failure are listed with the reason instead of numbers.
    ``rescored``: the rescored searches' file (:func:`one_run_rows`)."""
    from modquad_gym.scoring.tiers import get_tier, honours_fault
    from modquad_gym.search import SEARCHES

    tier = get_tier(tier_name)
    runs = one_run_rows(tier, results, rescored)
    full = len({r.task for r in in_scope(runs["exhaustive"][0], tier.n_max)})
    entries = []
    for m in SEARCHES:
        if tier.fault and not honours_fault(m):
            entries.append(unscored(tier, m, "search", FAULT_REFUSED))
        elif m in runs:
            rows, path = runs[m]
            entries.append(over_runs(tier, m, "search", {"-": rows}, _rel(path)))
    one = {m: over_runs(tier, m, "learned", {"-": runs[m][0]}, _rel(runs[m][1]))
           for m in tier.learned if m in runs}  # fmt: skip
    seeds = results / f"seeds_{tier.name}" / "seeds.csv"
    if seeds.is_file():
        entries += over_seeds(read_seeds(seeds), tier, _rel(seeds), one)
    else:  # no five-seed report: the shipped model's one run
        entries += one.values()
    folder = results / SUBMISSIONS if submissions is None else submissions
    for path in sorted(folder.glob("*.csv")) if folder.is_dir() else []:
        entries += submission_entries(path, tier, full)
    return entries


def submission_entries(path: Path, tier, full: int) -> list[Entry]:
    """The outside agents of a submission file
    (:func:`benchmarks.leaderboard_scoring.write_submission`) on ``tier``: the file, each
    agent's name and its rows checked (:mod:`benchmarks.leaderboard_checks`: one row per
    (seed, suite, task), the same tasks in every seed, each row verified again against the
    tier's own task), a ValueError naming the file and the row otherwise."""
    from benchmarks.leaderboard_checks import (
        one_row_per_task,
        refuse_taken,
        submission_records,
        verified_rows,
    )

    numbered = [(n, r) for n, r in submission_records(path) if r["tier"] == tier.name]
    out = []
    for method in dict.fromkeys(r["method"] for _, r in numbered):
        refuse_taken(method, str(path))
        mine = [(n, r) for n, r in numbered if r["method"] == method]
        status = next((r["status"] for _, r in mine if r["status"]), "")
        if status:
            out.append(unscored(tier, method, "outside", status))
            continue
        one_row_per_task(path, tier.name, method, mine)
        rows = {s: [] for s in dict.fromkeys(r["seed"] for _, r in mine)}
        for (_, r), row in zip(mine, verified_rows(path, tier, mine)):
            rows[r["seed"]].append(row)
        out.append(over_runs(tier, method, "outside", rows, _rel(path), full))
    return out


def read_anytime(path: Path) -> dict[str, list[tuple[float, bool]]]:
    """Per tier, (seconds until the anytime search's best structure so far first had the
    optimal count, reached) of every task in scope, from ``--anytime-history``'s file ({}
    without it)."""
    if not path.is_file():
        return {}
    out: dict[str, list[tuple[float, bool]]] = {}
    with open(path, newline="") as fh:
        for r in csv.DictReader(fh):
            if r["in_scope"] == "1":
                t = float(r["optimal_at"]) if r["optimal_at"] else math.inf
                out.setdefault(r["tier"], []).append((t, r["optimal_at"] != ""))
    return out


def curves(tier, rows_by_method: dict[str, list], anytime: list[tuple[float, bool]]):
    """(method, sorted seconds at which each task in scope was answered optimally (inf: never))
    per method of one run, the anytime search's history as ``anytime (history)``."""
    out = []
    for method, rows in rows_by_method.items():
        rs = in_scope(rows, tier.n_max)
        out.append((method, sorted(r.seconds if r.optimal else math.inf for r in rs)))
    if anytime:
        out.append(("anytime (history)", sorted(t for t, _ in anytime)))
    return out


def _rel(path: Path) -> str:
    try:
        return path.resolve().relative_to(ROOT).as_posix()
    except ValueError:
        return str(path)


if __name__ == "__main__":
    from benchmarks.common import refuse_as_script

    raise SystemExit(refuse_as_script("leaderboard_entries"))
