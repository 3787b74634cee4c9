"""Oracle speed: decisions and margins per second for each method on fresh structures, and the
goals of issue 3, each marked "met" or "NOT met" beside the measured value.

    python -m modquad_gym.bench.oracle [--structures 20] [--wrenches 80] [--seed 0] [--repeats 3]

Writes ``results/oracle_benchmark.md`` and ``results/oracle_benchmark.csv`` (``--out`` to change
the folder). Structures are random connected 7-module (m = 28 rotors) and 10-module (m = 40)
ones, each seen for the first time (no zonotope carried between them or between passes). Two
workloads: "paper tasks" (80 wrenches of ``PaperTasks()``, what the searches and the environment
see), and "boundary", which mixes feasible and infeasible wrenches around the boundary, the hard
case for certificates: w = c + (s / gamma) (A u - c) with u ~ U(0, 1)^m, s ~ U(0.5, 1.5), c the
zonotope centre and gamma the exact boundary scale of A u - c.

Timings include every per-structure preparation (range basis, pseudo-inverse; the H-rep build
for "hrep"). Each rate is the best of ``--repeats`` passes over the same structures (the timeit
convention: the least disturbed pass), so a busy machine distorts it less. Run it on one core
(set OMP_NUM_THREADS=1) on a quiet machine; the report records the load average it saw.

Goals (issue 3): the default method >= 100,000 decisions/s at m = 28 on every workload, >= 50x
scipy ``linprog`` and >= 100x cvxpy in the same run; H-representation build <= 50 ms at m = 28;
memory of the H-representation build bounded at m = 40 (chunked; peak traced by ``tracemalloc``
at most ``HREP_MEMORY_LIMIT_MB``).
"""

from __future__ import annotations

import os
import time
import tracemalloc
from pathlib import Path

import numpy as np

from modquad_gym.bench import (
    bench_args,
    int_option,
    machine_description,
    markdown_table,
    random_structure,
    write_csv,
)
from modquad_gym.core.outputs import write_text
from modquad_gym.oracle import BAND, TOL, Zonotope, decide_with, margin_with
from modquad_gym.oracle.daqp_lp import gamma_daqp

# per method: how many of the structures to time (the slow references get fewer)
_SHARE = {"auto": 1.0, "daqp": 1.0, "hrep": 0.25, "scipy": 0.15, "cvxpy": 0.15}

DECISIONS_GOAL = 100_000.0
SCIPY_RATIO_GOAL = 50.0
CVXPY_RATIO_GOAL = 100.0
HREP_BUILD_GOAL_MS = 50.0
HREP_MEMORY_LIMIT_MB = 256.0


def boundary_mix(A: np.ndarray, t: int, rng: np.random.Generator) -> np.ndarray:
    """Wrenches at s times the boundary distance from the centre, s ~ U(0.5, 1.5): about half
    feasible, many close to the boundary (the hard case for certificates)."""
    z = Zonotope(A)
    c = A.sum(axis=1) / 2
    base = (A @ rng.uniform(0, 1, (t, A.shape[1])).T).T
    gamma = gamma_daqp(z, z.reduce(base)[0])
    return c + (base - c) * (rng.uniform(0.5, 1.5, t) / gamma)[:, None]


def _best_rate(fn, cases: list, method: str, repeats: int) -> float:
    """Wrenches per second of ``fn(Zonotope(A), W, method)`` over the cases: best pass."""
    n = sum(len(W) for _, W in cases)
    best = np.inf
    for _ in range(max(1, repeats)):
        t0 = time.perf_counter()
        for A, W in cases:
            fn(Zonotope(A), W, method)
        best = min(best, time.perf_counter() - t0)
    return n / best


def hrep_build(A: np.ndarray, memory: bool = False) -> tuple[float, float, int]:
    """(seconds, peak traced MB or nan, facets) of one H-representation build from scratch."""
    z = Zonotope(A)
    if memory:
        tracemalloc.start()
    t0 = time.perf_counter()
    N, _ = z.hrep()
    seconds = time.perf_counter() - t0
    peak = np.nan
    if memory:
        peak = tracemalloc.get_traced_memory()[1] / 1e6
        tracemalloc.stop()
    return seconds, peak, len(N)


def run(
    n_structures: int, n_wrenches: int, seed: int, out: Path, repeats: int = 3
) -> tuple[list[dict], list[dict]]:
    rng = np.random.default_rng(seed)
    load = _load_average()
    rows = []
    builds: dict[int, list[float]] = {}
    from modquad_gym.tasks import PaperTasks

    paper = PaperTasks(n_wrenches=n_wrenches)
    workloads = {
        "boundary": lambda A: boundary_mix(A, n_wrenches, rng),
        "paper tasks": lambda A: paper(rng).wrenches,
    }
    for (workload, make), n in ((w, n) for w in workloads.items() for n in (7, 10)):
        cases = [random_structure(n, rng).configuration_matrix() for _ in range(n_structures)]
        cases = [(A, make(A)) for A in cases]
        shares = [decide_with(Zonotope(A), W, "daqp").mean() for A, W in cases]
        feasible_share = float(np.mean(shares))
        build = []
        for A, _ in cases[: max(1, int(len(cases) * _SHARE["hrep"]))]:
            build.append(min(hrep_build(A)[0] for _ in range(max(1, repeats))))
        builds.setdefault(n, []).extend(build)
        facets = hrep_build(cases[0][0])[2]
        for method in ("scipy", "cvxpy"):  # imports and compilation happen outside the timing
            margin_with(Zonotope(cases[0][0]), cases[0][1][:1], method)
        for method, share in _SHARE.items():
            subset = cases[: max(1, int(len(cases) * share))]
            rows.append(
                {
                    "workload": workload,
                    "modules": n,
                    "rotors_m": 4 * n,
                    "method": method,
                    "structures": len(subset),
                    "decisions_per_s": _best_rate(decide_with, subset, method, repeats),
                    "margins_per_s": _best_rate(margin_with, subset, method, repeats),
                }
            )
        here = [r for r in rows if r["modules"] == n and r["workload"] == workload]
        base = {r["method"]: r for r in here}
        for r in here:
            r["decisions_vs_scipy"] = r["decisions_per_s"] / base["scipy"]["decisions_per_s"]
            r["decisions_vs_cvxpy"] = r["decisions_per_s"] / base["cvxpy"]["decisions_per_s"]
            r["margins_vs_scipy"] = r["margins_per_s"] / base["scipy"]["margins_per_s"]
            r["feasible_share"] = feasible_share
            r["hrep_build_ms"] = 1e3 * float(np.median(build))
            r["hrep_facets"] = facets
    # memory of the H-representation build at m = 40, traced once on a fresh structure
    seconds, peak, facets = hrep_build(random_structure(10, rng).configuration_matrix(), True)
    goals = evaluate_goals(rows, builds, peak, facets)
    write_report(rows, goals, n_structures, n_wrenches, seed, repeats, load, out)
    return rows, goals


def evaluate_goals(
    rows: list[dict], builds: dict[int, list[float]], peak_mb: float, facets_40: int
) -> list[dict]:
    """Each goal of issue 3 with its target, the measured value and "met"/"NOT met"."""
    auto = [r for r in rows if r["method"] == "auto" and r["modules"] == 7]

    def per_workload(key: str, fmt: str) -> str:
        return "; ".join(f"{r['workload']}: {format(r[key], fmt)}" for r in auto)

    def status(ok: bool) -> str:
        return "met" if ok else "NOT met"

    build_ms = 1e3 * float(np.median(builds.get(7, [np.nan])))
    goals = [
        (
            "default method decisions/s at m = 28 (every workload)",
            f">= {DECISIONS_GOAL:,.0f}",
            per_workload("decisions_per_s", ",.0f"),
            all(r["decisions_per_s"] >= DECISIONS_GOAL for r in auto),
        ),
        (
            "default method vs scipy linprog, decisions at m = 28",
            f">= {SCIPY_RATIO_GOAL:.0f}x",
            per_workload("decisions_vs_scipy", ".0f"),
            all(r["decisions_vs_scipy"] >= SCIPY_RATIO_GOAL for r in auto),
        ),
        (
            "default method vs cvxpy, decisions at m = 28",
            f">= {CVXPY_RATIO_GOAL:.0f}x",
            per_workload("decisions_vs_cvxpy", ".0f"),
            all(r["decisions_vs_cvxpy"] >= CVXPY_RATIO_GOAL for r in auto),
        ),
        (
            "H-representation build at m = 28 (median)",
            f"<= {HREP_BUILD_GOAL_MS:.0f} ms",
            f"{build_ms:.1f} ms",
            build_ms <= HREP_BUILD_GOAL_MS,
        ),
        (
            "H-representation build memory at m = 40 (chunked, peak traced)",
            f"<= {HREP_MEMORY_LIMIT_MB:.0f} MB",
            f"{peak_mb:.0f} MB ({facets_40:,} facets)",
            peak_mb <= HREP_MEMORY_LIMIT_MB,
        ),
    ]
    return [
        {"goal": g, "target": t, "measured": m, "status": status(bool(ok))} for g, t, m, ok in goals
    ]


def _load_average() -> str:
    try:
        return ", ".join(f"{x:.2f}" for x in os.getloadavg())
    except OSError:  # pragma: no cover - not on every platform
        return "unknown"


def write_report(
    rows: list[dict],
    goals: list[dict],
    n_structures: int,
    n_wrenches: int,
    seed: int,
    repeats: int,
    load: str,
    out: Path,
) -> None:
    out.mkdir(parents=True, exist_ok=True)
    write_csv(rows, out / "oracle_benchmark.csv")
    threads = os.environ.get("OMP_NUM_THREADS", "unset")
    text = [
        "# Oracle benchmark",
        "",
        f"Machine: {machine_description()}. One process; OMP_NUM_THREADS={threads}; "
        f"load average (1, 5, 15 min) at the start: {load}.",
        f"Command: `python -m modquad_gym.bench.oracle --structures {n_structures} "
        f"--wrenches {n_wrenches} --seed {seed} --repeats {repeats}`",
        "",
        "## Goals (issue 3)",
        "",
        markdown_table(goals),
        "",
        "## Measurements",
        "",
        f"{n_wrenches} wrenches per fresh random structure, paper-like tasks or mixed around "
        "the boundary (see the module docstring); every method decides the same wrenches and "
        "their decisions agree (tests/test_oracle.py checks every method against HiGHS). "
        f"Each rate is the best of {repeats} passes. Ratios are against scipy `linprog` "
        "(HiGHS) and cvxpy measured in this same run. `hrep` includes building the "
        "H-representation for each structure, so it only pays off for large batches.",
        "",
        f"Tolerance rule (every method): feasible exactly when gamma <= 1 + {TOL:g}; methods "
        f"agree outside |gamma - (1 + TOL)| <= {BAND:g} (see `modquad_gym/oracle/tolerance.py`).",
        "",
        markdown_table(rows),
    ]
    write_text(out / "oracle_benchmark.md", "\n".join(text) + "\n")


def main(argv: list[str] | None = None) -> None:
    options = {
        "--structures": dict(type=int_option(1), default=20, help="structures per size"),
        "--wrenches": dict(type=int_option(1), default=80, help="wrenches per structure"),
        "--repeats": dict(type=int_option(1, 100), default=3, help="passes per timing (best kept)"),
    }  # fmt: skip
    args = bench_args(
        argv,
        "python -m modquad_gym.bench.oracle",
        "Measure decisions/s and margins/s of every oracle method on fresh 7- and 10-module "
        "structures, check the goals of issue 3; write results/oracle_benchmark.{md,csv}.",
        options,
        seed_help="random seed",
        outputs=("oracle_benchmark.md", "oracle_benchmark.csv"),
    )
    rows, goals = run(args.structures, args.wrenches, args.seed, args.out, args.repeats)
    print(markdown_table(goals))
    print()
    print(markdown_table(rows))


if __name__ == "__main__":
    main()
