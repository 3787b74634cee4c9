"""The leaderboard: every method on every benchmark tier, ranked at a stated time budget per task.

    python -m benchmarks.leaderboard --force

reads the committed data files and writes ``results/leaderboard.md``, ``results/leaderboard.csv``,
``results/leaderboard.png`` (optimal share against seconds per task),
``results/leaderboard_anytime.png`` (the share of tasks answered optimally within t seconds,
against t; both drawn by :mod:`benchmarks.leaderboard_figures`) and the documentation page
``docs/leaderboard.md`` (no number is typed by hand):

* the learned methods over five training seeds from ``results/seeds_<tier>/seeds.csv`` (one row
  per seed, method and suite): each seed's scores pooled over the tier's held-out tasks, the
  mean over seeds with a 95 % percentile bootstrap interval over seeds; their oracle calls and
  optimal share within the budget from the shipped model's one run in the tier report;
* the searches (one deterministic run; random and genetic seeded) from the one-run tier reports
  ``results/tier_<tier>/benchmark.csv`` (one row per method and task), and, for the searches a
  tier report did not run, from ``results/leaderboard_searches.csv``, which
  ``python -m benchmarks.leaderboard --rescore-searches --force`` fills by running just those
  searches on the tier's held-out suites (seconds, not hours: no training, no learned method);
* the anytime search's history (when its best structure so far first had the optimal count) from
  ``results/leaderboard_anytime.csv`` (``--anytime-history`` runs it again);
* outside agents' submissions, ``results/submissions/*.csv`` (the ``submission.csv`` that
  ``--solver`` writes), over their seeds like the learned methods.

Add your own agent (scored now on every tier, beside the committed rows; nothing committed
changes)::

    python -m benchmarks.leaderboard --solver my_agent:Agent --out my_board

It follows the protocol of ``modquad score --solver`` (docs/benchmarks.md, "Score your own
agent"): told each tier's n_max and the run's seed, counted through the evaluator it is handed.
"""

from __future__ import annotations

import argparse
import csv
import inspect
import math
import sys
from collections.abc import Iterable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from benchmarks.leaderboard_figures import plot, plot_curves

ROOT = Path(__file__).resolve().parents[1]
RESULTS = ROOT / "results"
DOCS = ROOT / "docs"
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
OUTPUTS = ("leaderboard.md", "leaderboard.csv", "leaderboard.png", "leaderboard_anytime.png",
           SUBMISSION)  # fmt: skip
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
def read_rows(path: Path):
    """The per-task rows (:class:`~modquad_gym.scoring.scores.Row`) of a benchmark CSV (rows
    with a ``status``, a submission's unscored tiers, are left out)."""
    from modquad_gym.scoring.scores import Row

    def num(v: str) -> int | None:
        return int(v) if v not in ("", None) else None

    with open(path, newline="") as fh:
        return [
            Row(r["suite"], r["task"], num(r["optimum"]), r["method"], r["success"] == "1",
                num(r["n_modules"]), int(r["evaluated"]), int(r["oracle_calls"]),
                float(r["seconds"]), None)
            for r in csv.DictReader(fh) if not r.get("status")
        ]  # fmt: skip


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
    percentile bootstrap interval (:func:`modquad_gym.scoring.seeds.interval`; the point for
    one run)."""
    from modquad_gym.scoring.seeds import interval

    per_seed = {k: [] for k in METRICS}
    modules = []
    tasks = 0
    for rows in runs.values():
        rows = in_scope([r for r in rows if r.method == method], tier.n_max)
        tasks = len(rows)
        for k, v in task_metrics(rows).items():
            per_seed[k].append(v)
        solved = [r.n_modules for r in rows if r.success]
        if solved:
            modules.append(float(np.mean(solved)))
    stats = {k: interval([np.array(v)], lambda x: float(np.mean(x))) for k, v in per_seed.items()}
    return Entry(tier.name, method, kind, tasks, len(runs), **stats,
                 modules=float(np.mean(modules)) if modules else None, source=source,
                 full=full or tasks)  # fmt: skip


def read_seeds(path: Path) -> list[dict]:
    with open(path, newline="") as fh:
        return list(csv.DictReader(fh))


def over_seeds(records: list[dict], tier, source: str, one_run: dict[str, Entry]) -> list[Entry]:
    """The learned methods of a five-seed report: per seed, each metric pooled over the tier's
    tasks (suites weighted by their task counts); the mean over seeds with its 95 % percentile
    bootstrap interval (:func:`modquad_gym.scoring.seeds.interval`, seeds resampled). What the
    report does not hold (per-task seconds, so the optimal share within the budget; oracle
    calls; mean modules in older reports) comes from ``one_run`` (method -> the shipped
    model's entry in the tier report), with a note."""
    from modquad_gym.scoring.seeds import interval

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
        stats = {k: interval([np.array(v)], lambda x: float(np.mean(x))) for k, v in pooled.items()}
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
FAULT_LEARNED = "not applicable: trained without failures; takes no fault="


def one_run_rows(tier, results: Path = RESULTS) -> dict[str, tuple[list, Path]]:
    """Per method, its per-task rows of one run on ``tier`` and their file: the tier report's,
    else (a search it did not run) the rescored searches' file."""
    report = results / f"tier_{tier.name}" / "benchmark.csv"
    out: dict[str, tuple[list, Path]] = {}
    for path in (report, results / RESCORED):
        if not path.is_file():
            continue
        for r in read_rows(path):
            if r.suite in tier.suites and (r.method not in out or out[r.method][1] == path):
                out.setdefault(r.method, ([], path))[0].append(r)
    return out


def tier_entries(tier_name: str, results: Path = RESULTS,
                 submissions: Path | None = None) -> list[Entry]:  # fmt: skip
    """Every committed method on one tier: the searches, the learned methods, then the outside
    agents' submissions (``submissions``, default ``results/submissions``). On a fault tier the
    methods that cannot honour the failure are listed with the reason instead of numbers."""
    from modquad_gym.scoring.tiers import TIERS as TIER_TABLE
    from modquad_gym.scoring.tiers import get_tier, honours_fault
    from modquad_gym.search import SEARCHES

    tier = get_tier(tier_name)
    runs = one_run_rows(tier, results)
    full = len({r.task for r in in_scope(runs["exhaustive"][0], tier.n_max)})
    entries = []
    for m in SEARCHES:
        if tier.fault and not honours_fault(m):
            entries.append(unscored(tier, m, "search", FAULT_REFUSED))
        elif m in runs:
            rows, path = runs[m]
            entries.append(over_runs(tier, m, "search", {"-": rows}, _rel(path)))
    if tier.fault:
        entries += [unscored(tier, m, "learned", FAULT_LEARNED)
                    for m in TIER_TABLE["current"].learned]  # fmt: skip
    else:
        one = {m: over_runs(tier, m, "learned", {"-": runs[m][0]}, _rel(runs[m][1]))
               for m in tier.learned if m in runs}  # fmt: skip
        seeds = results / f"seeds_{tier.name}" / "seeds.csv"
        entries += over_seeds(read_seeds(seeds), tier, _rel(seeds), one)
    folder = results / SUBMISSIONS if submissions is None else submissions
    for path in sorted(folder.glob("*.csv")) if folder.is_dir() else []:
        entries += submission_entries(path, tier, full)
    return entries


def submission_entries(path: Path, tier, full: int) -> list[Entry]:
    """The outside agents of a submission file (:func:`write_submission`) on ``tier``."""
    with open(path, newline="") as fh:
        records = [r for r in csv.DictReader(fh) if r["tier"] == tier.name]
    out = []
    for method in dict.fromkeys(r["method"] for r in records):
        mine = [r for r in records if r["method"] == method]
        status = next((r["status"] for r in mine if r["status"]), "")
        if status:
            out.append(unscored(tier, method, "outside", status))
            continue
        rows = {s: [] for s in dict.fromkeys(r["seed"] for r in mine)}
        for row in _rows_of(mine):
            rows[row[0]].append(row[1])
        out.append(over_runs(tier, method, "outside", rows, _rel(path), full))
    return out


def _rows_of(records: list[dict]):
    """(seed, Row) of submission records."""
    from modquad_gym.scoring.scores import Row

    def num(v: str) -> int | None:
        return int(v) if v not in ("", None) else None

    for r in records:
        yield r["seed"], Row(r["suite"], r["task"], num(r["optimum"]), r["method"],
                             r["success"] == "1", num(r["n_modules"]), int(r["evaluated"]),
                             int(r["oracle_calls"]), float(r["seconds"]), None)  # fmt: skip


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


def made_by(path: Path) -> str:
    """The command a committed report names in its first lines ("Made by `...`")."""
    md = path.with_suffix(".md")
    if not md.is_file():
        return ""
    for line in md.read_text().splitlines()[:6]:
        if "Made by `" in line:
            return line.split("Made by `", 1)[1].split("`", 1)[0]
    return ""


def _rel(path: Path) -> str:
    try:
        return path.resolve().relative_to(ROOT).as_posix()
    except ValueError:
        return str(path)


# --- scoring what is not committed --------------------------------------------------------------
def rescore_searches(results: Path = RESULTS, progress: bool = True) -> Path:
    """Run the searches that a tier report did not run on that tier's held-out suites and write
    their per-task rows to ``results/leaderboard_searches.csv`` (on a fault tier, those that
    honour the failure)."""
    from modquad_gym.core.outputs import write_csv, write_text
    from modquad_gym.scoring.agents import run_benchmark
    from modquad_gym.scoring.tiers import get_tier, honours_fault
    from modquad_gym.search import SEARCHES

    rows = []
    for name in TIERS:
        tier = get_tier(name)
        have = {r.method for r in read_rows(results / f"tier_{name}" / "benchmark.csv")}
        missing = [m for m in SEARCHES if m not in have and (not tier.fault or honours_fault(m))]
        if missing:
            print(f"{name}: scoring {', '.join(missing)}", file=sys.stderr)
            rows += run_benchmark(tier.load_suites(), missing, tier.n_max, None, 0, progress, 1,
                                  tier.modules, tier.name, tier.fault)  # fmt: skip
    path = results / RESCORED
    write_csv([r.as_csv() for r in rows], path)
    write_text(path.with_suffix(".md"), rescored_note(rows))
    return path


def rescored_note(rows) -> str:
    """What ``results/leaderboard_searches.csv`` holds and how it was made (its provenance)."""
    from modquad_gym.scoring import machine_description

    suites: dict[tuple, list[str]] = {}  # the methods run -> the suites they ran on
    for suite in dict.fromkeys(r.suite for r in rows):
        methods = tuple(dict.fromkeys(r.method for r in rows if r.suite == suite))
        suites.setdefault(methods, []).append(f"`{suite}`")
    what = "; ".join(f"{', '.join(m)} on {', '.join(s)}" for m, s in suites.items())
    return "\n".join([
        "# Searches scored for the leaderboard",
        "",
        f"Made by `{COMMAND} --rescore-searches --force`. Machine: {machine_description()}.",
        "",
        "The searches that a one-run tier report did not run, on that tier's held-out suites, "
        f"one row per method and task in `{RESCORED}` (as `modquad score` writes "
        f"them): {what}.",
        "",
    ])  # fmt: skip


def anytime_history(results: Path = RESULTS, progress: bool = True) -> Path:
    """Run the anytime search on every tier's held-out tasks and write, per task, when its
    best structure so far first had the certified optimum's module count (its history's events) to
    ``results/leaderboard_anytime.csv``, with a note of the machine beside it."""
    from tqdm import tqdm

    from modquad_gym.core.outputs import write_csv, write_text
    from modquad_gym.scoring import machine_description
    from modquad_gym.scoring.tiers import get_tier
    from modquad_gym.search import anytime_search

    out = []
    for name in TIERS:
        tier = get_tier(name)
        jobs = [(s, t) for s, tasks in tier.load_suites().items() for t in tasks]
        for suite, task in tqdm(jobs, f"anytime history ({name})", disable=not progress):
            optimum = task.meta.get("optimum")
            r = anytime_search(task, n_max=tier.n_max, **tier.search_kwargs())
            at = [e.seconds for e in r.history if optimum is not None and e.n_modules == optimum]
            out.append({"tier": name, "suite": suite, "task": task.name, "optimum": optimum,
                        "in_scope": int(optimum is not None and optimum <= tier.n_max),
                        "n_modules": r.n_modules, "certified": int(r.certified),
                        "seconds": f"{r.seconds:.5f}",
                        "optimal_at": f"{min(at):.5f}" if at else "",
                        "history": ";".join(f"{e.seconds:.5f}:{e.lower_bound}:{e.n_modules}"
                                            for e in r.history)})  # fmt: skip
    path = results / ANYTIME
    write_csv(out, path)
    write_text(path.with_suffix(".md"), "\n".join([
        "# The anytime search's history on the tiers' held-out tasks",
        "",
        f"Made by `{COMMAND} --anytime-history --force`. Machine: {machine_description()}.",
        "",
        "Per task (one row in `leaderboard_anytime.csv`): the anytime search's answer, its wall "
        "time, `optimal_at` (the seconds after which its best structure so far had the "
        "certified optimum's module count) and its `history` (seconds:lower bound:best "
        "structure's modules per event).",
        "",
    ]))  # fmt: skip
    return path


def _takes_seed(agent) -> bool:
    """Is the outside agent made with a ``seed`` (its class's constructor takes one)?"""
    if inspect.isfunction(agent) or inspect.ismethod(agent):
        return False
    try:
        params = inspect.signature(type(agent)).parameters.values()
    except (TypeError, ValueError):
        return False
    return any(p.name == "seed" or p.kind == p.VAR_KEYWORD for p in params)


def _one_line(err: BaseException) -> str:
    text = str(err).strip().splitlines()
    return f"{type(err).__name__}: {text[0] if text else ''}"


def score_agent(spec: str, tiers: Iterable[str], limit: int | None, seeds: list[int],
                progress: bool) -> list[dict]:  # fmt: skip
    """An outside agent on every tier's held-out suites (the first ``limit`` tasks of each),
    once per seed of ``seeds`` (once when the agent takes no seed): the submission's records
    (:func:`write_submission`), one per (tier, seed, task), the agent's own ``name`` as its
    method. A tier where the agent fails is one record with the failure in ``status``; the
    other tiers go on. An import error is a ValueError before any work."""
    from modquad_gym.scoring.agents import run_benchmark
    from modquad_gym.scoring.tiers import get_tier
    from modquad_gym.solvers import load_solver

    first = load_solver(spec, seed=seeds[0])  # a bad spec fails now, before any work
    name = first.name
    runs = seeds if _takes_seed(first.agent) else seeds[:1]
    records: list[dict] = []
    for tier_name in tiers:
        tier = get_tier(tier_name)
        status = {"tier": tier.name, "seed": "", "method": name, "status": ""}
        try:
            mine = []
            for seed in runs:
                rows = run_benchmark(tier.load_suites(limit), [spec], tier.n_max, None, seed,
                                     progress, 1, tier.modules, tier.name,
                                     tier.fault)  # fmt: skip
                mine += [{"tier": tier.name, "seed": str(seed), **r.as_csv(), "method": name,
                          "status": ""} for r in rows]  # fmt: skip
            records += mine
        except Exception as err:  # the agent's failure on this tier; the others go on
            print(f"{tier.name}: {name} failed: {_one_line(err)}", file=sys.stderr)
            records.append({**status, "status": f"failed: {_one_line(err)}"})
    return records


SUBMISSION_KEYS = ("tier", "seed", "method", "status", "suite", "task", "optimum", "success",
                   "n_modules", "gap", "optimal", "evaluated", "oracle_calls", "seconds",
                   "cells")  # fmt: skip


def write_submission(records: list[dict], path: Path) -> Path:
    """The submission file: one row per (tier, seed, task) as ``modquad score`` writes its rows,
    with the tier, the seed and ``status`` (a tier not scored: one row saying why)."""
    from modquad_gym.core.outputs import write_csv

    write_csv([{k: r.get(k, "") for k in SUBMISSION_KEYS} for r in records], path)
    return path


# --- writing ----------------------------------------------------------------------------------
def _pct(v: T3, interval: bool) -> str:
    if not interval or v[1] == v[2]:
        return f"{100 * v[0]:.1f} %"
    return f"{100 * v[0]:.1f} % [{100 * v[1]:.1f}, {100 * v[2]:.1f}]"


def _num(v: T3, interval: bool, fmt: str) -> str:
    if not interval or v[1] == v[2]:
        return format(v[0], fmt)
    return f"{format(v[0], fmt)} [{format(v[1], fmt)}, {format(v[2], fmt)}]"


def _label(e: Entry) -> str:
    if e.kind == "learned" and e.seeds:
        return f"{e.method} ({e.seeds} seeds)"
    if e.kind == "outside":
        runs = f", {e.seeds} seed{'s' if e.seeds != 1 else ''}" if e.seeds else ""
        return f"**{e.method}** (outside{runs})"
    return e.method


def ranked(entries: list[Entry]) -> list[Entry]:
    """Scored entries by optimal share within the budget (then success, fewer seconds), then
    the unscored ones."""
    scored = [e for e in entries if not e.status]
    scored.sort(key=lambda e: (-e.budget[0], -e.optimal[0], e.seconds[0]))
    return scored + [e for e in entries if e.status]


def tier_table(entries: list[Entry]) -> list[str]:
    """One tier's methods ranked at the budget; every row with its task count and seeds."""
    head = (f"| rank | method | tasks | optimal within {BUDGET:g} s | success | optimal share | "
            "mean modules | configs / task | oracle calls / task | seconds / task |")  # fmt: skip
    lines = [head, "|---|---|---|---|---|---|---|---|---|---|"]
    rank = 0
    for e in ranked(entries):
        if e.status:
            lines.append(f"| - | {_label(e)} | - | {e.status} | | | | | | |")
            continue
        rank += 1
        ci = e.seeds > 1
        one = " ‡" if any(n.startswith("one run:") for n in e.notes) else ""
        mark = " †" if any(n.startswith("modules:") for n in e.notes) else ""
        modules = "-" if e.modules is None else f"{e.modules:.2f}{mark}"
        tasks = f"{e.tasks}" if e.tasks >= e.full else f"{e.tasks} of {e.full} (partial)"
        lines.append(
            f"| {rank} | {_label(e)} | {tasks} | {_pct(e.budget, ci)}{one} | "
            f"{_pct(e.success, ci)} | {_pct(e.optimal, ci)} | {modules} | "
            f"{_num(e.evaluated, ci, '.1f')} | {_num(e.oracle_calls, ci, ',.0f')}{one} | "
            f"{_num(e.seconds, ci, '.3f')} |"
        )
    return lines


def glance(entries: list[Entry], tiers: list[str]) -> list[str]:
    """Optimal share (and within the budget) of every method on every tier."""
    methods = list(dict.fromkeys(e.method for e in entries))
    by = {(e.tier, e.method): e for e in entries}
    lines = ["| method | " + " | ".join(f"`{t}`" for t in tiers) + " |",
             "|---|" + "---|" * len(tiers)]  # fmt: skip
    for method in methods:
        cells = []
        for t in tiers:
            e = by.get((t, method))
            if e is None:
                cells.append("-")
            elif e.status:
                cells.append(e.status.partition(":")[0])
            else:
                part = "" if e.tasks >= e.full else f", {e.tasks} of {e.full} tasks"
                cells.append(f"{100 * e.optimal[0]:.1f} % ({100 * e.budget[0]:.1f} % within "
                             f"{BUDGET:g} s{part})")  # fmt: skip
        first = next(e for e in entries if e.method == method)
        lines.append(f"| {_label(first)} | " + " | ".join(cells) + " |")
    return lines


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


SCALE_REPORTS = {"default recipe": "scale_seeds", "+ expert iteration": "scale_seeds_exit"}
"""The five-seed scale reports (``python -m benchmarks.scale_seeds``): the default recipe's seeds,
and the same seeds after expert iteration at 8-32 modules (the shipped ``ppo_scale``'s recipe)."""


def scale_section(results_prefix: str, results: Path = RESULTS) -> list[str]:
    """The learned designer at 16-64 modules beside greedy, per band, from the five-seed scale
    reports' summaries ([] when they are not there)."""
    files = {k: results / v / "report.csv" for k, v in SCALE_REPORTS.items()}
    read = {k: {r["band"]: r for r in csv.DictReader(f.read_text().splitlines())}
            for k, f in files.items() if f.is_file()}  # fmt: skip
    if not read:
        return []
    columns = {"ppo_solves_greedys_pct": "greedy's tasks ppo solves, %",
               "ppo_minus_greedy_modules": "modules above greedy",
               "ppo_over_greedy_seconds": "time / greedy's"}  # fmt: skip
    head = ["band"] + [f"{c} ({k})" for c in columns.values() for k in read]
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for band in next(iter(read.values())):
        cells = [read[k].get(band, {}).get(c, "-") for c in columns for k in read]
        lines.append(f"| {band} | " + " | ".join(cells) + " |")
    sources = "; ".join(f"`{results_prefix}{v}/report.md`" for v in SCALE_REPORTS.values())
    return [
        "## At the field's sizes (16-64 modules)",
        "",
        "Single-pass `ppo` over five training seeds on the 36 held-out scale tasks (planted, "
        "mixed palette, heavy payload, low force with high torque; 12 per band), beside greedy "
        "with the same 30 s limit, which solves all of them: the share of greedy's tasks it "
        "solves, its modules above greedy's where both solve and its wall time over greedy's "
        "(mean over seeds, 95 % bootstrap interval). Every method at 16-128 modules: "
        f"`{results_prefix}scale/report.md`.",
        "",
        *lines,
        "",
        f"Sources: {sources}.",
        "",
    ]


def page(entries: list[Entry], tiers: list[str], image: str, results_prefix: str) -> str:
    """The leaderboard in Markdown; ``image`` is the plot's path from the page (the anytime
    curves lie beside it), ``results_prefix`` the path of ``results/`` files as written in the
    text."""
    r = results_prefix
    text = page_intro(entries, tiers, image)
    for t in tiers:
        mine = [e for e in entries if e.tier == t]
        if mine:
            text += tier_section(t, mine, r)
    text += scale_section(r)
    text += how_made(r)
    text += how_to_add(r)
    return "\n".join(text)


def page_intro(entries: list[Entry], tiers: list[str], image: str) -> list[str]:
    """The page's head: what is ranked and how, the at-a-glance table and both plots."""
    curves_image = image.replace("leaderboard.png", "leaderboard_anytime.png")
    return [
        "# Leaderboard",
        "",
        f"Made by `{COMMAND}` from the committed reports (every number below is read from their "
        "data files; none is typed by hand). Add your own agent: "
        "[below](#add-your-own-agent).",
        "",
        f"Every method on the held-out suites of the {len(tiers)} benchmark tiers, against each "
        "task's certified optimum (the exhaustive search's minimum module count), **ranked at "
        f"a time budget of {BUDGET:g} s per task**: the share of tasks a method answers with "
        f"the optimal module count within {BUDGET:g} s of wall time (every method gets the same "
        "budget). Beside it: success (an answer of at most the tier's n_max modules that the "
        "exact LP oracle verifies), the optimal share without a time limit, mean modules over "
        "the tasks solved, configurations evaluated (structures whose feasibility was decided), "
        "oracle calls (wrench-structure tests) and seconds per task, and the number of tasks "
        "each row was scored on. Learned methods and outside agents with several seeds: mean "
        "over the seeds with the 95 % bootstrap interval over seeds in brackets; searches: one "
        "run.",
        "",
        "## At a glance",
        "",
        f"Optimal share per tier (in brackets: within {BUDGET:g} s per task, the rank's "
        "measure); learned methods: mean over five seeds:",
        "",
        "<!-- --8<-- [start:glance] -->",
        *glance(entries, tiers),
        "<!-- --8<-- [end:glance] -->",
        "",
        f"![optimal share against seconds per task, per tier]({image})",
        "",
        f"The share of tasks answered optimally within t seconds, against t ({BUDGET:g} s "
        "dotted): each method's one run, and the anytime search's best structure so far "
        "(dashed), which reaches the optimum before it has proved it:",
        "",
        f"![tasks answered optimally within a time budget, per tier]({curves_image})",
        "",
    ]


def tier_section(t: str, mine: list[Entry], r: str) -> list[str]:
    """One tier's section: what the tier is, its ranked table, its footnotes and sources
    (``r``: the path of ``results/`` as written in the text)."""
    from modquad_gym.scoring.tiers import get_tier

    tier = get_tier(t)
    types = f"module types {tier.modules}" if tier.modules else "one module type"
    tasks = max(e.full for e in mine if not e.status)
    fault = (f", `fault=\"{tier.fault}\"`: an answer counts only when it still exerts every "
             f"task wrench after any single {tier.fault} failure, and the optimum is the "
             "smallest such structure" if tier.fault else "")  # fmt: skip
    text = [
        f"## Tier `{t}`",
        "",
        f"`{tier.env_id}`, {types}, n_max {tier.n_max}{fault}; held-out suites "
        f"{', '.join(f'`{s}`' for s in tier.suites)}: {tasks} tasks whose certified optimum "
        f"is within n_max.{_models(tier)}",
        "",
        *tier_table(mine),
        "",
        *tier_footnotes(mine, r),
    ]
    sources = dict.fromkeys(e.source for e in mine if e.source)
    return text + ["Sources: " + "; ".join(_source(s, r) for s in sources) + ".", ""]


FOOTNOTES = (
    ("one run: ", "‡ The shipped model's one run ({where}): the five-seed data file holds no "
     "per-task seconds or oracle calls (its optimal share may differ from the five seeds' mean)."),
    ("modules: ", "† Mean modules of the shipped model's one run ({where}): the five-seed data "
     "file predates its modules column."),
)  # fmt: skip
"""(the prefix of an entry's note that names a file, the footnote it gives) of a tier's rows
that take a column from the shipped model's one run."""


def tier_footnotes(mine: list[Entry], r: str) -> list[str]:
    """The ‡ and † notes of a tier whose learned rows take a column from the shipped model's
    one run (the five-seed data files lack it)."""
    text = []
    for prefix, note in FOOTNOTES:
        paths = sorted({n.removeprefix(prefix) for e in mine for n in e.notes
                        if n.startswith(prefix)})  # fmt: skip
        if paths:
            where = "; ".join(f"`{r}{p.removeprefix('results/')}`" for p in paths)
            text += [note.format(where=where), ""]
    return text


def how_made(r: str) -> list[str]:
    """The page's section on where each number comes from (``r``: the path of ``results/``
    as written in the text)."""
    return [
        "## How the numbers are made",
        "",
        f"- **The budget**: a task counts within {BUDGET:g} s when the method's answer has the "
        f"optimal module count and its wall time on the task was at most {BUDGET:g} s (one "
        "run per task, without a time limit: a slower answer counts as none, as it would under "
        "the limit). Ties are broken by the optimal share without a limit, then by fewer "
        "seconds.",
        "- **Learned methods** (`ppo`: one deterministic pass of the shipped policy; `ppo-k8`: "
        "eight sampled rollouts more; `ppo-guided`: best-first search ordered by the policy, "
        "certified at the lower bound): the five-seed reports "
        f"`{r}seeds_<tier>/seeds.csv`, one row per (seed, method, suite). Each seed's success, "
        "optimal share, configurations and seconds are pooled over the tier's tasks (suites "
        "weighted by their size), then averaged over the seeds; the interval is the 95 % "
        "percentile bootstrap over seeds (2,000 resamples, seeded). The seeds reports "
        f"(`{r}seeds_<tier>/seeds.md`) give the interquartile mean over seeds x suites and "
        "judge the tiers' goals. The five-seed files hold no per-task seconds or oracle calls: "
        "those two columns (‡) are the shipped model's one run in the tier report.",
        f"- **Searches**: the one-run tier reports `{r}tier_<tier>/benchmark.csv` (one row per "
        f"task), and `{r}{RESCORED}` for the searches a tier report did not run "
        f"(`{COMMAND} --rescore-searches --force`). `random` and `genetic` are seeded (seed 0).",
        "- **The fault tier**: only the methods that guarantee an answer surviving the failure "
        "are scored, and an answer counts only when it survives; milp refuses `fault=` and the "
        "learned policies were trained without failures: their rows say so in place of "
        "numbers. An outside agent is handed the problem with its fault and an evaluator that "
        "decides survival.",
        f"- **Anytime curves**: from the same per-task rows; the anytime search's history "
        f"(`{r}{ANYTIME}`, `{COMMAND} --anytime-history --force`) gives when its best structure so "
        "far first had the optimal count.",
        "- **Seconds** are wall time per task on the machine each source names (2 shared "
        "cores, no GPU): compare them within a tier, with care.",
        "",
    ]


def how_to_add(prefix: str) -> list[str]:
    """The page's section on adding a row: what to run, what to submit, how it is merged."""
    return [
        "## Add your own agent",
        "",
        "An agent is a class (or function) with `solve(task, evaluator)` that returns a "
        "structure; it is told each tier's `n_max`, `tier`, `modules` and the run's `seed` "
        "when its constructor takes them, and is counted through the evaluator it is handed: "
        "the protocol is in [Benchmark tiers and agents]("
        + ("" if prefix else "../docs/")
        + "benchmarks.md#score-your-own-agent). Its row is named by its own `name` attribute.",
        "",
        "**From the installed wheel** (no clone), score it on one tier beside the searches:",
        "",
        "```bash",
        "modquad score --tier current --solver my_agent:Agent --seed 0 --out my_scores",
        "```",
        "",
        "**A leaderboard row** needs a clone of the repository (`benchmarks/` is not in the "
        "wheel):",
        "",
        "```bash",
        f"{COMMAND} --solver my_agent:Agent --out my_board",
        "```",
        "",
        "scores it on every tier's held-out suites, once per seed (`--seeds`, default five "
        "like the learned methods; once when its constructor takes no `seed`), and writes "
        f"`my_board/leaderboard.md` with its rows ranked among the committed ones and "
        f"`my_board/{SUBMISSION}`: one row per (tier, seed, task). `--limit N` scores the first "
        "N tasks of each suite (the row is marked partial, with its task count); `--tiers` "
        "some tiers; a tier where the agent fails is reported as failed and the others are "
        "kept.",
        "",
        f"**To submit it**, open a pull request that adds `{SUBMISSION}` as "
        f"`results/{SUBMISSIONS}/<your agent>.csv`; the maintainers check it and rebuild the "
        f"page with `{COMMAND} --force`, which reads every file of `results/{SUBMISSIONS}/` "
        "(no rerun: the rows are the submitted ones, seconds on the submitter's machine).",
        "",
    ]


def _models(tier) -> str:
    """Where the tier's learned methods come from, in a sentence (or nothing)."""
    if tier.model_tier:
        return (f" The learned methods are the `{tier.model_tier}` tier's models (its recipe's "
                "five training seeds), acting here zero-shot.")  # fmt: skip
    return ""


def _source(source: str, prefix: str) -> str:
    if not source.startswith("results/"):
        return source
    command = made_by(ROOT / source)
    if source.endswith(RESCORED):
        command = f"{COMMAND} --rescore-searches --force"
    shown = f"`{prefix}{source.removeprefix('results/')}`"
    return shown + (f" (`{command}`)" if command else "")


def build(tiers: list[str], out: Path, docs: Path | None, records: list[dict] | None = None,
          results: Path = RESULTS) -> Path:  # fmt: skip
    """Write the leaderboard of the committed entries into ``out`` (and the documentation page
    into ``docs``); ``records`` (an outside agent scored now) are written as ``out``'s
    submission file and ranked beside them."""
    from modquad_gym.core.outputs import write_csv, write_text
    from modquad_gym.scoring.tiers import get_tier

    entries = [e for t in tiers for e in tier_entries(t, results)]
    if records:
        path = write_submission(records, out / SUBMISSION)
        for t in tiers:
            full = max((e.full for e in entries if e.tier == t and not e.status), default=0)
            entries += submission_entries(path, get_tier(t), full)
    write_csv([e.as_csv() for e in entries], out / "leaderboard.csv")
    history = read_anytime(results / ANYTIME)
    series = {}
    for t in tiers:
        tier = get_tier(t)
        by = {m: rows for m, (rows, _) in one_run_rows(tier, results).items()}
        series[t] = curves(tier, by, history.get(t, []))
    plot(entries, tiers, out / "leaderboard.png")
    plot_curves(series, BUDGET, out / "leaderboard_anytime.png")
    path = write_text(out / "leaderboard.md", page(entries, tiers, "leaderboard.png", ""))
    if docs is not None:
        write_text(docs / "leaderboard.md", page(entries, tiers, "results/leaderboard.png",
                                                 "results/"))  # fmt: skip
    return path


def main(argv: list[str] | None = None) -> int:
    p = parser()
    args = p.parse_args(argv)
    check_args(p, args)
    try:
        records = first_runs(args)
    except ValueError as err:
        p.error(str(err))
    except KeyboardInterrupt:
        print(f"{COMMAND}: interrupted; nothing written", file=sys.stderr)
        return 130
    out = args.out or RESULTS
    docs = DOCS if args.out is None else None
    path = build(args.tiers, out, docs, records)
    print(path.read_text())
    return 0


def parser() -> argparse.ArgumentParser:
    """The command's options: what to run first, an outside agent to score, where to write."""
    from modquad_gym.core.options import int_option

    p = argparse.ArgumentParser(prog=COMMAND, description=__doc__.split("\n\n")[0])
    p.add_argument(
        "--rescore-searches",
        action="store_true",
        help=f"first run the searches the tier reports lack into results/{RESCORED}",
    )
    p.add_argument(
        "--anytime-history",
        action="store_true",
        help=f"first run the anytime search on every tier's tasks into results/{ANYTIME}",
    )
    p.add_argument(
        "--solver",
        metavar="PKG.MOD:NAME",
        default=None,
        help="also score this outside agent on every tier (needs --out; a clone of the "
        "repository: `modquad score --solver` works from the wheel, one tier at a time)",
    )
    p.add_argument(
        "--seeds",
        nargs="+",
        type=int_option(0),
        default=[0, 1, 2, 3, 4],
        help="with --solver: the seeds it is run with (one run when it takes no seed)",
    )
    p.add_argument(
        "--tiers", nargs="+", choices=TIERS, default=list(TIERS), help="tiers to show (default all)"
    )
    p.add_argument(
        "--limit",
        type=int_option(1),
        default=None,
        help="with --solver: the first N tasks of each suite (the row is marked partial)",
    )
    p.add_argument(
        "--out",
        type=Path,
        default=None,
        help="folder for the leaderboard (default: results/ and docs/leaderboard.md; "
        "required with --solver, so the committed page stays the committed data's)",
    )
    p.add_argument(
        "--force",
        action="store_true",
        help="replace the leaderboard's files in --out (without --out: the committed pages "
        "results/leaderboard.*, docs/leaderboard.md and, with --rescore-searches or "
        f"--anytime-history, results/{RESCORED} or results/{ANYTIME}); default: refuse",
    )
    p.add_argument("--no-progress", action="store_true")
    return p


def check_args(p: argparse.ArgumentParser, args: argparse.Namespace) -> None:
    """Options that do not go together, and every file the run would write, checked before
    any work (``p.error``: one line, exit 2)."""
    from modquad_gym.core.outputs import check_output_dir

    if args.solver and args.out is None:
        p.error("--solver needs --out: the committed leaderboard holds committed data only")
    if args.out is None and sorted(args.tiers) != sorted(TIERS):
        p.error("--tiers needs --out: the committed leaderboard holds every tier")
    if args.limit is not None and not args.solver:
        p.error("--limit goes with --solver")
    if len(set(args.seeds)) != len(args.seeds):
        p.error(f"--seeds: a seed is given twice: {args.seeds}")
    written = OUTPUTS if args.solver else OUTPUTS[:-1]
    try:
        if args.out is None:
            check_output_dir(RESULTS, written, args.force)
            check_output_dir(DOCS, ("leaderboard.md",), args.force)
            data = (RESCORED,) * args.rescore_searches + (ANYTIME,) * args.anytime_history
            check_output_dir(RESULTS, data, args.force)
        else:
            check_output_dir(args.out, written, args.force)
    except ValueError as err:
        p.error(str(err))


def first_runs(args: argparse.Namespace) -> list[dict] | None:
    """The runs asked for before the page is built: the rescored searches, the anytime
    history, and the outside agent's records (None without ``--solver``)."""
    if args.rescore_searches:
        print(rescore_searches(progress=not args.no_progress))
    if args.anytime_history:
        print(anytime_history(progress=not args.no_progress))
    if not args.solver:
        return None
    return score_agent(args.solver, args.tiers, args.limit, args.seeds, not args.no_progress)


if __name__ == "__main__":
    from benchmarks.common import run_main

    raise SystemExit(run_main(main, "leaderboard"))
