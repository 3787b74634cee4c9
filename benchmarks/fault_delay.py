"""Calibrate the fault margin a detection delay needs: structures designed with a required
margin after the failure, flown in MuJoCo through their worst failure with the controller told
of it D seconds late.

    python -m benchmarks.fault_delay --tasks 4 --out results/fault_delay

For ``--tasks`` tasks drawn from each task source of ``--sources`` (the paper-like, planted and
random-motion generators by default) with the calibration's own seeds ``CALIBRATION_SEED0 + i``
(a range no suite, validation set or training stream uses: no held-out task is seen) and each
fault (rotor, module): the default search's minimum structure for every required margin of
``--margins`` (certified where its exact levels finish within ``--time-limit``); every distinct
structure is flown through its worst failure (:func:`modquad_gym.sim.fault_flight.fly_with_failure`,
a hover under the wrench that failure leaves with the smallest margin) at every delay of
``--delays``. The rule :func:`modquad_gym.oracle.faults.margin_for_delay` is read off the
flights: at each delay, the largest worst margin among the structures that left 5 cm (any
structure with more margin stayed within it), and a line through the origin above every one
of them. Writes flights.csv, report.md and margin_rule.png into ``--out``.
"""

from __future__ import annotations

import argparse
import csv
import sys
from pathlib import Path

import numpy as np

import modquad_gym as mq
from modquad_gym.scoring import machine_description
from modquad_gym.scoring.suites import draw_task
from modquad_gym.tasks import GENERATORS, make_generator

CALIBRATION_SEED0 = 9_000_000
"""Seeds of the calibration's tasks (source k draws ``CALIBRATION_SEED0 + 1000 k + i``); the
suites use 1-8 million (modquad_gym.scoring.suites, modquad_gym.scoring.tiers)."""
SOURCES = ("paper", "planted", "motions")
FAULTS = ("rotor", "module")
SAFETY = 1.25
"""The rule's slope: the fit's times this, rounded up to 0.05 (few structures per delay)."""


def designs(tasks, margins, n_max: int, time_limit: float) -> list[dict]:
    """One row per (task, fault, distinct structure): the smallest required margin that
    designed it, its size, whether certified, its worst margin after the failure."""
    rows = []
    for task in tasks:
        for fault in FAULTS:
            seen = set()
            for mu in margins:
                r = mq.anytime_search(task, n_max=n_max, time_limit=time_limit, fault=fault,
                                      fault_margin=mu)  # fmt: skip
                if r.structure is None or r.structure.cells in seen:
                    continue
                seen.add(r.structure.cells)
                W = task.rotor_wrenches(r.structure)
                worst = float(mq.fault_margin(r.structure, W, task.f_max, fault=fault).min())
                rows.append({"task": task.name, "fault": fault, "required_margin": mu,
                             "modules": r.n_modules, "certified": r.certified,
                             "worst_fault_margin": round(worst, 5), "_task": task,
                             "_structure": r.structure})  # fmt: skip
                print(f"{task.name} {fault} mu={mu}: {r.n_modules} modules, worst margin "
                      f"{worst:.4f}", file=sys.stderr)  # fmt: skip
    return rows


def fly(rows: list[dict], delays) -> list[dict]:
    """Each design flown at each delay: the largest position error after the failure."""
    from modquad_gym.sim.fault_flight import fly_with_failure

    out = []
    for row in rows:
        for delay in delays:
            f = fly_with_failure(row["_structure"], row["_task"], row["fault"],
                                 detection_delay_s=delay)  # fmt: skip
            err = f.max_position_error_m
            out.append({**{k: v for k, v in row.items() if not k.startswith("_")},
                        "delay_s": delay, "max_error_cm": round(100 * err, 3),
                        "within_5cm": bool(f.within_goal)})  # fmt: skip
    return out


def fit(flights: list[dict], delays) -> tuple[dict, float]:
    """Per delay the largest worst margin of a flight beyond 5 cm (0 when none), and the
    smallest slope c with c * D above every one of them."""
    needed = {}
    for d in delays:
        lost = [
            r["worst_fault_margin"] for r in flights if r["delay_s"] == d and not r["within_5cm"]
        ]
        needed[d] = max(lost, default=0.0)
    slope = max(needed[d] / d for d in delays if d > 0)
    return needed, slope


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--tasks", type=int, default=4, help="tasks per source (default 4)")
    ap.add_argument(
        "--sources",
        nargs="+",
        default=list(SOURCES),
        choices=list(GENERATORS),
        help="task generators (default: paper planted motions)",
    )
    ap.add_argument("--margins", type=float, nargs="+", default=[0.0, 0.02, 0.05, 0.1, 0.15])
    ap.add_argument("--delays", type=float, nargs="+", default=[0.01, 0.02, 0.03, 0.05])
    ap.add_argument("--n-max", type=int, default=12)
    ap.add_argument("--time-limit", type=float, default=10.0)
    ap.add_argument("--out", default="results/fault_delay")
    args = ap.parse_args(argv)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    tasks = [
        draw_task(make_generator(src), CALIBRATION_SEED0 + 1000 * k + i, f"{src}-cal-{i}")
        for k, src in enumerate(args.sources)
        for i in range(args.tasks)
    ]
    flights = fly(designs(tasks, args.margins, args.n_max, args.time_limit), args.delays)
    with open(out / "flights.csv", "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=list(flights[0]))
        w.writeheader()
        w.writerows(flights)
    needed, slope = fit(flights, args.delays)
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6, 4))
    for ok, mark, label in ((True, "o", "within 5 cm"), (False, "x", "beyond 5 cm")):
        pts = [(r["delay_s"], r["worst_fault_margin"]) for r in flights if r["within_5cm"] == ok]
        if pts:
            x, y = np.array(pts).T
            ax.scatter(1000 * x, y, marker=mark, label=label, alpha=0.6)
    d = np.linspace(0, max(args.delays), 20)
    ax.plot(1000 * d, slope * d, "k--", label=f"fit: mu = {slope:.2f} D")
    ax.set_xlabel("detection delay D (ms)")
    ax.set_ylabel("worst fault margin of the design")
    ax.legend()
    fig.tight_layout()
    fig.savefig(out / "margin_rule.png", dpi=120)
    lines = [
        "# The fault margin a detection delay needs",
        "",
        f"Made by `python -m benchmarks.fault_delay {' '.join(argv or sys.argv[1:])}` on "
        f"{machine_description()}.",
        "",
        f"{len(tasks)} tasks ({args.tasks} per source: {', '.join(args.sources)}; seeds "
        f"{CALIBRATION_SEED0:,} + 1000 k + i, disjoint from every suite), faults rotor and "
        f"module, designs for required margins {args.margins}, each flown through its worst "
        f"failure at delays {[f'{1000 * d:g} ms' for d in args.delays]} "
        f"({len(flights)} flights).",
        "",
        "| delay | flights | within 5 cm | largest worst margin beyond 5 cm | largest error (cm) |",
        "|---|---|---|---|---|",
    ]
    for dl in args.delays:
        rs = [r for r in flights if r["delay_s"] == dl]
        lines.append(
            f"| {1000 * dl:g} ms | {len(rs)} | {sum(r['within_5cm'] for r in rs)} | "
            f"{needed[dl]:.4f} | {max(r['max_error_cm'] for r in rs):.2f} |"
        )
    rule = np.ceil(SAFETY * slope / 0.05) * 0.05
    lines += ["", f"Fit through the origin above every threshold: mu = {slope:.3f} * D (D in s); "
              f"the rule (modquad_gym.oracle.faults.DELAY_SLOPE) takes {SAFETY:g} times it, "
              "rounded "
              f"up: mu = {rule:.2f} * D, for D up to {max(args.delays):g} s (the delays flown).",
              "", "![rule](margin_rule.png)", ""]  # fmt: skip
    (out / "report.md").write_text("\n".join(lines))
    print("\n".join(lines))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
