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

from benchmarks.common import (
    Distinct,
    bench_args,
    check_model,
    check_task_rows,
    int_option,
    read_rows_csv,
    run_main,
    write_csv,
)
from benchmarks.measure import fresh_map, measured, report_part
from benchmarks.scale_report import goal_lines, plot, report, summary
from benchmarks.scale_suites import (
    BANDS,
    FAMILIES,
    build_band,
    load_scale_suite,
    search_budget,
    task_palette,
)
from modquad_gym.cli.common import time_limit_option
from modquad_gym.core.options import nonempty_option, path_option
from modquad_gym.core.outputs import claim_output_dir, write_text
from modquad_gym.core.resources import cap_workers

METHODS = ("anytime", "greedy", "beam", "genetic", "centrosymmetric", "random", "milp", "ppo",
           "ppo-guided")  # fmt: skip
"""The methods compared by default: the default search (the portfolio), the field's baselines,
the mixed-integer program, the learned designer (the shipped size-free model, trained on tasks
of at most 7 modules)."""
OUTPUTS = ("report.md", "rows.csv", "summary.csv", "gap_vs_size.png")
ROW_COLUMNS = ["band", "family", "task", "method", "planted", "lower_bound", "found", "verified",
               "gap_to_planted_pct", "gap_to_bound", "seconds", "peak_MB", "note"]  # fmt: skip
"""The columns of rows.csv, in order (:func:`task_row`; what ``--rows`` reads back)."""
WARMUP_SECONDS = 5.0
"""Time limit of the untimed warm-up run that precedes each (method, palette, kind) in a fresh
process, so that no timed run pays the one-off compilation and imports."""


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


def known_method(name: str) -> bool:
    """Whether ``name`` is a method this benchmark runs: a solver, a learned variant or
    ``anytime-wN``, each also as ``METHOD+prune``."""
    from modquad_gym.solvers import METHODS as KNOWN
    from modquad_gym.solvers import learned_options

    method = without_prune(name)[0]
    return method in KNOWN or learned_options(method) is not None or bool(portfolio_workers(method))


def portfolio_workers(method: str) -> int | None:
    """N of a method named ``anytime-wN`` (the default search on N workers), else None."""
    head, _, n = method.partition("-w")
    return int(n) if head == "anytime" and n.isascii() and n.isdigit() and int(n) > 0 else None


def solve_band(method: str, tasks: list, time_limit: float, seed: int, engine, model=None):
    """:func:`run_band` in this process (``engine``: the ``anytime-wN`` search's; ``model``:
    the learned methods' model, default the shipped one)."""
    from modquad_gym.geometry.module import TModule
    from modquad_gym.search import verified
    from modquad_gym.solvers import learned_options, make_solver
    from modquad_gym.solvers.factory import draws_at_random

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
                seeded = {"seed": seed} if draws_at_random(name) else {}  # not ppo's one pass
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


def read_runs(paths: list[Path]) -> list[dict]:
    """The rows of earlier runs (:func:`read_rows`), merged: a (task, method) row of a later
    file replaces an earlier one, and each task's ``lower_bound`` (and so ``gap_to_bound``) is
    the largest any of them proved."""
    merged: dict[tuple, dict] = {}
    for path in paths:
        rows = read_rows(path)
        check_task_rows(rows, (), f"--rows {path}")  # one row per (task, method) in a run
        merged.update({(r["task"], r["method"]): r for r in rows})
    bound: dict[str, int] = {}
    for r in merged.values():
        bound[r["task"]] = max(bound.get(r["task"], 0), r["lower_bound"])
    rows = sorted(merged.values(), key=lambda r: r["band"])  # stable: each run's order kept
    for r in rows:
        r["lower_bound"] = bound[r["task"]]
        r["gap_to_bound"] = r["found"] - r["lower_bound"] if r["found"] != "none" else ""
        if r["verified"] and r["gap_to_bound"] < 0:  # a proved bound above a verified answer
            raise ValueError(f"--rows: task {r['task']}: {r['method']}'s verified {r['found']} "
                             f"modules lie below the bound {r['lower_bound']} another row "
                             "proved")  # fmt: skip
    return rows


def read_rows(path: Path, option: str = "--rows") -> list[dict]:
    """The rows of an earlier run's ``rows.csv``, typed as :func:`task_row` makes them; a
    ValueError naming ``option`` (none: the file alone), the file and the 1-based row (after
    the header) otherwise."""
    return read_rows_csv(path, option, ROW_COLUMNS, typed_row, "benchmarks.scale")


def typed_row(raw: dict) -> dict | None:
    """A row of rows.csv typed as :func:`task_row` writes it; None for values it never writes:
    a band outside 1..128, an unknown family or method, a count below 1, negative memory or
    seconds, a verified answer below its certified bound or a verified row with no answer,
    gaps that are not the answer's."""
    numbers = {"band": int, "planted": int, "lower_bound": int, "peak_MB": int, "seconds": float}
    row: dict = {**raw, **{key: kind(raw[key]) for key, kind in numbers.items()}}
    found = row["found"] = "none" if raw["found"] == "none" else int(raw["found"])
    row["verified"] = {"True": True, "False": False}[raw["verified"]]
    for key, kind in (("gap_to_planted_pct", float), ("gap_to_bound", int)):
        row[key] = kind(raw[key]) if raw[key] != "" else ""
    known = 1 <= row["band"] <= 128 and row["family"] in FAMILIES and known_method(row["method"])
    counts = min(row["planted"], row["lower_bound"], 1 if found == "none" else found) >= 1
    measured = 0 <= row["seconds"] < float("inf") and row["peak_MB"] >= 0
    answer = found != "none" and (found >= row["lower_bound"] or not row["verified"])
    gaps = (row["gap_to_bound"], row["gap_to_planted_pct"]) == (
        (found - row["lower_bound"], round(100.0 * (found - row["planted"]) / row["planted"], 1))
        if found != "none" else ("", "")
    )  # fmt: skip
    fits = answer or (found == "none" and not row["verified"])
    return row if known and counts and measured and fits and gaps else None


def task_options(bands=BANDS, workers: int = 1) -> dict[str, dict]:
    """The options every benchmark of the scale tasks takes (which tasks, and how they run),
    with its default ``bands`` and ``workers``: ``bench_args`` keywords by flag."""
    return {
        "--bands": dict(type=int_option(1, 128), nargs="+", action=Distinct, default=list(bands),
                        help=f"size bands (default {' '.join(map(str, bands))})"),
        "--families": dict(nargs="+", action=Distinct, choices=tuple(FAMILIES),
                           default=list(FAMILIES), help="task families (default all)"),
        "--per-family": dict(type=int_option(1, 100), default=1,
                             help="tasks per family and band (default 1)"),
        "--time-limit": dict(type=time_limit_option, default=30.0,
                             help="seconds each method gets per task (default 30)"),
        "--workers": dict(type=int_option(1, 64), default=workers,
                          help=f"(method, band) processes at a time (default {workers})"),
        "--validation": dict(action="store_true",
                             help="validation draws instead of the held-out suites"),
    }  # fmt: skip


def check_task_args(args) -> None:
    """The :func:`task_options` given, checked before any work (one line, exit 2 as the CLI's
    rule; the time limit is argparse's, :func:`~modquad_gym.cli.common.time_limit_option`): each
    band a held-out suite unless drawn."""
    unknown = [b for b in args.bands if b not in BANDS and not args.validation]
    if unknown:
        raise ValueError(f"--bands {unknown[0]}: no held-out suite of that size (bands "
                         f"{' '.join(map(str, BANDS))}; --validation draws any size)")  # fmt: skip


def main(argv: list[str] | None = None) -> None:
    options = {
        **task_options(),
        "--methods": dict(nargs="+", action=Distinct, default=list(METHODS),
                          help=f"solver names (default {' '.join(METHODS)}); METHOD+prune: "
                               "its answers through the prune post-pass"),
        "--model": dict(type=nonempty_option, default=None, metavar="ZIP",
                        help="the learned methods' model (default the shipped one)"),
        "--rows": dict(type=path_option, nargs="+", default=None, metavar="CSV",
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

    check_task_args(args)
    for method in args.methods:
        if not known_method(method):
            raise ValueError(f"--methods: unknown method {without_prune(method)[0]!r}; choose "
                             f"from {', '.join(KNOWN)} or a learned variant")  # fmt: skip
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
