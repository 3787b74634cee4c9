"""Oracle speed: decisions and margins per second for each method on fresh structures.

    python -m modquad_gym.bench.oracle [--structures 20] [--wrenches 80] [--seed 0]

Writes ``results/oracle_benchmark.md`` and ``results/oracle_benchmark.csv``. Structures are
random connected 7-module (m = 28 rotors) and 10-module (m = 40) ones, each seen for the first
time (no cache carried between them). Two workloads: "paper tasks" (80 wrenches of
``PaperTasks()``, what the searches and the environment see), and "boundary", which mixes
feasible and infeasible wrenches around the boundary, the hard case for certificates:
w = c + (s / gamma) (A u - c) with u ~ U(0, 1)^m, s ~ U(0.5, 1.5), c the zonotope
centre and gamma the exact boundary scale of A u - c.
Timings include every per-structure preparation (range basis, pseudo-inverse; the H-rep build
for "hrep"). Runs on one core (set OMP_NUM_THREADS=1 for stable numbers).
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

from ..oracle import Zonotope, _decide, _margin
from ..structure import Structure, free_neighbours
from . import machine_description, markdown_table, write_csv

# per method: how many of the structures to time (the slow references get fewer)
_SHARE = {"auto": 1.0, "daqp": 1.0, "hrep": 0.25, "scipy": 0.15, "cvxpy": 0.15}


def random_structure(n: int, rng: np.random.Generator) -> Structure:
    cells = [(0, 0)]
    while len(cells) < n:
        options = free_neighbours(cells)
        cells.append(options[int(rng.integers(len(options)))])
    return Structure(cells)


def boundary_mix(A: np.ndarray, t: int, rng: np.random.Generator) -> np.ndarray:
    """Wrenches at s times the boundary distance from the centre, s ~ U(0.5, 1.5): about half
    feasible, many close to the boundary (the hard case for certificates)."""
    z = Zonotope(A)
    c = A.sum(axis=1) / 2
    base = (A @ rng.uniform(0, 1, (t, A.shape[1])).T).T
    gamma = z.gamma_daqp(z.reduce(base)[0])
    return c + (base - c) * (rng.uniform(0.5, 1.5, t) / gamma)[:, None]


def run(n_structures: int, n_wrenches: int, seed: int, out: Path) -> list[dict]:
    rng = np.random.default_rng(seed)
    rows = []
    from ..tasks import PaperTasks

    paper = PaperTasks(n_wrenches=n_wrenches)
    workloads = {
        "boundary": lambda A: boundary_mix(A, n_wrenches, rng),
        "paper tasks": lambda A: paper(rng).wrenches,
    }
    for (workload, make), n in ((w, n) for w in workloads.items() for n in (7, 10)):
        cases = [random_structure(n, rng).configuration_matrix() for _ in range(n_structures)]
        cases = [(A, make(A)) for A in cases]
        feasible_share = float(np.mean([_decide(Zonotope(A), W, "daqp").mean() for A, W in cases]))
        build = []
        for A, _ in cases[: max(1, int(len(cases) * _SHARE["hrep"]))]:
            t0 = time.perf_counter()
            Zonotope(A).hrep()
            build.append(time.perf_counter() - t0)
        facets = len(Zonotope(cases[0][0]).hrep()[0])
        for method in ("scipy", "cvxpy"):  # imports and compilation happen outside the timing
            _margin(Zonotope(cases[0][0]), cases[0][1][:1], method)
        for method, share in _SHARE.items():
            subset = cases[: max(1, int(len(cases) * share))]
            timings = {}
            for kind, fn in (("decisions", _decide), ("margins", _margin)):
                t0 = time.perf_counter()
                for A, W in subset:
                    fn(Zonotope(A), W, method)
                timings[kind] = len(subset) * n_wrenches / (time.perf_counter() - t0)
            rows.append(
                {
                    "workload": workload,
                    "modules": n,
                    "rotors_m": 4 * n,
                    "method": method,
                    "structures": len(subset),
                    "decisions_per_s": timings["decisions"],
                    "margins_per_s": timings["margins"],
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
    write_report(rows, n_structures, n_wrenches, seed, out)
    return rows


def write_report(rows: list[dict], n_structures: int, n_wrenches: int, seed: int, out: Path):
    out.mkdir(parents=True, exist_ok=True)
    write_csv(rows, out / "oracle_benchmark.csv")
    text = [
        "# Oracle benchmark",
        "",
        f"Machine: {machine_description()}. One process, one thread.",
        f"Command: `python -m modquad_gym.bench.oracle --structures {n_structures} "
        f"--wrenches {n_wrenches} --seed {seed}`",
        "",
        f"{n_wrenches} wrenches per fresh random structure, paper-like tasks or mixed around "
        "the boundary (see the module docstring); every method decides the same wrenches and "
        "their decisions agree (tests/test_oracle.py checks agreement against HiGHS). Ratios "
        "are against scipy `linprog` (HiGHS) and cvxpy measured in this same run. `hrep` "
        "includes building the H-representation for each structure, so it only pays off for "
        "large batches.",
        "",
        markdown_table(rows),
        "",
        "Goals: default method >= 100,000 decisions/s at m = 28, >= 50x scipy, >= 100x cvxpy; "
        "H-representation build <= 50 ms at m = 28, memory bounded (chunked) at m = 40.",
    ]
    (out / "oracle_benchmark.md").write_text("\n".join(text) + "\n")


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(
        prog="python -m modquad_gym.bench.oracle",
        description="Measure decisions/s and margins/s of every oracle method on fresh "
        "7- and 10-module structures; write results/oracle_benchmark.{md,csv}.",
    )
    parser.add_argument("--structures", type=int, default=20, help="structures per size")
    parser.add_argument("--wrenches", type=int, default=80, help="wrenches per structure")
    parser.add_argument("--seed", type=int, default=0, help="random seed")
    parser.add_argument("--out", type=Path, default=Path("results"), help="output folder")
    args = parser.parse_args(argv)
    rows = run(args.structures, args.wrenches, args.seed, args.out)
    print(markdown_table(rows))


if __name__ == "__main__":
    main()
