"""The price of a margin that survives the detection delay, and of two rotor failures.

    python -m benchmarks.fault_price --per-suite 4 --out results/faults/delay

For the first ``--per-suite`` tasks of the held-out paper-like and planted suites and the
dynamic suite (none of them used by the margin's calibration, benchmarks/fault_delay.py): the
default search's intact minimum, its minimum surviving any single rotor failure, the same with
the margin the rule derives from a 20 ms and a 50 ms detection delay
(:func:`modquad_gym.oracle.faults.margin_for_delay`), and its minimum surviving any two rotor
failures (``fault="rotor2"``), each with its time; every rotor design is flown through its worst
failure in MuJoCo with the controller told of it 20 ms and 50 ms late. Also the rate of deciding
two-rotor tolerance against a plain decision at 1,000 wrenches. Writes report.md, price.csv,
flights.csv, oracle.csv and price_delay.png into ``--out``.
"""

from __future__ import annotations

import argparse
import csv
import sys
import time
from pathlib import Path

import numpy as np

import modquad_gym as mq
from modquad_gym.oracle.faults import margin_for_delay
from modquad_gym.scoring import machine_description
from modquad_gym.tasks.suites import load_suite

SUITES = ("heldout_paper", "heldout_planted", "dynamic_motions")
SUITES_DIR = Path(mq.__file__).parent / "data" / "suites"
DELAYS = (0.02, 0.05)
DESIGNS = ("intact", "rotor", "rotor_20ms", "rotor_50ms", "rotor2")


def search(task, design: str, n_max: int, time_limit: float):
    fault = {"intact": None, "rotor2": "rotor2"}.get(design, "rotor")
    mu = margin_for_delay(int(design[6:8]) / 1000) if design.endswith("ms") else None
    t0 = time.perf_counter()
    r = mq.anytime_search(task, n_max=n_max, time_limit=time_limit, fault=fault, fault_margin=mu)
    return r, time.perf_counter() - t0


def price(per_suite: int, n_max: int, time_limit: float) -> tuple[list[dict], list[dict]]:
    from modquad_gym.sim.fault_flight import fly_with_failure

    rows, flights = [], []
    for suite in SUITES:
        for task in load_suite(SUITES_DIR / f"{suite}.json")[:per_suite]:
            row = {"suite": suite, "task": task.name}
            found = {}
            for design in DESIGNS:
                r, seconds = search(task, design, n_max, time_limit)
                found[design] = r.structure
                row[design] = r.n_modules
                row[f"{design}_certified"] = r.certified
                row[f"{design}_seconds"] = round(seconds, 2)
                print(f"{suite} {task.name} {design}: {r.n_modules} (bound {r.lower_bound}, "
                      f"{seconds:.1f} s)", file=sys.stderr)  # fmt: skip
            rows.append(row)
            for design in ("rotor", "rotor_20ms", "rotor_50ms"):
                s = found[design]
                if s is None:
                    continue
                W = task.rotor_wrenches(s)
                worst = float(mq.fault_margin(s, W, task.f_max, fault="rotor").min())
                for delay in DELAYS:
                    f = fly_with_failure(s, task, "rotor", detection_delay_s=delay)
                    flights.append({"suite": suite, "task": task.name, "design": design,
                                    "modules": s.n_modules, "worst_fault_margin": round(worst, 5),
                                    "delay_s": delay,
                                    "max_error_cm": round(100 * f.max_position_error_m, 3),
                                    "within_5cm": bool(f.within_goal)})  # fmt: skip
    return rows, flights


def oracle_speed(repeats: int = 5, t: int = 1000) -> list[dict]:
    """Wrenches decided per second at ``t`` wrenches (best of ``repeats``), 7 modules."""
    s = mq.Structure([(0, 0), (1, 0), (0, 1), (1, 1), (2, 0), (2, 1), (0, 2)])
    A = s.configuration_matrix()
    rng = np.random.default_rng(0)
    W = rng.uniform(0.3, 1.0, size=(t, A.shape[1])) * rng.uniform(0, 1, size=(t, A.shape[1]))
    W = W @ A.T
    out = []
    for name, fn in (("feasible", lambda: mq.feasible(A, W)),
                     ("tolerates rotor", lambda: mq.tolerates(A, W, fault="rotor")),
                     ("tolerates rotor2", lambda: mq.tolerates(A, W, fault="rotor2"))):  # fmt: skip
        fn()
        best = min(_timed(fn) for _ in range(repeats))
        out.append({"decision": name, "wrenches": t, "per_second": round(t / best)})
    return out


def _timed(fn) -> float:
    t0 = time.perf_counter()
    fn()
    return time.perf_counter() - t0


def write(out: Path, name: str, rows: list[dict]) -> None:
    if not rows:
        return
    with open(out / name, "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)


def mean(xs) -> str:
    xs = [x for x in xs if x is not None]
    return f"{np.mean(xs):.2f}" if xs else "n/a"


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--per-suite", type=int, default=4)
    ap.add_argument("--n-max", type=int, default=12)
    ap.add_argument("--time-limit", type=float, default=30.0)
    ap.add_argument("--out", default="results/faults/delay")
    args = ap.parse_args(argv)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    speed = oracle_speed()
    write(out, "oracle.csv", speed)
    rows, flights = price(args.per_suite, args.n_max, args.time_limit)
    write(out, "price.csv", rows)
    write(out, "flights.csv", flights)
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6, 4))
    for suite in SUITES:
        rs = [r for r in rows if r["suite"] == suite]
        ys = []
        for design in ("rotor", "rotor_20ms", "rotor_50ms"):
            extra = [r[design] - r["intact"] for r in rs if r[design] and r["intact"]]
            ys.append(np.mean(extra) if extra else np.nan)
        ax.plot([0, 20, 50], ys, "o-", label=suite)
    ax.set_xlabel("detection delay designed for (ms)")
    ax.set_ylabel("extra modules over the intact minimum (mean)")
    ax.set_title("rotor failure, margin = rule(delay)")
    ax.legend()
    fig.tight_layout()
    fig.savefig(out / "price_delay.png", dpi=120)
    mu20, mu50 = margin_for_delay(0.02), margin_for_delay(0.05)
    lines = [
        "# The price of a margin for the detection delay, and of two rotor failures",
        "",
        f"Made by `python -m benchmarks.fault_price {' '.join(argv or sys.argv[1:])}` on "
        f"{machine_description()}. A subset: the first {args.per_suite} tasks of each suite "
        "(the full regeneration of results/faults did not fit the session's time).",
        "",
        f"Minimum module counts by the default search (n_max {args.n_max}, time limit "
        f"{args.time_limit:g} s): intact; surviving any rotor failure; the same with the margin "
        f"the rule derives from 20 ms (mu = {mu20:.3f}) and 50 ms (mu = {mu50:.3f}); surviving "
        "any two rotor failures (rotor2).",
        "",
        "| suite | tasks | intact | rotor | rotor, 20 ms | rotor, 50 ms | rotor2 | certified "
        "(all designs) | rotor2 slowest (s) |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for suite in SUITES:
        rs = [r for r in rows if r["suite"] == suite]
        cert = sum(all(r[f"{d}_certified"] for d in DESIGNS) for r in rs)
        slow = max(r["rotor2_seconds"] for r in rs)
        means = " | ".join(mean(r[d] for r in rs) for d in DESIGNS)
        lines.append(f"| {suite} | {len(rs)} | {means} | {cert} of {len(rs)} | {slow:.1f} |")
    lines += ["", "Per task:", "", "| suite | task | " + " | ".join(DESIGNS) + " |",
              "|---|---|" + "---|" * len(DESIGNS)]  # fmt: skip
    for r in rows:
        cells = [f"{r[d]}{'' if r[f'{d}_certified'] else '*'}" for d in DESIGNS]
        lines.append(f"| {r['suite']} | {r['task']} | " + " | ".join(cells) + " |")
    lines += ["", "(* not certified within the time limit)", "",
              "## Flown through the worst rotor failure (MuJoCo, hover or trajectory)", "",
              "| design | delay | structures | within 5 cm | largest error (cm) |",
              "|---|---|---|---|---|"]  # fmt: skip
    for design in ("rotor", "rotor_20ms", "rotor_50ms"):
        for delay in DELAYS:
            fs = [f for f in flights if f["design"] == design and f["delay_s"] == delay]
            if fs:
                lines.append(f"| {design} | {1000 * delay:g} ms | {len(fs)} | "
                             f"{sum(f['within_5cm'] for f in fs)} | "
                             f"{max(f['max_error_cm'] for f in fs):.2f} |")  # fmt: skip
    lines += ["", "## Deciding two-rotor tolerance", "",
              "| decision | wrenches | decided per second |", "|---|---|---|"]  # fmt: skip
    for s in speed:
        lines.append(f"| {s['decision']} | {s['wrenches']} | {s['per_second']:,} |")
    ratio = speed[2]["per_second"] / speed[0]["per_second"]
    lines += ["", f"Two-rotor tolerance at {ratio:.1%} of a plain decision's rate (goal 5 %).",
              "", "![price](price_delay.png)", ""]  # fmt: skip
    (out / "report.md").write_text("\n".join(lines))
    print("\n".join(lines))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
