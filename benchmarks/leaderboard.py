"""The leaderboard: every method on every benchmark tier, from the committed reports.

    python -m benchmarks.leaderboard --force

reads the committed data files and writes ``results/leaderboard.md``, ``results/leaderboard.csv``,
``results/leaderboard.png`` and the documentation page ``docs/leaderboard.md`` (no number is
typed by hand):

* the learned methods over five training seeds from ``results/seeds_<tier>/seeds.csv`` (one row
  per seed, method and suite): each seed's scores pooled over the tier's held-out tasks, the
  mean over seeds with a 95 % percentile bootstrap interval over seeds;
* the searches (one deterministic run; random and genetic seeded) from the one-run tier reports
  ``results/tier_<tier>/benchmark.csv`` (one row per method and task), and, for the searches a
  tier report did not run, from ``results/leaderboard_searches.csv``, which
  ``python -m benchmarks.leaderboard --rescore-searches --force`` fills by running just those
  searches on the tier's held-out suites (seconds, not hours: no training, no learned method).

Add your own agent (scored now on every tier, beside the committed rows; nothing committed
changes)::

    python -m benchmarks.leaderboard --solver my_agent:Agent --out my_board

It follows the protocol of ``modquad score --solver`` (docs/benchmarks.md, "Score your own
agent"): told each tier's n_max, counted through the evaluator it is handed.
"""

from __future__ import annotations

import argparse
import csv
import sys
from collections.abc import Iterable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
RESULTS = ROOT / "results"
DOCS = ROOT / "docs"
COMMAND = "python -m benchmarks.leaderboard"
TIERS = ("current", "large", "mixed", "dynamic")
RESCORED = "leaderboard_searches.csv"
"""The searches a tier report did not run, scored by ``--rescore-searches`` (in results/)."""
OUTPUTS = ("leaderboard.md", "leaderboard.csv", "leaderboard.png")


@dataclass
class Entry:
    """One method on one tier: each metric as (point, low, high) (low = high = point for one
    run); ``modules`` the mean module count over the solved tasks."""

    tier: str
    method: str
    kind: str  # "search", "learned" or "yours"
    tasks: int
    seeds: int
    success: tuple[float, float, float]
    optimal: tuple[float, float, float]
    evaluated: tuple[float, float, float]
    seconds: tuple[float, float, float]
    modules: float | None
    source: str
    notes: list[str] = field(default_factory=list)

    def as_csv(self) -> dict:
        out = {"tier": self.tier, "method": self.method, "kind": self.kind, "tasks": self.tasks,
               "seeds": self.seeds}  # fmt: skip
        for name in ("success", "optimal", "evaluated", "seconds"):
            point, low, high = getattr(self, name)
            out |= {
                name: f"{point:.6g}",
                f"{name}_low": f"{low:.6g}",
                f"{name}_high": f"{high:.6g}",
            }
        out["modules"] = "" if self.modules is None else f"{self.modules:.6g}"
        out["source"] = self.source
        out["notes"] = "; ".join(self.notes)
        return out


def _point(v: float) -> tuple[float, float, float]:
    return (float(v), float(v), float(v))


# --- reading the committed data ---------------------------------------------------------------
def read_rows(path: Path):
    """The per-task rows (:class:`~modquad_gym.scoring.scores.Row`) of a benchmark CSV."""
    from modquad_gym.scoring.scores import Row

    def num(v: str) -> int | None:
        return int(v) if v not in ("", None) else None

    with open(path, newline="") as fh:
        return [
            Row(r["suite"], r["task"], num(r["optimum"]), r["method"], r["success"] == "1",
                num(r["n_modules"]), int(r["evaluated"]), int(r["oracle_calls"]),
                float(r["seconds"]), None)
            for r in csv.DictReader(fh)
        ]  # fmt: skip


def one_run(rows, tier, methods: Iterable[str], kind: str, source: str) -> list[Entry]:
    """Entries of ``methods`` from one run's per-task rows (the tasks whose optimum is within
    the tier's n_max, as every report of the project counts them)."""
    from modquad_gym.scoring.scores import summarise

    out = []
    for s in summarise(rows, list(methods), tier.n_max):
        out.append(Entry(tier.name, s["method"], kind, s["tasks"], 1, _point(s["success_rate"]),
                         _point(s["optimal_share"]), _point(s["mean_evaluated"]),
                         _point(s["mean_seconds"]), s["mean_modules"], source))  # fmt: skip
    return out


def read_seeds(path: Path) -> list[dict]:
    with open(path, newline="") as fh:
        return list(csv.DictReader(fh))


def over_seeds(records: list[dict], tier, source: str, fallback: dict) -> list[Entry]:
    """The learned methods of a five-seed report: per seed, each metric pooled over the tier's
    tasks (suites weighted by their task counts); the mean over seeds with its 95 % percentile
    bootstrap interval (:func:`modquad_gym.scoring.seeds.interval`, seeds resampled). Mean
    modules from the report where it holds them, else ``fallback`` (method -> (value, where))."""
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
        notes = []
        if len(modules) == len(seeds):
            mean_modules = float(np.mean(modules))
        else:
            mean_modules, where = fallback.get(method, (None, ""))
            if mean_modules is not None:
                notes.append(f"modules: {where}")
        out.append(Entry(tier.name, method, "learned", tasks, len(seeds), stats["success"],
                         stats["optimal"], stats["evaluated"], stats["seconds"], mean_modules,
                         source, notes))  # fmt: skip
    return out


def tier_entries(tier_name: str, results: Path = RESULTS) -> list[Entry]:
    """Every committed method on one tier: the searches, then the learned methods."""
    from modquad_gym.scoring.tiers import get_tier
    from modquad_gym.search import SEARCHES

    tier = get_tier(tier_name)
    report = results / f"tier_{tier.name}" / "benchmark.csv"
    seeds = results / f"seeds_{tier.name}" / "seeds.csv"
    rows = read_rows(report)
    entries = one_run(rows, tier, SEARCHES, "search", _rel(report))
    missing = [m for m in SEARCHES if m not in {e.method for e in entries}]
    rescored = results / RESCORED
    if missing and rescored.is_file():
        extra = [r for r in read_rows(rescored) if r.suite in tier.suites]
        entries += one_run(extra, tier, missing, "search", _rel(rescored))
    fallback = {e.method: (e.modules, _rel(report))
                for e in one_run(rows, tier, tier.learned, "learned", "")}  # fmt: skip
    entries += over_seeds(read_seeds(seeds), tier, _rel(seeds), fallback)
    order = [*SEARCHES, *tier.learned]
    return sorted(entries, key=lambda e: order.index(e.method) if e.method in order else 99)


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
    their per-task rows to ``results/leaderboard_searches.csv``."""
    from modquad_gym.core.outputs import write_csv, write_text
    from modquad_gym.scoring.agents import run_benchmark
    from modquad_gym.scoring.tiers import get_tier
    from modquad_gym.search import SEARCHES

    rows = []
    for name in TIERS:
        tier = get_tier(name)
        have = {r.method for r in read_rows(results / f"tier_{name}" / "benchmark.csv")}
        missing = [m for m in SEARCHES if m not in have]
        if missing:
            print(f"{name}: scoring {', '.join(missing)}", file=sys.stderr)
            rows += run_benchmark(tier.load_suites(), missing, tier.n_max, None, 0, progress, 1,
                                  tier.modules, tier.name)  # fmt: skip
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
        f"Made by `{COMMAND} --rescore-searches`. Machine: {machine_description()}.",
        "",
        "The searches that a one-run tier report did not run, on that tier's held-out suites, "
        f"one row per method and task in `{RESCORED}` (as `modquad score` writes "
        f"them): {what}.",
        "",
    ])  # fmt: skip


def score_agent(spec: str, tiers: Iterable[str], limit: int | None, progress: bool) -> list[Entry]:
    """An outside agent on every tier's held-out suites (first ``limit`` tasks of each), one run."""
    from modquad_gym.geometry.module import palette
    from modquad_gym.scoring.agents import run_benchmark
    from modquad_gym.scoring.tiers import get_tier
    from modquad_gym.solvers import load_solver

    out = []
    for name in tiers:
        tier = get_tier(name)
        types = palette(tier.modules) if tier.modules else None
        load_solver(spec, n_max=tier.n_max, tier=tier.name, modules=types)  # fails before work
        rows = run_benchmark(tier.load_suites(limit), [spec], tier.n_max, None, 0, progress, 1,
                             tier.modules, tier.name)  # fmt: skip
        source = "scored now" + (f", first {limit} tasks of each suite" if limit else "")
        out += one_run(rows, tier, [spec], "yours", source)
    return out


# --- writing ----------------------------------------------------------------------------------
def _pct(v: tuple[float, float, float], interval: bool) -> str:
    if not interval:
        return f"{100 * v[0]:.1f} %"
    return f"{100 * v[0]:.1f} % [{100 * v[1]:.1f}, {100 * v[2]:.1f}]"


def _num(v: tuple[float, float, float], interval: bool, fmt: str) -> str:
    if not interval:
        return format(v[0], fmt)
    return f"{format(v[0], fmt)} [{format(v[1], fmt)}, {format(v[2], fmt)}]"


def _label(e: Entry) -> str:
    if e.kind == "learned":
        return f"{e.method} ({e.seeds} seeds)"
    if e.kind == "yours":
        return f"**{e.method}** (yours)"
    return e.method


def tier_table(entries: list[Entry]) -> list[str]:
    lines = [
        "| method | success | optimal share | mean modules | configs / task | seconds / task |",
        "|---|---|---|---|---|---|",
    ]
    for e in entries:
        ci = e.kind == "learned"
        mark = " †" if any(n.startswith("modules:") for n in e.notes) else ""
        modules = "-" if e.modules is None else f"{e.modules:.2f}{mark}"
        lines.append(
            f"| {_label(e)} | {_pct(e.success, ci)} | {_pct(e.optimal, ci)} | {modules} | "
            f"{_num(e.evaluated, ci, '.1f')} | {_num(e.seconds, ci, '.3f')} |"
        )
    return lines


def glance(entries: list[Entry], tiers: list[str]) -> list[str]:
    """Optimal share (success) of every method on every tier: one table."""
    methods = list(dict.fromkeys(e.method for e in entries))
    by = {(e.tier, e.method): e for e in entries}
    lines = ["| method | " + " | ".join(f"`{t}`" for t in tiers) + " |",
             "|---|" + "---|" * len(tiers)]  # fmt: skip
    for method in methods:
        cells = []
        for t in tiers:
            e = by.get((t, method))
            cells.append("-" if e is None else
                         f"{100 * e.optimal[0]:.1f} % ({100 * e.success[0]:.0f} %)")  # fmt: skip
        first = next(e for e in entries if e.method == method)
        lines.append(f"| {_label(first)} | " + " | ".join(cells) + " |")
    return lines


def plot(entries: list[Entry], tiers: list[str], path: Path) -> Path:
    """Per tier: optimal share against configurations per task (log), learned methods with
    their 95 % intervals over seeds; methods at the same point share one label."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    from modquad_gym.core.outputs import save_figure

    cols = min(2, len(tiers))
    rows = -(-len(tiers) // cols)
    fig = Figure(figsize=(6.2 * cols, 4.6 * rows), layout="constrained")
    FigureCanvasAgg(fig)
    colours = {"search": "#555555", "learned": "#4c72b0", "yours": "#dd8452"}
    for i, t in enumerate(tiers):
        ax = fig.add_subplot(rows, cols, i + 1)
        points: dict[tuple, list[Entry]] = {}
        for e in (e for e in entries if e.tier == t):
            x, y = e.evaluated[0], 100 * e.optimal[0]
            xerr = [[x - e.evaluated[1]], [e.evaluated[2] - x]]
            yerr = [[y - 100 * e.optimal[1]], [100 * e.optimal[2] - y]]
            ax.errorbar(x, y, xerr=xerr, yerr=yerr, fmt="o", color=colours[e.kind], ms=5,
                        capsize=2)  # fmt: skip
            points.setdefault((round(np.log10(x), 2), round(y, 1)), []).append(e)
        placed: list[tuple[float, float]] = []  # label anchors (log x, y) already used
        for (lx, y), group in sorted(points.items(), key=lambda kv: (-kv[0][1], kv[0][0])):
            label = " = ".join(e.method.rpartition(":")[2] for e in group)
            near = sum(abs(lx - px) < 0.35 and abs(y - py) < 6 for px, py in placed)
            placed.append((lx, y))
            ax.annotate(label, (10**lx, y), textcoords="offset points", xytext=(5, 3 - 10 * near),
                        fontsize=8, color=colours[group[0].kind])  # fmt: skip
        ax.set_xscale("log")
        ax.set_ylim(-3, 106)
        ax.set_title(f"tier {t}")
        ax.set_xlabel("configurations evaluated / task (log)")
        ax.set_ylabel("optimal module count (% of tasks)")
        ax.grid(alpha=0.3)
    return save_figure(fig, path, dpi=100)


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
    """The leaderboard in Markdown; ``image`` is the plot's path from the page,
    ``results_prefix`` the path of ``results/`` files as written in the text."""
    from modquad_gym.scoring.tiers import get_tier

    r = results_prefix
    text = [
        "# Leaderboard",
        "",
        f"Made by `{COMMAND}` from the committed reports (every number below is read from their "
        "data files; none is typed by hand). Add your own agent with one command: "
        "[below](#add-your-own-agent).",
        "",
        "Every method on the held-out suites of the four benchmark tiers, against each task's "
        "certified optimum (the exhaustive search's minimum module count). Success: an answer "
        "of at most the tier's n_max modules that the exact LP oracle verifies; optimal share: "
        "an answer with the certified minimum count; mean modules over the tasks solved; "
        "configurations evaluated (structures whose feasibility was decided) and seconds per "
        "task. Learned methods: mean over five training seeds with the 95 % bootstrap "
        "interval over seeds in brackets; searches: one run.",
        "",
        "## At a glance",
        "",
        "Optimal share (success) per tier:",
        "",
        "<!-- --8<-- [start:glance] -->",
        *glance(entries, tiers),
        "<!-- --8<-- [end:glance] -->",
        "",
        f"![optimal share against configurations per task]({image})",
        "",
    ]
    for t in tiers:
        tier = get_tier(t)
        mine = [e for e in entries if e.tier == t]
        if not mine:
            continue
        types = f"module types {tier.modules}" if tier.modules else "one module type"
        tasks = max(e.tasks for e in mine if e.kind != "yours")
        text += [
            f"## Tier `{t}`",
            "",
            f"`{tier.env_id}`, {types}, n_max {tier.n_max}; held-out suites "
            f"{', '.join(f'`{s}`' for s in tier.suites)}: {tasks} tasks whose certified optimum "
            f"is within n_max.{_models(tier)}",
            "",
            *tier_table(mine),
            "",
        ]
        notes = sorted({n.removeprefix("modules: ") for e in mine for n in e.notes})
        if notes:
            where = "; ".join(f"`{r}{n.removeprefix('results/')}`" for n in notes)
            text += [f"† Mean modules of the shipped model's one run ({where}): the five-seed "
                     "data file predates its modules column.", ""]  # fmt: skip
        sources = dict.fromkeys(e.source for e in mine)
        text += ["Sources: " + "; ".join(_source(s, r) for s in sources) + ".", ""]
    text += scale_section(r)
    text += [
        "## How the numbers are made",
        "",
        "- **Learned methods** (`ppo`: one deterministic pass of the shipped policy; `ppo-k8`: "
        "eight sampled rollouts more; `ppo-guided`: best-first search ordered by the policy, "
        "certified at the lower bound): the five-seed reports "
        f"`{r}seeds_<tier>/seeds.csv`, one row per (seed, method, suite). Each seed's success, "
        "optimal share, configurations and seconds are pooled over the tier's tasks (suites "
        "weighted by their size), then averaged over the seeds; the interval is the 95 % "
        "percentile bootstrap over seeds (2,000 resamples, seeded). The seeds reports "
        f"(`{r}seeds_<tier>/seeds.md`) give the interquartile mean over seeds x suites and "
        "judge the tiers' goals.",
        f"- **Searches**: the one-run tier reports `{r}tier_<tier>/benchmark.csv` (one row per "
        f"task), and `{r}{RESCORED}` for the searches a tier report did not run "
        f"(`{COMMAND} --rescore-searches`). `random` and `genetic` are seeded (seed 0).",
        "- **Seconds** are wall time per task on the machine each source names (2 shared "
        "cores, no GPU): compare them within a tier, with care.",
        "",
        "## Add your own agent",
        "",
        "```bash",
        f"{COMMAND} --solver my_agent:Agent --out my_board",
        "```",
        "",
        "scores `Agent` (imported from `my_agent.py` in the working folder, or an installed "
        "package) on every tier's held-out suites and writes `my_board/leaderboard.md` with its "
        "rows beside the committed ones (`--limit N`: the first N tasks of each suite; "
        "`--tiers current large`: some tiers). The agent is told each tier's n_max and counted "
        "through the evaluator it is handed, as `modquad score --solver` does: the "
        "protocol is in [Benchmark tiers and agents]("
        + ("" if r else "../docs/")
        + "benchmarks.md#score-your-own-agent).",
        "",
    ]
    return "\n".join(text)


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
        command = f"{COMMAND} --rescore-searches"
    shown = f"`{prefix}{source.removeprefix('results/')}`"
    return shown + (f" (`{command}`)" if command else "")


def build(tiers: list[str], extra: list[Entry], out: Path, docs: Path | None) -> Path:
    """Write the leaderboard of the committed entries (and ``extra``) into ``out`` (and the
    documentation page into ``docs``)."""
    from modquad_gym.core.outputs import write_csv, write_text

    entries = [e for t in tiers for e in tier_entries(t)]
    entries += extra
    write_csv([e.as_csv() for e in entries], out / "leaderboard.csv")
    plot(entries, tiers, out / "leaderboard.png")
    path = write_text(out / "leaderboard.md", page(entries, tiers, "leaderboard.png", ""))
    if docs is not None:
        write_text(docs / "leaderboard.md", page(entries, tiers, "results/leaderboard.png",
                                                 "results/"))  # fmt: skip
    return path


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(prog=COMMAND, description=__doc__.split("\n\n")[0])
    p.add_argument(
        "--rescore-searches",
        action="store_true",
        help=f"first run the searches the tier reports lack into results/{RESCORED}",
    )
    p.add_argument(
        "--solver",
        metavar="PKG.MOD:NAME",
        default=None,
        help="also score this outside agent on every tier (needs --out)",
    )
    p.add_argument(
        "--tiers", nargs="+", choices=TIERS, default=list(TIERS), help="tiers to show (default all)"
    )
    p.add_argument(
        "--limit", type=int, default=None, help="with --solver: the first N tasks of each suite"
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
        "results/leaderboard.*, docs/leaderboard.md and, with --rescore-searches, "
        f"results/{RESCORED}); default: refuse",
    )
    p.add_argument("--no-progress", action="store_true")
    args = p.parse_args(argv)  # fmt: skip
    if args.solver and args.out is None:
        p.error("--solver needs --out: the committed leaderboard holds committed data only")
    if args.out is None and sorted(args.tiers) != sorted(TIERS):
        p.error("--tiers needs --out: the committed leaderboard holds every tier")
    if args.limit is not None and (args.limit < 1 or not args.solver):
        p.error("--limit takes a positive count, with --solver")
    from modquad_gym.core.outputs import check_output_dir

    try:  # the committed pages too: replaced only with --force
        check_output_dir(args.out or RESULTS, OUTPUTS, args.force)
        if args.out is None:
            check_output_dir(DOCS, ("leaderboard.md",), args.force)
            if args.rescore_searches:
                check_output_dir(RESULTS, (RESCORED,), args.force)
    except ValueError as err:
        p.error(str(err))
    try:
        if args.rescore_searches:
            print(rescore_searches(progress=not args.no_progress))
        extra = []
        if args.solver:
            extra = score_agent(args.solver, args.tiers, args.limit, not args.no_progress)
    except ValueError as err:
        p.error(str(err))
    out = args.out or RESULTS
    docs = DOCS if args.out is None else None
    path = build(args.tiers, extra, out, docs)
    print(path.read_text())
    return 0


if __name__ == "__main__":
    from benchmarks.common import run_main

    raise SystemExit(run_main(main, "leaderboard"))
