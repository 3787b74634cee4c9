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
a hover under the wrench that failure leaves with the smallest margin, or a dynamic task's
trajectory) at every delay of ``--delays``. The rule
:func:`modquad_gym.oracle.fault_delay.margin_for_delay` is read off the flights, for each fault
on its own: at each delay, the largest worst margin among the structures that left 5 cm, and a
line through the origin above every one of them (the rule takes 1.25 times its slope, rounded
up). ``--skip`` and ``--update`` add new tasks to an earlier run's flights.csv (each row names
its command). Writes flights.csv, report.md and margin_rule.png into ``--out``.
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


def fit(flights: list[dict], delays, fault: str) -> tuple[dict, float]:
    """Per delay the largest worst margin of a ``fault`` flight beyond 5 cm (0 when none), and
    the smallest slope c with c * D above every one of them."""
    needed = {}
    for d in delays:
        lost = [r["worst_fault_margin"] for r in flights
                if r["fault"] == fault and r["delay_s"] == d and not r["within_5cm"]]  # fmt: skip
        needed[d] = max(lost, default=0.0)
    return needed, max(needed[d] / d for d in delays if d > 0)


def read_flights(path: Path) -> list[dict]:
    """The rows of an earlier flights.csv, numbers and booleans restored."""
    if not path.is_file():
        return []
    with path.open(newline="") as fh:
        rows = list(csv.DictReader(fh))
    for r in rows:
        for k in ("required_margin", "worst_fault_margin", "delay_s", "max_error_cm"):
            r[k] = float(r[k])
        r["modules"] = int(r["modules"])
        r["certified"], r["within_5cm"] = r["certified"] == "True", r["within_5cm"] == "True"
    return rows


def plot(path: Path, flights: list[dict], slopes: dict, delays) -> None:
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, len(FAULTS), figsize=(10, 4), sharey=True)
    for ax, fault in zip(axes, FAULTS):
        for ok, mark, label in ((True, "o", "within 5 cm"), (False, "x", "beyond 5 cm")):
            pts = [(r["delay_s"], r["worst_fault_margin"]) for r in flights
                   if r["within_5cm"] == ok and r["fault"] == fault]  # fmt: skip
            if pts:
                x, y = np.array(pts).T
                ax.scatter(1000 * x, y, marker=mark, label=label, alpha=0.6)
        d = np.linspace(0, max(delays), 20)
        ax.plot(1000 * d, slopes[fault] * d, "k--", label=f"fit: mu = {slopes[fault]:.2f} D")
        ax.set_title(f"{fault} failure")
        ax.set_xlabel("detection delay D (ms)")
        ax.legend(fontsize=8)
    axes[0].set_ylabel("worst fault margin of the design")
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--tasks", type=int, default=4, help="tasks per source (default 4)")
    ap.add_argument("--skip", type=int, default=0,
                    help="leave out the first SKIP tasks of each source (new tasks for a run "
                    "that adds to an earlier one)")  # fmt: skip
    ap.add_argument("--sources", nargs="+", default=list(SOURCES), choices=list(GENERATORS),
                    help="task generators (default: paper planted motions)")  # fmt: skip
    ap.add_argument("--margins", type=float, nargs="+", default=[0.0, 0.02, 0.05, 0.1, 0.15])
    ap.add_argument("--delays", type=float, nargs="+", default=[0.01, 0.02, 0.03, 0.05])
    ap.add_argument("--n-max", type=int, default=12)
    ap.add_argument("--time-limit", type=float, default=10.0)
    ap.add_argument(
        "--update",
        action="store_true",
        help="keep the flights of flights.csv in --out (other tasks) and fit on all",
    )
    ap.add_argument("--out", default="results/fault_delay")
    args = ap.parse_args(argv)
    if not 0 <= args.skip < args.tasks:
        ap.error("--skip must lie in [0, --tasks)")
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    command = "python -m benchmarks.fault_delay " + " ".join(argv or sys.argv[1:])
    tasks = [
        draw_task(make_generator(src), CALIBRATION_SEED0 + 1000 * k + i, f"{src}-cal-{i}")
        for k, src in enumerate(args.sources)
        for i in range(args.skip, args.tasks)
    ]
    new = fly(designs(tasks, args.margins, args.n_max, args.time_limit), args.delays)
    for r in new:
        r["command"] = command
    names = {t.name for t in tasks}
    old = read_flights(out / "flights.csv") if args.update else []
    flights = [r for r in old if r["task"] not in names] + new
    with open(out / "flights.csv", "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=list(new[0]))
        w.writeheader()
        w.writerows({**r, "command": r.get("command") or command} for r in flights)
    delays = sorted({r["delay_s"] for r in flights})
    fits = {fault: fit(flights, delays, fault) for fault in FAULTS}
    plot(out / "margin_rule.png", flights, {f: fits[f][1] for f in FAULTS}, delays)
    commands = list(dict.fromkeys(r.get("command") or command for r in flights))
    lines = [
        "# The fault margin a detection delay needs",
        "",
        f"Made by {', then '.join(f'`{c}`' for c in commands)} on {machine_description()}.",
        "",
        f"{len({r['task'] for r in flights})} tasks drawn from the sources "
        f"{', '.join(args.sources)} with the calibration's own seeds ({CALIBRATION_SEED0:,} + "
        "1000 k + i, disjoint from every suite), faults rotor and module, designs for required "
        f"margins {sorted({r['required_margin'] for r in flights})} ({len(flights)} flights of "
        f"{len({(r['task'], r['fault'], r['required_margin']) for r in flights})} designs), each "
        f"flown through its worst failure at delays {[f'{1000 * d:g} ms' for d in delays]}.",
        "",
        "| fault | delay | flights | within 5 cm | largest worst margin beyond 5 cm | "
        "largest error (cm) |",
        "|---|---|---|---|---|---|",
    ]
    for fault in FAULTS:
        for dl in delays:
            rs = [r for r in flights if r["delay_s"] == dl and r["fault"] == fault]
            lines.append(
                f"| {fault} | {1000 * dl:g} ms | {len(rs)} | {sum(r['within_5cm'] for r in rs)} | "
                f"{fits[fault][0][dl]:.4f} | {max(r['max_error_cm'] for r in rs):.2f} |"
            )
    lines += ["", "Fit through the origin above every threshold, and the rule "
              f"(modquad_gym.oracle.fault_delay.DELAY_SLOPES: {SAFETY:g} times the fit, rounded "
              f"up to 0.05), for D up to {max(delays):g} s (the delays flown):", ""]  # fmt: skip
    for fault in FAULTS:
        slope = fits[fault][1]
        rule = np.ceil(SAFETY * slope / 0.05) * 0.05
        lines.append(f"- {fault}: fit mu = {slope:.3f} D, rule mu = {rule:.2f} D")
    lines += ["", "![rule](margin_rule.png)", ""]
    (out / "report.md").write_text("\n".join(lines))
    print("\n".join(lines))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
