"""Two rotor failures: the certified minimum per benchmark task, and how fast tolerance is decided.

    python -m benchmarks.fault_rotor2 --per-suite 10 --time-limit 30 --out results/faults/rotor2

For the first ``--per-suite`` tasks of the fault tier's suite, the held-out paper-like and
planted suites and the dynamic suite (those of benchmarks/faults.py): the default search's intact
minimum and its minimum structure that still exerts every task wrench after ANY two rotors stop
(``fault="rotor2"``), with the search's wall time (issue 47's goal: certified within 30 s
wherever the intact optimum is at most 6 modules); every answer re-verified by an LP (DAQP) on
each failed matrix. ``--suites`` re-runs some suites and keeps the rows of the others already in
``--out``. The oracle part times ``mq.tolerates(..., fault="rotor2")`` against ``mq.feasible``
as benchmarks/fault_price.py does (its 7-module structure, m = 28 rotors, 378 pairs; its
wrenches inside W), best of ``--repeats`` (one process), and counts which test of the pair
certificate settled each (wrench, pair). Writes report.md, minima.csv and oracle.csv into
``--out``.
"""

from __future__ import annotations

import csv
import io
import os
import sys
import time
from pathlib import Path

import numpy as np

import modquad_gym as mq
from benchmarks.common import (
    Distinct,
    bench_args,
    command_as_run,
    made_by,
    markdown_table,
    read_input_text,
    run_main,
    write_csv,
    write_text,
)
from modquad_gym.cli.common import N_MAX_OPTION, time_limit_option
from modquad_gym.core.options import int_option
from modquad_gym.oracle import Zonotope
from modquad_gym.oracle.fault_kernels import PATHS
from modquad_gym.oracle.faults import FaultTolerance, failure_sets
from modquad_gym.tasks.suites import load_suite

SUITES = ("fault_rotor", "heldout_paper", "heldout_planted", "dynamic_motions")
SUITES_DIR = Path(mq.__file__).parent / "data" / "suites"
SIZES = (100, 1000, 10000)


def minima(suites, per_suite: int, n_max: int, time_limit: float) -> list[dict]:
    rows = []
    for suite in suites:
        for task in load_suite(SUITES_DIR / f"{suite}.json")[:per_suite]:
            intact = mq.anytime_search(task, n_max=n_max, time_limit=time_limit)
            t0 = time.perf_counter()
            r = mq.anytime_search(task, n_max=n_max, time_limit=time_limit, fault="rotor2")
            seconds = time.perf_counter() - t0
            if r.structure is not None:  # an LP per failed matrix agrees
                W = task.rotor_wrenches(r.structure)
                ok = mq.tolerates(r.structure, W, task.f_max, fault="rotor2", method="daqp")
                assert ok.all(), f"{task.name}: the LP rejects the answer"
            rows.append({"suite": suite, "task": task.name, "intact": intact.n_modules,
                         "intact_certified": intact.certified, "rotor2": r.n_modules,
                         "lower_bound": r.lower_bound, "certified": r.certified,
                         "seconds": round(seconds, 2), "evaluated": r.evaluated})  # fmt: skip
            print(f"{suite} {task.name}: intact {intact.n_modules}, rotor2 {r.n_modules} "
                  f"(bound {r.lower_bound}, {seconds:.1f} s)", file=sys.stderr)  # fmt: skip
    return rows


def oracle_speed(repeats: int) -> list[dict]:
    """Wrenches decided per second by ``feasible`` and ``tolerates(fault="rotor2")`` (best of
    ``repeats``), and the share of (wrench, pair) cases each test of the certificate settled."""
    s = mq.Structure([(0, 0), (1, 0), (0, 1), (1, 1), (2, 0), (2, 1), (0, 2)])
    A = s.configuration_matrix()
    rng = np.random.default_rng(0)
    rows = []
    for t in SIZES:
        W = (rng.uniform(0.3, 1.0, (t, 28)) * rng.uniform(0, 1, (t, 28))) @ A.T
        best = {}
        deciders = {"feasible": lambda W=W: mq.feasible(A, W),
                    "rotor2": lambda W=W: mq.tolerates(A, W, fault="rotor2")}  # fmt: skip
        for name, fn in deciders.items():
            fn()  # compiled code and caches warm
            times = [_timed(fn) for _ in range(repeats)]
            best[name] = min(t[0] for t in times)
            best[f"{name}_cpu"] = min(t[1] for t in times)
        ft = FaultTolerance(A, 1.0, failure_sets(28, "rotor2"), Zonotope(A, 1.0))
        ft.decide(W)
        share = ft.paths / max(1, ft.paths.sum() + ft.tests)
        row = {"wrenches": t, "feasible_per_s": round(t / best["feasible"]),
               "rotor2_per_s": round(t / best["rotor2"]),
               "ratio": round(best["feasible"] / best["rotor2"], 4),
               "ratio_cpu": round(best["feasible_cpu"] / best["rotor2_cpu"], 4),
               "lp_pairs": ft.tests}  # fmt: skip
        row.update(
            {f"share_{p.replace(' ', '_')}": round(float(x), 4) for p, x in zip(PATHS, share)}
        )
        rows.append(row)
    return rows


def _timed(fn) -> tuple[float, float]:
    """(wall, CPU) seconds of one call: on a shared machine the CPU time of this process is
    what the call cost, the wall time adds the waits for a core."""
    t0, c0 = time.perf_counter(), time.process_time()
    fn()
    return time.perf_counter() - t0, time.process_time() - c0


def read_rows(path: Path) -> list[dict]:
    """The rows of an earlier run's minima.csv (none where there is no such file)."""
    if not os.path.lexists(path):
        return []
    return list(csv.DictReader(io.StringIO(read_input_text(path, "--out"), newline="")))


def report(rows: list[dict], speed: list[dict], command: str, repeats: int) -> str:
    small = [r for r in rows if r["intact"] not in ("", None) and int(r["intact"]) <= 6]
    met = [r for r in small if str(r["certified"]) == "True" and float(r["seconds"]) <= 30]
    k = next(r for r in speed if r["wrenches"] == 1000)
    lines = [
        "# Two rotor failures: certified minima and the decision's rate", "",
        made_by(command), "",
        "Per task: the default search's intact minimum and its minimum surviving any two rotor "
        "failures (rotor2), the lower bound it proved, whether they meet (certified) and the "
        "search's wall time (the machine is shared: wall time includes waiting for a core).", "",
        markdown_table(rows), "",
        f"Goal (issue 47): every task whose intact optimum is at most 6 modules certified within "
        f"30 s: {len(met)} of {len(small)}; slowest "
        f"{max((float(r['seconds']) for r in small), default=0):.1f} s.", "",
        "## Deciding two-rotor tolerance", "",
        "Wrenches decided per second, 7-module structure (m = 28, 378 pairs), wrenches inside "
        "W (benchmarks/fault_price.py's); ratio = rotor2 / feasible in the same run, by wall "
        "time and by this process's CPU time (ratio_cpu: on a shared machine the wall time of a "
        "9 ms call includes waits for a core that a 0.4 ms call escapes); shares: "
        "the (wrench, pair) cases each test of the certificate settled (lp_pairs: left to an "
        "LP on the failed matrix).", "",
        markdown_table(speed), "",
        rate_goal(k, repeats), "",
    ]  # fmt: skip
    return "\n".join(lines)


RATE_GOAL = 0.05
"""Issue 47: two-rotor tolerance decided at least this fraction of a plain decision's rate."""


def rate_goal(k: dict, repeats: int) -> str:
    """The rate goal's line for the 1,000-wrench row ``k`` of oracle.csv: each ratio to the
    digits oracle.csv keeps (0.0496 is 4.96 %, never rounded up to the goal), and whether it
    is met."""
    hows = {"ratio": "wall time", "ratio_cpu": "CPU time"}
    met = [how for key, how in hows.items() if float(k[key]) >= RATE_GOAL]
    verdict = {2: "met", 0: "not met"}.get(len(met), f"met by {''.join(met)} only")
    told = ", ".join(f"{100 * float(k[key]):.2f} % by {how}" for key, how in hows.items())
    return (f"Goal (issue 47): at least {100 * RATE_GOAL:g} % of a plain decision's rate at 1,000 "
            f"wrenches: {told} (best of {repeats} each); {verdict}.")  # fmt: skip


def main(argv: list[str] | None = None) -> int:
    args = bench_args(argv, "python -m benchmarks.fault_rotor2", __doc__.split("\n\n")[0], {
        "--per-suite": {"type": int_option(1), "default": 10,
                        "help": "tasks per suite (default 10)"},
        "--n-max": {"type": N_MAX_OPTION, "default": 12, "help": "module budget (default 12)"},
        "--time-limit": {"type": time_limit_option, "default": 30.0,
                         "help": "seconds per search (default 30)"},
        "--suites": {"nargs": "+", "action": Distinct, "choices": SUITES, "default": list(SUITES),
                     "help": "suites to run (the others' rows in --out are kept)"},
        "--repeats": {"type": int_option(1), "default": 15,
                      "help": "timings per decision (best of)"},
        "--oracle-only": {"action": "store_true", "help": "only the rate; keep minima.csv"},
    }, seed_help=None, out="results/faults/rotor2",
        outputs=("report.md", "minima.csv", "oracle.csv"))  # fmt: skip
    if args.oracle_only and not (args.out / "minima.csv").is_file():
        raise ValueError(f"--oracle-only: no minima.csv in {args.out} to keep rows from (run "
                         "once without it)")  # fmt: skip
    args.out.mkdir(parents=True, exist_ok=True)
    kept = [r for r in read_rows(args.out / "minima.csv")
            if args.oracle_only or r["suite"] not in args.suites]  # fmt: skip
    new = [] if args.oracle_only else minima(args.suites, args.per_suite, args.n_max,
                                             args.time_limit)  # fmt: skip
    rows = sorted(kept + new, key=lambda r: (SUITES.index(r["suite"]), r["task"]))
    speed = oracle_speed(args.repeats)
    command = command_as_run("fault_rotor2", argv)
    write_csv(rows, args.out / "minima.csv")
    write_csv(speed, args.out / "oracle.csv")
    write_text(args.out / "report.md", report(rows, speed, command, args.repeats))
    print(f"wrote {args.out}/report.md", file=sys.stderr)
    return 0


if __name__ == "__main__":
    raise SystemExit(run_main(main, "fault_rotor2"))
