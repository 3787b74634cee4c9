"""Every method at the field's sizes, on the same held-out tasks of 16-128 modules.

    python -m benchmarks.scale [--bands 16 24 32 48 64 96 128] [--families ...] [--per-family 1]
                        [--methods anytime greedy beam genetic centrosymmetric random milp ppo
                         ppo-guided] [--time-limit 30] [--workers 1] [--validation]

Writes ``results/scale/report.md``, ``rows.csv`` (one row per task and method), ``summary.csv``
(one row per band and method) and ``gap_vs_size.png``. Tasks: the shipped scale suites
(:mod:`.scale_suites`: planted, mixed palette, heavy payload, low force / high torque), or with
``--validation`` the validation draws (where settings are tuned; bounds computed on the fly).

Each (method, band) runs in a fresh spawned process (its peak resident memory is the band's),
after an untimed warm-up run of at most 5 s on the band's first task of each palette and kind
(imports, numba compilation and caches: a one-off cost, see ``python -m benchmarks.coldstart``),
with
``n_max`` 64 (the band, past 64) and every method given the same ``--time-limit``. A method
``anytime-wN`` is the default search with N Ray workers for its producers (it uses N cores: run
it with ``--workers 1``). Every structure is re-verified
by the exact LP oracle. A task's certified lower bound is the largest of the suite's (what the
default search proved when the suite was built) and what any method proved in this run; the gap
of an answer is measured to it and to the planted size (an upper bound on the optimum).
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

from benchmarks.common import (
    bench_args,
    check_model,
    int_option,
    load_average,
    machine_description,
    markdown_table,
    read_rows_csv,
    run_main,
    write_csv,
)
from benchmarks.measure import fresh_map, measured, report_part
from benchmarks.scale_suites import (
    BANDS,
    FAMILIES,
    build_band,
    load_scale_suite,
    search_budget,
    task_palette,
)
from modquad_gym.core.outputs import claim_output_dir, save_figure, write_text
from modquad_gym.core.resources import cap_workers

METHODS = ("anytime", "greedy", "beam", "genetic", "centrosymmetric", "random", "milp", "ppo",
           "ppo-guided")  # fmt: skip
"""The methods compared by default: the default search (the portfolio), the field's baselines,
the mixed-integer program, the learned designer (the shipped size-free model, trained on tasks
of at most 7 modules)."""
BASELINES = ("greedy", "beam", "genetic", "centrosymmetric")
LEARNED = ("ppo", "ppo-guided")
OUTPUTS = ("report.md", "rows.csv", "summary.csv", "gap_vs_size.png")
ROW_COLUMNS = ["band", "family", "task", "method", "planted", "lower_bound", "found", "verified",
               "gap_to_planted_pct", "gap_to_bound", "seconds", "peak_MB", "note"]  # fmt: skip
"""The columns of rows.csv, in order (:func:`task_row`; what ``--rows`` reads back)."""
WARMUP_SECONDS = 5.0
"""Time limit of the untimed warm-up run that precedes each (method, palette, kind) in a fresh
process, so that no timed run pays the one-off compilation and imports."""
GOALS = {"anytime_gap_pct": 5.0, "heuristic_gap_pct": 10.0, "seconds": 60.0,
         "certified_gap_pct": 10.0, "seconds_128": 120.0, "peak_MB_128": 2048.0}  # fmt: skip


def band_tasks(band: int, families, per_family: int, validation: bool, time_limit: float):
    if validation:
        tasks = build_band(band, per_family, time_limit, validation=True)
        return [t for t in tasks if t.meta["family"] in families]
    return load_scale_suite(band, families, per_family)


def run_band(
    method: str, tasks: list, time_limit: float, seed: int, model: str | None = None
) -> list[dict]:
    """Solve ``tasks`` with ``method`` (one process: a solver made once per palette and kind).
    A task the method refuses (a ValueError) is recorded with its one-line reason."""
    from modquad_gym.core.distributed import Engine

    workers = portfolio_workers(method)
    with Engine(workers or 1) as engine:  # Ray, when asked for, serves every task of the band
        return solve_band(method, tasks, time_limit, seed, engine if workers else None, model)


def without_prune(method: str) -> tuple[str, bool]:
    """(the method, whether it prunes) of a name ``METHOD`` or ``METHOD+prune`` (its answers
    through the prune post-pass, :mod:`modquad_gym.search.prune`)."""
    base, plus, post = method.partition("+")
    return (base, True) if plus and post == "prune" else (method, False)


def portfolio_workers(method: str) -> int | None:
    """N of a method named ``anytime-wN`` (the default search on N workers), else None."""
    head, _, n = method.partition("-w")
    return int(n) if head == "anytime" and n.isdigit() and int(n) > 0 else None


def solve_band(method: str, tasks: list, time_limit: float, seed: int, engine, model=None):
    """:func:`run_band` in this process (``engine``: the ``anytime-wN`` search's; ``model``:
    the learned methods' model, default the shipped one)."""
    from modquad_gym.geometry.module import TModule
    from modquad_gym.methods import method_of
    from modquad_gym.search import verified
    from modquad_gym.solvers import learned_options, make_solver

    method, pruning = without_prune(method)
    learned = learned_options(method) is not None
    solvers: dict = {}
    out = []
    n_max = search_budget(tasks[0].meta["band"]) if tasks else 64
    name, extra = (method, {}) if engine is None else ("anytime", {"engine": engine})
    extra.update({"prune": True} if pruning else {})
    if learned and model is not None:
        extra["model"] = model
    for task in tasks:
        modules = task_palette(task)
        if modules is None and learned and task.kind != "total":
            modules = [TModule()]  # the env decides self-weight through a module set
        key = (task.meta.get("palette"), task.kind)
        try:
            if key not in solvers:
                seeded = {"seed": seed} if "seed" in method_of(name)[0].options.names() else {}
                options = dict(n_max=n_max, modules=modules, **seeded, **extra)
                warm = make_solver(name, time_limit=min(WARMUP_SECONDS, time_limit), **options)
                warm.solve(task)  # untimed: imports, compilation, caches (the process is new)
                solvers[key] = make_solver(name, time_limit=time_limit, **options)
            r, seconds, peak = measured(solvers[key].solve, task)
        except ValueError as exc:
            note = str(exc).splitlines()[0]
            out.append({"task": task.name, "found": None, "proved": 0, "verified": False,
                        "seconds": 0.0, "peak_MB": 0.0, "note": note})  # fmt: skip
        else:
            out.append({"task": task.name, "found": r.n_modules, "proved": r.lower_bound,
                        "verified": verified(r.structure, task), "seconds": seconds,
                        "peak_MB": peak, "note": ""})  # fmt: skip
        report_part(out[-1])  # kept by the parent if the run is stopped
    return out


def task_row(task, method: str, res: dict, bound: int) -> dict:
    m, found = task.meta, res["found"]
    planted = m["planted"]
    return {
        "band": m["band"],
        "family": m["family"],
        "task": task.name,
        "method": method,
        "planted": planted,
        "lower_bound": bound,
        "found": found if found is not None else "none",
        "verified": res["verified"],
        "gap_to_planted_pct": round(100.0 * (found - planted) / planted, 1) if found else "",
        "gap_to_bound": found - bound if found is not None else "",
        "seconds": round(res["seconds"], 2),
        "peak_MB": round(res["peak_MB"]),
        "note": res["note"],
    }


def measure(args, keep=None) -> list[dict]:
    """Every (band, method) run; rows with each task's best proved bound. ``keep(rows)`` is
    called with the rows so far each time a task's answer comes in, so an interrupted run
    keeps them."""
    rows: list[dict] = []
    for band in args.bands:
        tasks = band_tasks(band, args.families, args.per_family, args.validation, args.time_limit)
        jobs = [(m, tasks, args.time_limit, args.seed, args.model) for m in args.methods]
        done: dict[str, list] = {m: [] for m in args.methods}

        def arrived(i: int, answer: dict, tasks=tasks, done=done, rows=rows) -> None:
            done[args.methods[i]].append(answer)
            if keep is not None:
                keep(rows + band_rows(tasks, args.methods, done))

        def finished(i: int, result: list, tasks=tasks, done=done, rows=rows) -> None:
            done[args.methods[i]] = result
            if keep is not None:
                keep(rows + band_rows(tasks, args.methods, done))

        # each (method, band) in a new process, each task's answer sent back as it comes
        fresh_map(run_band, jobs, args.workers, finished, on_part=arrived)
        rows += band_rows(tasks, args.methods, done)
        for row in rows[-len(tasks) * len(args.methods) :]:
            print(row, flush=True)
    return rows


def band_rows(tasks: list, methods, done: dict[str, list]) -> list[dict]:
    """The rows of one band's answers so far (``done``: method -> its results, one per task
    in task order, fewer while it runs), in task then method order; each task's bound is the
    best any of them proved."""
    rows = []
    for i, task in enumerate(tasks):
        have = {m: res[i] for m, res in done.items() if i < len(res)}
        bound = max([task.meta["lower_bound"]] + [r["proved"] for r in have.values()])
        rows += [task_row(task, m, have[m], bound) for m in methods if m in have]
    return rows


def summary(rows: list[dict]) -> list[dict]:
    """Per band and method: tasks solved, and on those the mean modules and gap to the certified
    bound (read them beside ``solved``: a method that fails a hard task is not scored on it),
    mean seconds over all its tasks, peak memory."""
    out = []
    for band in sorted({r["band"] for r in rows}):
        mine = [r for r in rows if r["band"] == band]
        for method in dict.fromkeys(r["method"] for r in mine):
            rs = [r for r in mine if r["method"] == method]
            solved = [r for r in rs if r["found"] != "none"]
            out.append({
                "band": band, "method": method, "tasks": len(rs), "solved": len(solved),
                "mean_modules": _mean([r["found"] for r in solved]),
                "mean_gap_to_bound": _mean([r["gap_to_bound"] for r in solved]),
                "mean_seconds": _mean([r["seconds"] for r in rs]),
                "peak_MB": max(r["peak_MB"] for r in rs),
            })  # fmt: skip
    return out


def _mean(values: list) -> float | str:
    return round(float(np.mean(values)), 2) if values else ""


def versus(rows: list[dict], method: str, rival: str) -> dict:
    """``method`` against ``rival`` on the tasks both solved: mean modules and mean seconds of
    each, and how many tasks each solved."""
    by = {(r["method"], r["task"]): r for r in rows}
    tasks = [t for (m, t) in by if m == method and (rival, t) in by]
    both = [
        t for t in tasks if by[method, t]["found"] != "none" and by[rival, t]["found"] != "none"
    ]
    return {
        "both": len(both),
        "modules": _mean([by[method, t]["found"] for t in both]),
        "rival_modules": _mean([by[rival, t]["found"] for t in both]),
        "seconds": _mean([by[method, t]["seconds"] for t in tasks]),
        "rival_seconds": _mean([by[rival, t]["seconds"] for t in tasks]),
        "solved": sum(by[method, t]["found"] != "none" for t in tasks),
        "rival_solved": sum(by[rival, t]["found"] != "none" for t in tasks),
        "tasks": len(tasks),
    }


def goal_lines(rows: list[dict], methods, time_limit: float) -> list[str]:
    """The issues' goals, judged on this run (each line says met or NOT met)."""
    lines = []
    checks = ((64, "anytime", "anytime_gap_pct"), (64, "beam", "heuristic_gap_pct"),
              (64, "genetic", "heuristic_gap_pct"),
              (128, "anytime", "anytime_gap_pct"))  # fmt: skip
    for band, method, goal in checks:
        rs = [r for r in rows if (r["band"], r["family"], r["method"]) == (band, "planted", method)]
        if not rs:
            continue
        worst = max(r["gap_to_planted_pct"] if r["found"] != "none" else 1e9 for r in rs)
        slow, peak = max(r["seconds"] for r in rs), max(r["peak_MB"] for r in rs)
        limit = GOALS["seconds"] if band == 64 else GOALS["seconds_128"]
        ok = worst <= GOALS[goal] and slow <= min(limit, time_limit * 1.1)
        ok = ok and (band == 64 or peak <= GOALS["peak_MB_128"])
        lines.append(f"- {band}-module planted tasks, {method}: worst gap to the planted size "
                     f"{worst:g} % (goal <= {GOALS[goal]:g} %), slowest {slow:g} s (limit "
                     f"{min(limit, time_limit):g} s), peak {peak:g} MB"
                     + (f" (goal <= {GOALS['peak_MB_128']:g} MB)" if band == 128 else "")
                     + f": {'met' if ok else 'NOT met'}")  # fmt: skip
    for method in (m for m in methods if m.startswith("anytime")):
        lines += portfolio_goal_lines(rows, method)
    rivals = [m for m in BASELINES if m in methods]
    bands = sorted({r["band"] for r in rows})
    sizes = f"{bands[0]}-{bands[-1]}" if bands else "no"
    for method in (m for m in LEARNED if m in methods):
        parts, beaten = [], []
        for rival in rivals:
            v = versus(rows, method, rival)
            fewer = v["modules"] != "" and v["modules"] < v["rival_modules"]
            wins = fewer and v["solved"] >= v["rival_solved"] and v["seconds"] <= v["rival_seconds"]
            beaten += [rival] if wins else []
            parts.append(f"vs {rival}: {v['modules']} vs {v['rival_modules']} modules on the "
                         f"{v['both']} tasks both solved, solved {v['solved']} vs "
                         f"{v['rival_solved']} of {v['tasks']}, {v['seconds']} vs "
                         f"{v['rival_seconds']} s")  # fmt: skip
        if parts:
            lines.append(f"- learned `{method}` at {sizes} modules (fewer modules, at least as "
                         f"many solved, no more time): {'; '.join(parts)}. Beats "
                         f"{len(beaten)}/{len(rivals)} ({', '.join(beaten) or 'none'}): "
                         f"{'met' if len(beaten) == len(rivals) else 'NOT met'}")  # fmt: skip
    return lines


def portfolio_goal_lines(rows: list[dict], method: str = "anytime") -> list[str]:
    """Issue 35's goals for the default search (``method``: ``anytime``, or ``anytime-wN`` on
    workers), on the tasks it ran: no method other than the default search answers with fewer
    modules (a method that answers where it finds nothing counts as fewer), and its certified
    gap (found - bound) / found is at most ``certified_gap_pct``."""
    by_task: dict[str, dict[str, dict]] = {}
    for r in rows:
        by_task.setdefault(r["task"], {})[r["method"]] = r
    beaten, gaps = [], []
    for task, methods in by_task.items():
        mine = methods.get(method)
        if mine is None:
            continue
        found = mine["found"] if mine["found"] != "none" else None
        for rival, r in methods.items():
            if not rival.startswith("anytime") and r["found"] != "none":
                if found is None or int(r["found"]) < int(found):
                    beaten.append(f"{task} ({rival} {r['found']} vs {found or 'none'})")
        bound = int(mine["lower_bound"])
        gaps.append((100.0 * (int(found) - bound) / int(found) if found else 100.0, task))
    if not gaps:
        return []
    worst, worst_task = max(gaps)
    goal = GOALS["certified_gap_pct"]
    within = sum(g <= goal for g, _ in gaps)
    name = "the portfolio" if method == "anytime" else "the portfolio on workers"
    return [
        f"- default search (`{method}`, {name}) never uses more modules than another "
        f"method on a task: {len(gaps) - len({b.split(' ')[0] for b in beaten})} of "
        f"{len(gaps)} tasks; " + (f"beaten on {'; '.join(beaten)}: NOT met" if beaten else "met"),
        f"- `{method}`'s certified gap (found - bound) / found <= {goal:g} % on every task: "
        f"{within} of {len(gaps)} tasks, worst {worst:.1f} % ({worst_task}): "
        f"{'met' if within == len(gaps) else 'NOT met'}",
    ]


MARKERS = "osD^v<>pPX*h"


def common_solved(rows: list[dict], methods: list[str]) -> dict[int, list[str]]:
    """Per band, the tasks that every one of ``methods`` solved (a fair subset to average a
    gap over: a method that fails a hard task is not scored on an easier set)."""
    out = {}
    for band in sorted({r["band"] for r in rows}):
        solved = [{r["task"] for r in rows if r["band"] == band and r["method"] == m
                   and r["found"] != "none"} for m in methods]  # fmt: skip
        out[band] = sorted(set.intersection(*solved)) if solved else []
    return out


def plot(rows: list[dict], path: Path) -> None:
    """Left: each method's gap to the certified lower bound, mean (marker) and range (bar) over
    the tasks that every plotted method solved in the band (the methods that solved at least
    half the tasks of every band; n per band under the axis); right: the share of tasks
    solved. Methods side by side within a band, each with its own marker, so none hides
    another."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    bands = sorted({r["band"] for r in rows})
    methods = list(dict.fromkeys(r["method"] for r in rows))

    def tasks(band, m):
        return [r for r in rows if r["band"] == band and r["method"] == m]

    def solved(band, m):
        return [r for r in tasks(band, m) if r["found"] != "none"]

    steady = [m for m in methods
              if all(2 * len(solved(b, m)) >= max(1, len(tasks(b, m))) for b in bands)]  # fmt: skip
    subset = common_solved(rows, steady)
    fig, (gap_ax, solved_ax) = plt.subplots(1, 2, figsize=(13, 4.8))
    width = 0.8 / max(len(methods), 1)
    for k, m in enumerate(methods):
        style = {"marker": MARKERS[k % len(MARKERS)], "color": f"C{k % 10}", "label": m}
        dx = (k - (len(methods) - 1) / 2) * width
        if m in steady:
            xs, mid, lo, hi = [], [], [], []
            for i, b in enumerate(bands):
                gaps = [r["gap_to_bound"] for r in solved(b, m) if r["task"] in subset[b]]
                if gaps:
                    xs.append(i + dx)
                    mid.append(float(np.mean(gaps)))
                    lo.append(mid[-1] - min(gaps))
                    hi.append(max(gaps) - mid[-1])
            gap_ax.errorbar(xs, mid, yerr=[lo, hi], capsize=3, lw=1, **style)
        pts = [(i + dx, 100.0 * len(solved(b, m)) / len(tasks(b, m)))
               for i, b in enumerate(bands) if tasks(b, m)]  # fmt: skip
        solved_ax.plot(*zip(*pts, strict=True), ls="none", ms=7, **style)
    gap_ax.set_xticks(range(len(bands)),
                      [f"{b}\n(n={len(subset[b])})" for b in bands])  # fmt: skip
    gap_ax.set_ylabel("modules above the certified lower bound")
    gap_ax.set_title("Gap to the lower bound: mean and range over the tasks all of these "
                     "solved", fontsize="medium")  # fmt: skip
    gap_ax.set_ylim(bottom=0)
    gap_ax.legend(fontsize=8, ncol=2)
    solved_ax.set_xticks(range(len(bands)), [str(b) for b in bands])
    solved_ax.set_ylabel("tasks solved within the time limit (%)")
    solved_ax.set_ylim(-3, 105)
    solved_ax.set_title("Tasks solved (every method)", fontsize="medium")
    solved_ax.legend(fontsize=8, ncol=2, loc="lower left")
    for ax in (gap_ax, solved_ax):
        ax.set_xlabel("planted size (modules)")
        ax.grid(alpha=0.3)
    fig.tight_layout()
    save_figure(fig, path)
    plt.close(fig)


def read_runs(paths: list[Path]) -> list[dict]:
    """The rows of earlier runs (:func:`read_rows`), merged: a (task, method) row of a later
    file replaces an earlier one, and each task's ``lower_bound`` (and so ``gap_to_bound``) is
    the largest any of them proved."""
    merged: dict[tuple, dict] = {}
    for path in paths:
        merged.update({(r["task"], r["method"]): r for r in read_rows(path)})
    bound: dict[str, int] = {}
    for r in merged.values():
        bound[r["task"]] = max(bound.get(r["task"], 0), r["lower_bound"])
    rows = sorted(merged.values(), key=lambda r: r["band"])  # stable: each run's order kept
    for r in rows:
        r["lower_bound"] = bound[r["task"]]
        r["gap_to_bound"] = r["found"] - r["lower_bound"] if r["found"] != "none" else ""
    return rows


def read_rows(path: Path) -> list[dict]:
    """The rows of an earlier run's ``rows.csv``, typed as :func:`task_row` makes them; a
    ValueError naming the file and the 1-based row (after the header) otherwise."""
    return read_rows_csv(path, "--rows", ROW_COLUMNS, typed_row, "benchmarks.scale")


def typed_row(raw: dict) -> dict | None:
    """A row of rows.csv typed as :func:`task_row` writes it; None for values it never writes."""
    numbers = {"band": int, "planted": int, "lower_bound": int, "peak_MB": int, "seconds": float}
    row: dict = {**raw, **{key: kind(raw[key]) for key, kind in numbers.items()}}
    row["found"] = "none" if raw["found"] == "none" else int(raw["found"])
    row["verified"] = {"True": True, "False": False}[raw["verified"]]
    for key, kind in (("gap_to_planted_pct", float), ("gap_to_bound", int)):
        row[key] = kind(raw[key]) if raw[key] != "" else ""
    finite = 0 <= row["seconds"] < float("inf")
    return row if finite and (row["found"] == "none" or row["found"] >= 1) else None


def command_line(args) -> str:
    line = (f"python -m benchmarks.scale --bands {' '.join(map(str, args.bands))} --families "
            f"{' '.join(args.families)} --per-family {args.per_family} --methods "
            f"{' '.join(args.methods)} --time-limit {args.time_limit:g} --workers {args.workers}"
            + (" --validation" if args.validation else "") + f" --seed {args.seed}"
            + (f" --model {args.model}" if args.model else ""))  # fmt: skip
    if args.rows:  # re-rendered: the measuring run's command, then the re-rendering
        line += (
            f"`, re-rendered by `... --rows {' '.join(map(str, args.rows))} --out {args.out} "
            "--force"
        )
    return line


def report(rows: list[dict], summary_rows: list[dict], args) -> str:
    load = load_average()
    return "\n".join([
        f"# Every method at {min(args.bands)}-{max(args.bands)} modules",
        "",
        f"Made by `{command_line(args)}` on {machine_description()}; each (method, band) in a "
        f"fresh process, {args.workers} at a time; "
        + ("load average not recorded (re-rendered)." if args.rows else
           f"load average at the end {load}."),
        "",
        "Tasks: the held-out scale suites (`modquad_gym/data/suites/scale_N.json`; families "
        "`planted` one type, `mixed` palette t45/t45m/flat, `payload` heavy payload with "
        "self-weight, `torque` low force and high torque where no lift bound helps). "
        "`lower_bound`: certified (the largest proved by the suite's default search or by any "
        "method here). `gap_to_bound`: modules above it. `planted`: the hidden structure's size, "
        "an upper bound on the optimum. "
        + (f"Learned methods use the model {args.model}. " if args.model else
           "Learned methods use the shipped pair (`modquad_gym.policy.default_model`): "
           "`ppo_scale`, trained further on one-type tasks of 8-32 modules, for the one-type "
           "families, the default model with the mixed palette. ")
        + "Every structure is verified by the exact LP. "
        "Per band, `mean_modules` and `mean_gap_to_bound` are over the tasks the method solved "
        "(read them beside `solved`); `mean_seconds` over all its tasks.",
        "",
        "## Per band and method",
        "",
        markdown_table(summary_rows),
        "",
        "Goals:",
        *goal_lines(rows, args.methods, args.time_limit),
        "",
        "![gap vs size](gap_vs_size.png)",
        "",
        "## Every task",
        "",
        markdown_table(rows),
        "",
    ])  # fmt: skip


def task_options(bands=BANDS, workers: int = 1) -> dict[str, dict]:
    """The options every benchmark of the scale tasks takes (which tasks, and how they run),
    with its default ``bands`` and ``workers``: ``bench_args`` keywords by flag."""
    return {
        "--bands": dict(type=int_option(1, 128), nargs="+", default=list(bands),
                        help=f"size bands (default {' '.join(map(str, bands))})"),
        "--families": dict(nargs="+", choices=tuple(FAMILIES), default=list(FAMILIES),
                           help="task families (default all)"),
        "--per-family": dict(type=int_option(1, 100), default=1,
                             help="tasks per family and band (default 1)"),
        "--time-limit": dict(type=float, default=30.0,
                             help="seconds each method gets per task (default 30)"),
        "--workers": dict(type=int_option(1, 64), default=workers,
                          help=f"(method, band) processes at a time (default {workers})"),
        "--validation": dict(action="store_true",
                             help="validation draws instead of the held-out suites"),
    }  # fmt: skip


def check_task_args(args) -> None:
    """The :func:`task_options` given, checked before any work (one line each, exit 2 as the
    CLI's rule): the time limit in (0, a day], each band a held-out suite unless drawn."""
    from modquad_gym.search.problem import check_time_limit

    try:
        check_time_limit(args.time_limit)
    except ValueError as exc:
        raise ValueError(f"--time-limit: {exc}") from None
    unknown = [b for b in args.bands if b not in BANDS and not args.validation]
    if unknown:
        raise ValueError(f"--bands {unknown[0]}: no held-out suite of that size (bands "
                         f"{' '.join(map(str, BANDS))}; --validation draws any size)")  # fmt: skip


def main(argv: list[str] | None = None) -> None:
    options = {
        **task_options(),
        "--methods": dict(nargs="+", default=list(METHODS),
                          help=f"solver names (default {' '.join(METHODS)}); METHOD+prune: "
                               "its answers through the prune post-pass"),
        "--model": dict(default=None, metavar="ZIP",
                        help="the learned methods' model (default the shipped one)"),
        "--rows": dict(type=Path, nargs="+", default=None, metavar="CSV",
                       help="re-render the report from earlier runs' rows.csv (no solving; "
                            "give the options they used; several runs are merged, a later "
                            "file's (task, method) rows replacing an earlier one's)"),
    }  # fmt: skip
    args = bench_args(
        argv,
        "python -m benchmarks.scale",
        "Every method on the held-out scale suites (16-128 modules) with one time limit; "
        "write results/scale/.",
        options,
        seed_help="seed of the seeded methods (default 0)",
        out="results/scale",
        outputs=OUTPUTS,
    )
    from modquad_gym.solvers import METHODS as KNOWN
    from modquad_gym.solvers import learned_options

    check_task_args(args)
    for method in (without_prune(m)[0] for m in args.methods):
        if (
            method not in KNOWN
            and learned_options(method) is None
            and not portfolio_workers(method)
        ):
            raise ValueError(f"--methods: unknown method {method!r}; choose from "
                             f"{', '.join(KNOWN)} or a learned variant")  # fmt: skip
    check_model_option(args.model, args.methods)
    args.workers = cap_workers(args.workers)
    earlier = read_runs(args.rows) if args.rows else None  # before --force clears --out
    with claim_output_dir(args.out, OUTPUTS, args.force) as claim:  # a second run is refused
        kept = claim.path("rows.csv")
        try:
            rows = earlier if earlier is not None else measure(args, keep_rows(kept))
        except KeyboardInterrupt:
            if kept.exists():
                print(f"kept the finished rows in {kept}", file=sys.stderr)
            raise
        summary_rows = summary(rows)
        write_csv(rows, kept)
        write_csv(summary_rows, claim.path("summary.csv"))
        plot(rows, claim.path("gap_vs_size.png"))
        write_text(claim.path("report.md"), report(rows, summary_rows, args))
    print("\n".join(goal_lines(rows, args.methods, args.time_limit)))


def keep_rows(path: Path):
    """What :func:`measure` calls with the rows so far: they go to ``path`` at once."""

    def keep(rows: list[dict]) -> None:
        if rows:
            write_csv(rows, path)

    return keep


def check_model_option(model: str | None, methods) -> None:
    """``--model``: a saved model, for a learned method among ``methods`` (one line, before any
    work; a missing file would leave every learned answer empty)."""
    from modquad_gym.solvers import learned_options

    if model is None:
        return
    if not any(learned_options(m) is not None for m in methods):
        raise ValueError(f"--model {model}: no learned method among --methods to use it")
    check_model(model, f"--model {model}")


if __name__ == "__main__":
    raise SystemExit(run_main(main, "scale"))
