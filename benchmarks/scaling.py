"""Scaling of the certified exhaustive search, level by level, against the search as it was.

    python -m benchmarks.scaling [--seed 0] [--n-max 14] [--reference-n-max 12] [--tasks 3]

Writes ``results/search_scaling.md`` and ``.csv``. Two workloads:
* a low-force task that refutes every level up to ``--n-max`` (wrenches of a hidden large
  structure, forces small enough for one module, torques that need long lever arms), searched
  with n_max = n for n = 8..n_max: the cost of a certified "no" up to n modules;
* planted tasks whose certified optimum is exactly 12 modules, searched with n_max = 12.
The reference is the previous implementation (:mod:`.reference_search`: each level built in
memory from the previous one, numpy support tests), run on the same tasks up to
``--reference-n-max``; speed-ups are ratios of wall times in this run. Every run is a fresh
spawned process, so its peak resident memory (``peak_MB``) is its own.
"""

from __future__ import annotations

import argparse
import multiprocessing as mp
import time
from pathlib import Path

import numpy as np

from benchmarks.common import (
    bench_args,
    int_option,
    report_page,
    run_main,
    write_report,
)
from benchmarks.measure import own_peak_mb, warm_search
from modquad_gym.geometry.polyominoes import A001168

GOALS = {"refute 12": 3.0, "refute 14": 60.0, "planted 12": 5.0, "memory_MB": 2048.0}


def _timed(impl: str, W: np.ndarray, n_max: int) -> tuple[float, int | None, int, float]:
    """Run one search in this (fresh) process: (seconds, n_modules, evaluated, peak MB)."""
    if impl == "reference":
        from benchmarks.reference_search import exhaustive_search
    else:
        from modquad_gym.search import exhaustive_search
    warm_search(exhaustive_search)
    t0 = time.perf_counter()
    r = exhaustive_search(W, n_max=n_max)
    seconds = time.perf_counter() - t0
    return seconds, r.n_modules, r.evaluated, own_peak_mb()


def measure(impl: str, W: np.ndarray, n_max: int) -> tuple[float, int | None, int, float]:
    """:func:`_timed` in a fresh spawned process."""
    with mp.get_context("spawn").Pool(1) as pool:
        return pool.apply(_timed, (impl, W, n_max))


def refuting_task(seed: int, n_max: int) -> np.ndarray:
    """A low-force task (see :func:`.search.low_force_task`) whose certified optimum exceeds
    ``n_max``: hidden structures of 3 n_max modules, redrawn until none of up to n_max works."""
    from benchmarks.search import low_force_task, random_structure
    from modquad_gym.search import exhaustive_search

    rng = np.random.default_rng(seed)
    while True:
        W = low_force_task(random_structure(3 * n_max, rng), 8, rng)
        if exhaustive_search(W, n_max=n_max).structure is None:
            return W


def planted_12(seed: int, count: int) -> list[np.ndarray]:
    """``count`` planted tasks (80 wrenches of a hidden 12-module structure) with optimum 12."""
    from benchmarks.search import planted_task
    from modquad_gym.search import exhaustive_search

    rng = np.random.default_rng(seed)
    tasks = []
    while len(tasks) < count:
        W = planted_task(12, 80, rng)
        if exhaustive_search(W, n_max=12).n_modules == 12:
            tasks.append(W)
    return tasks


def _row(workload, n, impl, run, ref=None) -> dict:
    seconds, n_found, evaluated, peak = run
    return {
        "workload": workload,
        "n_max": n,
        "level_structures": A001168[n - 1],
        "implementation": impl,
        "optimum": n_found if n_found is not None else f"> {n}",
        "evaluated": evaluated,
        "seconds": round(seconds, 3),
        "structures_per_s": round(evaluated / seconds) if seconds > 0 else 0,
        "peak_MB": round(peak),
        "speedup": round(ref[0] / seconds, 1) if ref else "",
    }


def run(seed: int, n_max: int, ref_n_max: int, n_tasks: int, out: Path) -> list[dict]:
    rows = []
    W = refuting_task(seed, n_max)
    for n in range(8, n_max + 1):
        ref = measure("reference", W, n) if n <= ref_n_max else None
        if ref:
            rows.append(_row("refute every level", n, "reference", ref))
        rows.append(_row("refute every level", n, "streaming", measure("new", W, n), ref))
        print(rows[-1], flush=True)
    for i, Wp in enumerate(planted_12(seed, n_tasks)):
        ref = measure("reference", Wp, 12) if ref_n_max >= 12 else None
        if ref:
            rows.append(_row(f"planted optimum 12 #{i}", 12, "reference", ref))
        rows.append(_row(f"planted optimum 12 #{i}", 12, "streaming", measure("new", Wp, 12), ref))
        print(rows[-1], flush=True)
    return rows


def goal_lines(rows: list[dict]) -> list[str]:
    new = [r for r in rows if r["implementation"] == "streaming"]

    def secs(workload, n):
        return max(
            r["seconds"] for r in new if r["workload"].startswith(workload) and r["n_max"] == n
        )

    checks = []
    if any(r["n_max"] == 12 and r["workload"] == "refute every level" for r in new):
        checks.append(("n_max = 12, refuting task", secs("refute", 12), GOALS["refute 12"], "s"))
    if any(r["n_max"] == 14 for r in new):
        checks.append(("n_max = 14, refuting task", secs("refute", 14), GOALS["refute 14"], "s"))
    if any(r["workload"].startswith("planted") for r in new):
        checks.append(
            ("planted optimum 12 (slowest)", secs("planted", 12), GOALS["planted 12"], "s")
        )
    peak = max(r["peak_MB"] for r in new)
    checks.append(("peak memory of any streaming run", peak, GOALS["memory_MB"], "MB"))
    return [
        f"- {what}: {value:g} {unit} (goal <= {goal:g} {unit}): "
        f"{'met' if value <= goal else 'NOT met'}"
        for what, value, goal, unit in checks
    ]


def report(rows: list[dict], args: argparse.Namespace) -> str:
    command = (
        f"python -m benchmarks.scaling --seed {args.seed} --n-max {args.n_max} "
        f"--reference-n-max {args.reference_n_max} --tasks {args.tasks}"
    )
    return report_page(
        "Certified exhaustive search at scale",
        command,
        "`refute every level`: one low-force task with no structure of up to "
        f"{args.n_max} modules, searched with n_max = n (every level up to n decided: "
        "`evaluated` counts the structures decided, the rest of each level is skipped by "
        "exact level bounds). `planted optimum 12`: tasks whose certified optimum is 12. "
        "`reference` is the previous implementation on the same task; `speedup` = its wall "
        "time / the streaming search's, in this run. `peak_MB` is the run's peak resident "
        "memory (its own process, Python and numba included).",
        rows,
        "Goals of the issue:",
        *goal_lines(rows),
        "",
        how="; one process per run (workers = 1)",
    )


def main(argv: list[str] | None = None) -> None:
    options = {
        "--n-max": dict(type=int_option(8, 16), default=14, help="largest level (default 14)"),
        "--reference-n-max": dict(type=int_option(0, 16), default=12,
                                  help="largest level for the reference"),
        "--tasks": dict(type=int_option(0, 1000), default=3, help="planted optimum-12 tasks"),
    }  # fmt: skip
    args = bench_args(
        argv,
        "python -m benchmarks.scaling",
        "Time the certified exhaustive search level by level (n = 8..N) against the previous "
        "implementation; write results/search_scaling.{md,csv}.",
        options,
        outputs=("search_scaling.md", "search_scaling.csv"),
    )
    rows = run(args.seed, args.n_max, args.reference_n_max, args.tasks, args.out)
    write_report(args.out, "search_scaling", rows, report(rows, args))
    print("\n".join(goal_lines(rows)))


if __name__ == "__main__":
    raise SystemExit(run_main(main, "scaling"))
