"""Oracle speed: decisions and margins per second for each method on fresh structures of 7 to
64 modules, and the goals of issues 3 and 26, each marked "met" or "NOT met" beside the measured
value.

    python -m benchmarks.oracle [--structures 20] [--wrenches 80] [--seed 0] [--repeats 3]
                         [--modules 7,10,16,32,64]

Writes ``results/oracle_benchmark.md`` and ``results/oracle_benchmark.csv`` (``--out`` to change
the folder). Structures are random connected ones of each size in ``--modules`` (m = 4 n
rotors), each seen for the first time (no zonotope carried between them or between passes). Two
workloads: "paper tasks" (random wrenches of ``PaperTasks()``, what the searches and the
environment see), and "boundary", which mixes feasible and infeasible wrenches around the
boundary, the hard case for certificates: w = c + (s / gamma) (A u - c) with u ~ U(0, 1)^m,
s ~ U(0.5, 1.5), c the zonotope centre and gamma the exact boundary scale of A u - c. The slow
references run on a share of the structures (cvxpy and the H-representation up to 10 modules
only: their cost explodes with m).

Timings include every per-structure preparation (range basis, pseudo-inverse; the H-rep build
for "hrep"). Each rate is the best of ``--repeats`` passes over the same structures (the timeit
convention: the least disturbed pass), so a busy machine distorts it less. Run it on one core
(set OMP_NUM_THREADS=1) on a quiet machine; the report records the load average it saw.

Goals (issue 3): the default method >= 100,000 decisions/s at m = 28 on every workload, >= 50x
scipy ``linprog`` and >= 100x cvxpy in the same run; H-representation build <= 50 ms at m = 28;
memory of the H-representation build bounded at m = 40 (chunked; peak traced by ``tracemalloc``
at most ``HREP_MEMORY_LIMIT_MB``). Issue 26: >= 20,000 decisions/s at m = 256 (64 modules) on the
boundary workload, with its ratio to HiGHS in the same run.
"""

from __future__ import annotations

import argparse
import importlib.util
import os
import time
import tracemalloc
from pathlib import Path

import numpy as np

from benchmarks.common import (
    bench_args,
    int_option,
    load_average,
    machine_description,
    markdown_table,
    random_structure,
    repeats,
    run_main,
    write_csv,
)
from benchmarks.reference_oracle import register
from benchmarks.reference_oracle.hrep import zonotope_hrep
from modquad_gym.core.extras import missing_extra_message
from modquad_gym.core.options import parse_integer
from modquad_gym.core.outputs import write_text
from modquad_gym.oracle import BAND, TOL, Zonotope
from modquad_gym.oracle.backends import decide_with, margin_with  # unchecked: the kernels
from modquad_gym.oracle.daqp_lp import gamma_daqp

register()  # the reference methods it times beside the product's

# per method: how many of the structures to time (the slow references get fewer), and the
# largest structure (modules) it is timed on
_SHARE = {"auto": 1.0, "compiled": 1.0, "certified": 0.25, "daqp": 0.5, "hrep": 0.25,
          "scipy": 0.1, "cvxpy": 0.1}  # fmt: skip
_UP_TO = {"hrep": 10, "cvxpy": 10}
SIZES = (7, 10, 16, 32, 64)

DECISIONS_GOAL = 100_000.0
LARGE_GOAL = 20_000.0  # decisions/s at m = 256, boundary workload (issue 26)
SCIPY_RATIO_GOAL = 50.0
CVXPY_RATIO_GOAL = 100.0
HREP_BUILD_GOAL_MS = 50.0
HREP_MEMORY_LIMIT_MB = 256.0


def sizes_option(text: str) -> tuple[int, ...]:
    """``--modules``: comma-separated structure sizes, each from 7 (the goals of issue 3 are
    at m = 28) to 64, each once (a size given twice would be timed and counted twice)."""
    try:
        sizes = tuple(parse_integer(v) for v in text.split(","))
    except ValueError:
        sizes = ()
    if not sizes or any(not 7 <= n <= 64 for n in sizes):
        raise argparse.ArgumentTypeError(f"expected sizes from 7 to 64 like 7,16,64, got {text}")
    twice = repeats(sizes)
    if twice:
        raise argparse.ArgumentTypeError(f"{twice[0]} is given twice in {text}")
    return sizes


def boundary_mix(A: np.ndarray, t: int, rng: np.random.Generator) -> np.ndarray:
    """Wrenches at s times the boundary distance from the centre, s ~ U(0.5, 1.5): about half
    feasible, many close to the boundary (the hard case for certificates)."""
    z = Zonotope(A)
    c = A.sum(axis=1) / 2
    base = (A @ rng.uniform(0, 1, (t, A.shape[1])).T).T
    gamma = gamma_daqp(z, z.reduce(base)[0])
    return c + (base - c) * (rng.uniform(0.5, 1.5, t) / gamma)[:, None]


def _best_rate(fn, cases: list, method: str, repeats: int) -> tuple[float, float]:
    """Wrenches per second of ``fn(Zonotope(A), W, method)`` over the cases, by the wall clock
    and by this process's CPU time (less distorted by other processes): best passes."""
    n = sum(len(W) for _, W in cases)
    wall = cpu = np.inf
    for _ in range(max(1, repeats)):
        t0, c0 = time.perf_counter(), time.process_time()
        for A, W in cases:
            fn(Zonotope(A), W, method)
        wall = min(wall, time.perf_counter() - t0)
        cpu = min(cpu, max(time.process_time() - c0, 1e-9))
    return n / wall, n / cpu


def hrep_build(A: np.ndarray, memory: bool = False) -> tuple[float, float, int]:
    """(seconds, peak traced MB or nan, facets) of one H-representation build from scratch."""
    z = Zonotope(A)
    if memory:
        tracemalloc.start()
    t0 = time.perf_counter()
    N, _ = zonotope_hrep(z)
    seconds = time.perf_counter() - t0
    peak = np.nan
    if memory:
        peak = tracemalloc.get_traced_memory()[1] / 1e6
        tracemalloc.stop()
    return seconds, peak, len(N)


def run(
    n_structures: int,
    n_wrenches: int,
    seed: int,
    out: Path,
    repeats: int = 3,
    sizes: tuple[int, ...] = SIZES,
) -> tuple[list[dict], list[dict]]:
    rng = np.random.default_rng(seed)
    load = _load_average()
    rows: list[dict] = []
    builds: dict[int, list[float]] = {}
    from modquad_gym.tasks import PaperTasks

    paper = PaperTasks(n_wrenches=n_wrenches)
    workloads = {
        "boundary": lambda A: boundary_mix(A, n_wrenches, rng),
        "paper tasks": lambda A: paper(rng).wrenches,
    }
    for (workload, make), n in ((w, n) for w in workloads.items() for n in sizes):
        cases = [random_structure(n, rng).configuration_matrix() for _ in range(n_structures)]
        cases = [(A, make(A)) for A in cases]
        shares = [decide_with(Zonotope(A), W, "compiled").mean() for A, W in cases]
        methods = [k for k in _SHARE if n <= _UP_TO.get(k, n)]
        build, facets = [], 0
        if "hrep" in methods:
            for A, _ in cases[: max(1, int(len(cases) * _SHARE["hrep"]))]:
                build.append(min(hrep_build(A)[0] for _ in range(max(1, repeats))))
            builds.setdefault(n, []).extend(build)
            facets = hrep_build(cases[0][0])[2]
        for method in methods:  # imports and compilation happen outside the timing
            margin_with(Zonotope(cases[0][0]), cases[0][1][:1], method)
            decide_with(Zonotope(cases[0][0]), cases[0][1][:1], method)
        here = [_time_method(cases, method, repeats) for method in methods]
        base = {r["method"]: r for r in here}
        for r in here:
            r.update(workload=workload, modules=n, rotors_m=4 * n)
            r["decisions_vs_scipy"] = r["decisions_per_s"] / base["scipy"]["decisions_per_s"]
            cvx = base.get("cvxpy", {}).get("decisions_per_s", np.nan)
            r["decisions_vs_cvxpy"] = r["decisions_per_s"] / cvx
            r["margins_vs_scipy"] = r["margins_per_s"] / base["scipy"]["margins_per_s"]
            r["feasible_share"] = float(np.mean(shares))
            r["hrep_build_ms"] = 1e3 * float(np.median(build)) if build else np.nan
            r["hrep_facets"] = facets
        rows.extend(here)
    # memory of the H-representation build at m = 40, traced once on a fresh structure
    seconds, peak, facets = hrep_build(random_structure(10, rng).configuration_matrix(), True)
    goals = evaluate_goals(rows, builds, peak, facets)
    write_report(rows, goals, n_structures, n_wrenches, seed, repeats, load, out, sizes)
    return rows, goals


def _time_method(cases: list, method: str, repeats: int) -> dict:
    """A row of measurements of ``method`` on its share of the cases (columns in report order:
    the caller adds the workload and the ratios)."""
    subset = cases[: max(1, int(len(cases) * _SHARE[method]))]
    decisions, decisions_cpu = _best_rate(decide_with, subset, method, repeats)
    return {
        "workload": "",
        "modules": 0,
        "rotors_m": 0,
        "method": method,
        "structures": len(subset),
        "decisions_per_s": decisions,
        "decisions_per_cpu_s": decisions_cpu,
        "margins_per_s": _best_rate(margin_with, subset, method, repeats)[0],
    }


def evaluate_goals(
    rows: list[dict], builds: dict[int, list[float]], peak_mb: float, facets_40: int
) -> list[dict]:
    """Each goal of issues 3 (when 7 modules were measured) and 26 (when 64 were) with its
    target, the measured value and "met"/"NOT met"."""
    auto = [r for r in rows if r["method"] == "auto" and r["modules"] == 7]
    large = [r for r in rows if r["method"] == "auto" and r["rotors_m"] == 256]
    large = [r for r in large if r["workload"] == "boundary"]
    goals = _small_goals(auto, builds, peak_mb, facets_40) if auto else []
    if large:  # issue 26
        r = large[0]
        goals.append(
            (
                "default method decisions/s at m = 256, boundary workload (issue 26)",
                f">= {LARGE_GOAL:,.0f}",
                f"{r['decisions_per_s']:,.0f} ({r['decisions_per_cpu_s']:,.0f} per CPU second; "
                f"{r['decisions_vs_scipy']:,.0f}x HiGHS in this run)",
                r["decisions_per_s"] >= LARGE_GOAL,
            )
        )
    return [
        {"goal": g, "target": t, "measured": m, "status": "met" if ok else "NOT met"}
        for g, t, m, ok in goals
    ]


def _small_goals(auto: list[dict], builds: dict, peak_mb: float, facets_40: int) -> list:
    """The goals of issue 3 (m = 28; the H-representation) as (goal, target, measured, ok)."""

    def per_workload(key: str, fmt: str) -> str:
        return "; ".join(f"{r['workload']}: {format(r[key], fmt)}" for r in auto)

    build_ms = 1e3 * float(np.median(builds.get(7, [np.nan])))
    return [
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


GOAL_SIZES = {7: "issue 3, m = 28", 64: "issue 26, m = 256"}
"""The sizes (modules) the goals are measured at, and which goals."""


def goals_text(goals: list[dict], sizes: tuple[int, ...]) -> str:
    """The goals' table, then a line naming the goals ``sizes`` (``--modules``) left
    unmeasured and the size each needs (every size list gives a report)."""
    lacking = [
        f"{what} (give {n} in --modules)" for n, what in GOAL_SIZES.items() if n not in sizes
    ]
    lines = [markdown_table(goals)] if goals else []
    if lacking:
        lines.append(f"Not measured in this run: the goals of {' and '.join(lacking)}.")
    return "\n\n".join(lines)


def _load_average() -> str:
    try:
        return load_average(", ")
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
    sizes: tuple[int, ...] = SIZES,
) -> None:
    out.mkdir(parents=True, exist_ok=True)
    write_csv(rows, out / "oracle_benchmark.csv")
    threads = os.environ.get("OMP_NUM_THREADS", "unset")
    text = [
        "# Oracle benchmark",
        "",
        f"Machine: {machine_description()}. One process; OMP_NUM_THREADS={threads}; "
        f"load average (1, 5, 15 min) at the start: {load}.",
        f"Command: `python -m benchmarks.oracle --structures {n_structures} "
        f"--wrenches {n_wrenches} "
        f"--seed {seed} --repeats {repeats} --modules {','.join(map(str, sizes))}`",
        "",
        "## Goals (issues 3 and 26)",
        "",
        goals_text(goals, sizes),
        "",
        "## Measurements",
        "",
        f"{n_wrenches} wrenches per fresh random structure, paper-like tasks or mixed around "
        "the boundary (see the module docstring); every method decides the same wrenches and "
        "their decisions agree (tests/test_oracle.py and tests/test_oracle_compiled.py check "
        "every method against HiGHS). "
        f"Each rate is the best of {repeats} passes by the wall clock (`decisions_per_cpu_s`: "
        "by this process's CPU time, which other processes on a busy machine distort less; "
        "compare methods by their ratios within one size). Ratios are against scipy `linprog` "
        "(HiGHS) and cvxpy measured in this same run. `auto` and `compiled` decide alike (the "
        "compiled dual simplex, `modquad_gym/oracle/walk.py`); their margins differ: DAQP's "
        "gamma for `auto`, the walk run to the optimum for `compiled`. `certified` is the "
        "numpy certificates (the default before the compiled walk). `hrep` includes building "
        "the H-representation for each structure, so it only pays off for large batches.",
        "",
        f"Tolerance rule (every method): feasible exactly when gamma <= 1 + {TOL:g}; methods "
        f"agree outside |gamma - (1 + TOL)| <= {BAND:g} (see `modquad_gym/oracle/tolerance.py`).",
        "",
        markdown_table(rows),
    ]
    write_text(out / "oracle_benchmark.md", "\n".join(text) + "\n")


def main(argv: list[str] | None = None) -> None:
    options = {
        "--structures": dict(type=int_option(1, 1000), default=20, help="structures per size"),
        "--wrenches": dict(type=int_option(1, 10_000), default=80, help="wrenches per structure"),
        "--repeats": dict(type=int_option(1, 100), default=3, help="passes per timing (best kept)"),
        "--modules": dict(type=sizes_option, default=SIZES,
                          help="structure sizes, comma-separated, each 7..64 (default "
                          f"{','.join(map(str, SIZES))}: m = 28 .. 256 rotors)"),
    }  # fmt: skip
    args = bench_args(
        argv,
        "python -m benchmarks.oracle",
        "Measure decisions/s and margins/s of every oracle method on fresh structures of 7 to "
        "64 modules (boundary-heavy and random wrenches, ratios to HiGHS in the same run), "
        "check the goals of issues 3 and 26; write results/oracle_benchmark.{md,csv}.",
        options,
        seed_help="random seed",
        outputs=("oracle_benchmark.md", "oracle_benchmark.csv"),
    )
    if importlib.util.find_spec("cvxpy") is None:  # a reference it times: say so before work
        raise ImportError(missing_extra_message("cvxpy"))
    rows, goals = run(
        args.structures, args.wrenches, args.seed, args.out, args.repeats, args.modules
    )
    print(goals_text(goals, args.modules))
    print()
    print(markdown_table(rows))


if __name__ == "__main__":
    raise SystemExit(run_main(main, "oracle"))
