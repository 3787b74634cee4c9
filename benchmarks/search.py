"""Search speed: the certified exhaustive search against a plain reference on the same
enumeration (one scipy/HiGHS LP per wrench, stopping at a structure's first infeasible wrench).

    python -m benchmarks.search [--tasks 4] [--seed 0] [--reference-structures 300]

Writes ``results/search_benchmark.md`` and ``.csv``. Four workloads:
* ``optimum 8``: planted tasks whose certified optimum is 8 modules, searched with n_max = 8.
  Their forces are large, so the exact force bound skips most small levels (few evaluations);
* ``optimum 8, low force``: wrenches of a hidden 8-module structure with small forces (the
  force bound allows one module, no level is skipped) and torques that only 8 modules reach,
  searched with n_max = 8: levels 1-7 (1,067 structures) are all evaluated, then level 8 up to
  the first feasible structure;
* ``none up to 8, low force``: the same with a hidden 9-module structure (so the optimum is
  exactly 9), searched with n_max = 8: all 3,792 structures are evaluated;
* ``none up to 10``: torque-heavy tasks that no structure of up to 10 modules satisfies,
  searched with n_max = 10 (every one of the 50,148 structures above the force bound).
The reference is timed on a prefix of the same enumeration (its structures/s is what compares);
its full time is extrapolated and marked as such.
"""

from __future__ import annotations

import os
import time
from pathlib import Path

import numpy as np

from benchmarks.common import (
    bench_args,
    int_option,
    machine_description,
    markdown_table,
    random_structure,
    run_main,
    write_report,
)
from modquad_gym.geometry.polyominoes import PolyominoStream
from modquad_gym.geometry.structure import Structure, normalise
from modquad_gym.oracle import Zonotope, decide_from_gamma
from modquad_gym.oracle.highs_lp import gamma_highs
from modquad_gym.scoring.scale_tasks import low_force_task  # noqa: F401 - used by the benchmarks
from modquad_gym.search import exhaustive_search, force_lower_bound


def planted_task(n: int, t: int, rng: np.random.Generator) -> np.ndarray:
    """Wrenches of a hidden random n-module structure, most at 0/1 rotor vertices."""
    A = random_structure(n, rng).configuration_matrix()
    U = rng.uniform(0, 1, (t, A.shape[1]))
    vertex = rng.uniform(size=U.shape) < 0.9
    U[vertex] = rng.integers(0, 2, int(vertex.sum()))
    return (A @ U.T).T


def torque_task(t: int, rng: np.random.Generator) -> np.ndarray:
    W = np.zeros((t, 6))
    W[:, 2] = rng.uniform(2.0, 4.0, t)
    W[:, 3:] = rng.normal(scale=1.5, size=(t, 3))
    return W


def reference_rate(W: np.ndarray, n_max: int, limit: int) -> tuple[float, int]:
    """Structures/s of the plain reference on the first ``limit`` structures it must check."""
    n_lb = force_lower_bound(W, Structure([(0, 0)]).module)
    keys = [
        normalise(map(tuple, cells.tolist()))
        for n in range(n_lb, n_max + 1)
        for block in PolyominoStream(n)
        for cells in block
    ][:limit]
    t0 = time.perf_counter()
    for key in keys:
        z = Zonotope(Structure.from_trusted(key).configuration_matrix())
        R, off = z.reduce(W)
        for i in range(len(W)):
            if off[i] or not decide_from_gamma(gamma_highs(z, R[i : i + 1]))[0]:
                break
    return len(keys) / (time.perf_counter() - t0), len(keys)


def _count(workloads: list[tuple[str, int, np.ndarray]], name: str) -> int:
    return sum(w[0] == name for w in workloads)


def _span(values: list[int]) -> str:
    lo, hi = min(values), max(values)
    return str(lo) if lo == hi else f"{lo}-{hi}"


def _levels_text(levels: list[int]) -> str:
    """Skipped levels (consecutive, from 1) as text: "none", "1" or "1-6"."""
    return _span(levels) if levels else "none"


def _goal_lines(rows: list[dict], machine: str) -> list[str]:
    """Each speed goal of the issue with its measured value and "met" / "NOT met"."""

    def worst(names: tuple[str, ...]) -> dict:
        return max((r for r in rows if r["workload"] in names), key=lambda r: r["seconds"])

    r8 = worst(("optimum 8", "optimum 8, low force"))
    full8 = worst(("none up to 8, low force",))
    r10 = worst(("none up to 10",))
    low = [r["evaluated"] for r in rows if r["workload"] == "optimum 8, low force"]
    speedups = [r["speedup"] for r in rows]
    ok8 = r8["seconds"] < 0.5 and full8["seconds"] < 0.5

    def mark(ok: bool) -> str:
        return "met" if ok else "NOT met"

    return [
        f"Goals of the issue, measured in this run on {machine} (1-minute load average "
        f"{os.getloadavg()[0]:.2f} when the report was written; above ~1 means another job "
        f"shared the CPUs):",
        "",
        f"- Certified exhaustive search to n_max = 8 on tasks whose optimum is 8 in well under "
        f"a second (read as < 0.5 s): **{mark(ok8)}**. Slowest optimum-8 task "
        f"{r8['seconds']:.3f} s ({r8['workload']}, {r8['evaluated']} evaluated); the "
        f"low-force optimum-8 tasks skip no level and evaluate {_span(low)} "
        f"structures (all 1,067 of levels 1-7, then level 8 up to the first feasible one); "
        f"the whole n_max = 8 enumeration ({full8['evaluated']} of 3,792 structures, optimum "
        f"9) takes at most {full8['seconds']:.3f} s.",
        f"- n_max = 10 (50,148 structures) in <= 10 s: **{mark(r10['seconds'] <= 10)}**. "
        f"Slowest {r10['seconds']:.3f} s for {r10['evaluated']} evaluated (skipped by the "
        f"exact force bound: {_levels_text(r10['skipped_levels_list'])}).",
        f"- Compared with the plain reference (scipy/HiGHS LP per wrench, same enumeration) "
        f"in the same run: **met**. Speedup {min(speedups):.0f}x to {max(speedups):.0f}x in "
        f"structures/s; the reference is timed on a prefix of the enumeration and "
        f"extrapolated.",
    ]


def run(n_tasks: int, seed: int, ref_limit: int, out: Path) -> list[dict]:
    """Time every workload, write ``search_benchmark.{md,csv}`` into ``out``; the rows."""
    rng = np.random.default_rng(seed)
    t0 = time.perf_counter()
    sum(len(block) for n in range(1, 11) for block in PolyominoStream(n))
    enum_seconds = time.perf_counter() - t0
    rows = [_measure(name, n_max, W, ref_limit) for name, n_max, W in _workloads(n_tasks, rng)]
    machine = machine_description()
    goals = _goal_lines(rows, machine)
    for r in rows:
        del r["skipped_levels_list"]
    text = _report(rows, goals, machine, n_tasks, seed, ref_limit, enum_seconds)
    write_report(out, "search_benchmark", rows, text)
    return rows


def _workloads(n_tasks: int, rng: np.random.Generator) -> list[tuple[str, int, np.ndarray]]:
    """(name, n_max, wrenches) of every task of the four workloads (module docstring)."""
    workloads: list[tuple[str, int, np.ndarray]] = []
    while _count(workloads, "optimum 8") < n_tasks:
        W = planted_task(8, 80, rng)
        if exhaustive_search(W, n_max=8).n_modules == 8:  # certified: levels 1-7 fail
            workloads.append(("optimum 8", 8, W))
    while _count(workloads, "none up to 10") < max(1, n_tasks // 2):
        W = torque_task(40, rng)
        workloads.append(("none up to 10", 10, W))
    while _count(workloads, "optimum 8, low force") < n_tasks:
        W = low_force_task(random_structure(8, rng), 40, rng)
        if exhaustive_search(W, n_max=8).n_modules == 8:
            workloads.append(("optimum 8, low force", 8, W))
    while _count(workloads, "none up to 8, low force") < max(1, n_tasks // 2):
        W = low_force_task(random_structure(9, rng), 40, rng)  # the hidden 9 works
        if exhaustive_search(W, n_max=8).structure is None:  # so the optimum is 9
            workloads.append(("none up to 8, low force", 8, W))
    return workloads


def _measure(name: str, n_max: int, W: np.ndarray, ref_limit: int) -> dict:
    """One workload task: the certified search against the reference's rate."""
    res = exhaustive_search(W, n_max=n_max)
    rate, checked = reference_rate(W, n_max, ref_limit)
    ours = res.evaluated / res.seconds
    return {
        "workload": name,
        "n_max": n_max,
        "found_modules": res.n_modules if res.n_modules else "none",
        "force_bound": force_lower_bound(W, Structure([(0, 0)]).module),
        "skipped_levels": _levels_text(res.skipped_levels),
        "skipped_levels_list": res.skipped_levels,
        "evaluated": res.evaluated,
        "oracle_calls": res.oracle_calls,
        "seconds": res.seconds,
        "structures_per_s": ours,
        "reference_structures_per_s": rate,
        "reference_checked": checked,
        "reference_seconds_extrapolated": res.evaluated / rate,
        "speedup": ours / rate,
    }


def _report(rows, goals, machine, n_tasks, seed, ref_limit, enum_seconds) -> str:
    """The text of ``search_benchmark.md``."""
    text = [
        "# Search benchmark",
        "",
        f"Machine: {machine}. One process.",
        f"Command: `python -m benchmarks.search --tasks {n_tasks} --seed {seed} "
        f"--reference-structures {ref_limit}`",
        "",
        f"Enumerating every structure up to 10 modules (50,148) took {enum_seconds:.2f} s, once "
        "per process (cached; not included in the per-search seconds below).",
        "",
        "Workloads: `optimum 8` are planted tasks with large forces, so the exact force bound "
        "(`force_bound`, the smallest module count whose force set holds every task force) "
        "skips most levels; `optimum 8, low force` are wrenches of a hidden 8-module structure "
        "with forces one module can exert and torques near the hidden structure's limit, "
        "certified optimum 8, so every level is searched (levels 1-7 hold 1,067 structures, "
        "then level 8 is searched up to its first feasible structure); `none up to 8, low "
        "force` is the same with a hidden 9-module structure (optimum 9), so all 3,792 "
        "structures up to 8 modules are evaluated; `none up to 10` are torque-heavy tasks no "
        "structure of up to 10 modules satisfies.",
        "",
        "`seconds` is the certified exhaustive search; the reference is the same enumeration "
        "with one scipy/HiGHS LP per wrench (stopping at a structure's first infeasible "
        "wrench), timed on a prefix, its first `reference_checked` structures, and "
        "extrapolated to the same number of evaluations (`reference_seconds_extrapolated`; "
        "`speedup` = ratio of structures/s in this run). The prefix holds the smallest "
        "structures, whose LPs are the cheapest, so the extrapolation likely understates the "
        "reference's full time.",
        "",
        markdown_table(rows),
        "",
        *goals,
        "",
        "For comparison the paper's reference script needs about 23 s to check a single "
        "4-module structure.",
    ]
    return "\n".join(text) + "\n"


def main(argv: list[str] | None = None) -> None:
    options = {
        "--tasks": dict(type=int_option(1, 1000), default=4, help="tasks per workload"),
        "--reference-structures": dict(type=int_option(1), default=300,
                                       help="structures the slow reference checks per task"),
    }  # fmt: skip
    args = bench_args(
        argv,
        "python -m benchmarks.search",
        "Time the certified exhaustive search against a plain LP reference; write "
        "results/search_benchmark.{md,csv}.",
        options,
        outputs=("search_benchmark.md", "search_benchmark.csv"),
    )
    rows = run(args.tasks, args.seed, args.reference_structures, args.out)
    print(markdown_table(rows))


if __name__ == "__main__":
    raise SystemExit(run_main(main, "search"))
