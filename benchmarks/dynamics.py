"""Designing for a motion: the certified minimum structure per speed, flown in MuJoCo, against
the static (hover-only) design.

    python -m benchmarks.dynamics [--circle-speeds 1 1.5 1.75 2 2.1 2.2]
                                  [--eight-speeds 1 1.5 2 2.5] [--push-forces 1 2 4 6 8]
                                  [--n-max 8] [--out results/dynamics]

Writes ``report.md``, ``dynamics.csv`` and ``modules_vs_speed.png`` into ``--out``. Three
motions (:mod:`modquad_gym.dynamics.motions`, 50 samples/s, f_max 2 N, 0.3 kg T-modules): a
circle of radius 1 m at increasing cruise speed, a figure-eight of half-width 1 m carrying a
0.4 kg payload 10 cm below the COM, and a 1 m push at 0.5 m/s against an increasing contact
force. For each: the certified minimum structure (``exhaustive_search``, n_max 8), its flight
along the trajectory (:func:`~modquad_gym.sim.track.fly_trajectory`: max and RMS tracking
error, share of control steps with a saturated rotor), and the *static design*: the minimum
structure for the same payload and exerted wrench at rest (the trajectory's wrenches at zero
acceleration), whether it can produce the motion's wrenches (exact oracle) and how it flies.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

from benchmarks.common import Distinct, bench_args, report_page, run_main, write_csv
from modquad_gym.cli.common import N_MAX_OPTION
from modquad_gym.core.options import real_option
from modquad_gym.core.outputs import save_figure, write_text

OUTPUTS = ("report.md", "dynamics.csv", "modules_vs_speed.png")
RATE = 50.0
"""Samples per second of the benchmark's trajectories."""
PAYLOAD = (0.4, (0.0, 0.0, -0.1))
"""The figure-eight's payload: kg, offset from the COM (m)."""
TRACK_GOAL_M = 0.05
"""The issue's goal: feasible tasks tracked within 5 cm (max) without saturating."""


def positive_option(text: str) -> float:
    """An argparse ``type`` for a speed or force: a finite number above 0."""
    value = real_option(text)
    if not value > 0:
        raise argparse.ArgumentTypeError(f"must be > 0, got {value:g}")
    return value


positive_option.__name__ = "number"


def motions(args: argparse.Namespace) -> list:
    """(motion, parameter name, value, task) of the benchmark, in order, all built before any
    search: a motion that cannot be built (too fast for its ramp, too long) is a ValueError
    naming the option and the value."""
    from modquad_gym import dynamics as dy

    payload = dy.Payload(*PAYLOAD)
    plan = (
        ("--circle-speeds", args.circle_speeds, "circle r=1 m", "speed_m_s",
         lambda v: dy.circle(1.0, v, rate=RATE)),
        ("--eight-speeds", args.eight_speeds, f"figure-eight + {PAYLOAD[0]:g} kg", "speed_m_s",
         lambda v: dy.figure_eight(1.0, v, payload=payload, rate=RATE)),
        ("--push-forces", args.push_forces, "push 0.5 m/s", "force_N",
         lambda f: dy.push(1.0, 0.5, f, rate=RATE)),
    )  # fmt: skip
    out = []
    for flag, values, motion, name, make in plan:
        for v in values:
            try:
                out.append((motion, name, v, make(v)))
            except ValueError as exc:
                raise ValueError(f"{flag} {v:g}: {exc}") from None
    return out


def static_task(task):
    """The same payload and exerted wrenches at rest: the trajectory's wrenches at zero
    acceleration (what a hover-only design is given)."""
    from modquad_gym.dynamics import DynamicTask, Trajectory

    t = task.trajectory.t
    zero = np.zeros((len(t), 3))
    rest = Trajectory(t, zero, velocity=zero, acceleration=zero, angular_velocity=zero,
                      angular_acceleration=zero)  # fmt: skip
    return DynamicTask(rest, task.payload, task.exerted, task.f_max, task.name + "-static")


def flight(structure, task) -> dict:
    """The flight's numbers, or Nones without a structure."""
    from modquad_gym.sim.track import fly_trajectory

    if structure is None:
        return {"max_err_cm": None, "rms_err_cm": None, "saturated_pct": None, "diverged": None}
    f = fly_trajectory(structure, task)
    return {
        "max_err_cm": 100 * f.max_position_error_m,
        "rms_err_cm": 100 * f.rms_position_error_m,
        "saturated_pct": 100 * f.saturated_fraction,
        "diverged": f.diverged is not None,
    }


def row(motion: str, name: str, value: float, task, n_max: int, cache: dict) -> dict:
    """One motion at one parameter: the minimum, its flight, the static design on it."""
    from modquad_gym.oracle import feasible
    from modquad_gym.search import exhaustive_search

    t0 = time.perf_counter()
    try:
        r = exhaustive_search(task, n_max=n_max)
        structure, bound, certified = r.structure, r.lower_bound, r.certified
    except ValueError:  # no number of modules can: refused before any work (lift check)
        structure, bound, certified = None, "any", True
    seconds = time.perf_counter() - t0
    out = {"motion": motion, "parameter": name, "value": value, "samples": task.n_wrenches,
           "n_min": structure.n_modules if structure else "none", "lower_bound": bound,
           "certified": certified, "search_s": round(seconds, 3),
           "cells": [list(c) for c in structure.cells] if structure else None}  # fmt: skip
    out |= flight(structure, task)
    key = (motion, task.payload, None if task.exerted is None else task.exerted.tobytes())
    if key not in cache:
        cache[key] = exhaustive_search(static_task(task), n_max=n_max).structure
    s0 = cache[key]
    out["static_n"] = s0.n_modules if s0 is not None else "none"
    ok = s0 is not None and bool(
        feasible(s0.configuration_matrix(), task.rotor_wrenches(s0), task.f_max).all()
    )
    out["static_feasible"] = ok
    same = structure is not None and s0 is not None and s0.key == structure.key
    static = {k: out[k] for k in ("max_err_cm", "rms_err_cm", "saturated_pct", "diverged")}
    static = static if same else flight(s0, task)
    out |= {f"static_{k}": v for k, v in static.items()}
    return out


def plot(rows: list[dict], path: Path) -> None:
    """Modules vs speed (force for the push): the minimum and the static design."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    groups = list(dict.fromkeys(r["motion"] for r in rows))
    fig, axes = plt.subplots(1, len(groups), figsize=(4.2 * len(groups), 3.4), squeeze=False)
    for ax, g in zip(axes[0], groups):
        sel = [r for r in rows if r["motion"] == g]
        x = [r["value"] for r in sel]
        n = [r["n_min"] if r["n_min"] != "none" else np.nan for r in sel]
        s = [r["static_n"] if r["static_n"] != "none" else np.nan for r in sel]
        ax.plot(x, n, "o-", label="certified minimum for the motion")
        ax.plot(x, s, "s--", color="grey", label="static (hover-only) design")
        bad = [(xi, si) for xi, si, r in zip(x, s, sel) if not r["static_feasible"]]
        if bad:
            ax.plot(*zip(*bad), "x", color="red", ms=10, label="static design fails the motion")
        ax.set_title(g)
        ax.set_xlabel("speed (m/s)" if sel[0]["parameter"] == "speed_m_s" else "force (N)")
        ax.set_ylabel("modules")
        ax.grid(alpha=0.3)
    axes[0][0].legend(fontsize=7)
    fig.tight_layout()
    save_figure(fig, path, dpi=120)
    plt.close(fig)


def goal_lines(rows: list[dict]) -> list[str]:
    flown = [r for r in rows if r["max_err_cm"] is not None]
    worst = max((r["max_err_cm"] for r in flown), default=0.0)
    sat = max((r["saturated_pct"] for r in flown), default=0.0)
    ok = worst <= 100 * TRACK_GOAL_M and sat == 0.0
    fails = [f"{r['motion']} at {r['value']:g}" for r in rows if not r["static_feasible"]]
    return [
        f"- Every certified minimum flown: worst max tracking error {worst:.3g} cm (goal <= "
        f"{100 * TRACK_GOAL_M:g} cm), worst saturated share {sat:.3g} % (goal 0): "
        f"{'met' if ok else 'NOT met'} ({len(flown)} flights).",
        f"- Every answer certified (minimum up to n_max): {all(r['certified'] for r in rows)}.",
        f"- The static (hover-only) design cannot produce the motion's wrenches at: "
        f"{', '.join(fails) if fails else 'none'}.",
    ]


def report(rows: list[dict], args: argparse.Namespace, seconds: float) -> str:
    command = (
        "python -m benchmarks.dynamics --circle-speeds "
        + " ".join(f"{v:g}" for v in args.circle_speeds)
        + " --eight-speeds "
        + " ".join(f"{v:g}" for v in args.eight_speeds)
        + " --push-forces "
        + " ".join(f"{v:g}" for v in args.push_forces)
        + f" --n-max {args.n_max}"
    )
    table = [{k: v for k, v in r.items() if k != "cells"} for r in rows]
    return report_page(
        "Designing for a motion: minimum structures per speed, flown in MuJoCo",
        command,
        "Motions sampled at 50 Hz, f_max = 2 N per rotor, 0.3 kg T-modules (eta = 45 deg). "
        "`n_min`: the certified minimum module count for the motion (exhaustive search over "
        f"every structure up to {args.n_max} modules with the structure's own mass and inertia "
        "in the wrenches); `max_err_cm`, `rms_err_cm`: distance between the flown and the "
        "desired COM in MuJoCo (feed-forward Newton-Euler wrench + LQR, bounded allocation); "
        "`saturated_pct`: share of control steps with a rotor at 0 or f_max. `static_*`: the "
        "minimum structure for the same payload and contact force at rest (hover-only "
        "design); `static_feasible`: whether it can produce every wrench of the motion (exact "
        "oracle); its flight along the motion. `diverged`: the flight left the path by 1 m. "
        "`lower_bound` `any`: the lift check proves that no number of modules can fly the "
        "motion (the modules cannot carry their own weight along it).",
        table,
        "![modules vs speed](modules_vs_speed.png)",
        "",
        "Goals of the issue:",
        *goal_lines(rows),
        "",
        "Structures found (cells):",
        "",
        *[f"- {r['motion']} {r['parameter']}={r['value']:g}: {r['cells']}" for r in rows],
        "",
        how=f" in {seconds:.0f} s",
        caveat=" (the machine was shared: seconds are upper bounds)",
    )


def main(argv: list[str] | None = None) -> None:
    speeds = dict(type=positive_option, nargs="*", action=Distinct)
    options = {
        "--circle-speeds": dict(**speeds, default=[1.0, 1.5, 1.75, 2.0, 2.1, 2.2],
                                help="circle cruise speeds, m/s (default 1 1.5 1.75 2 2.1 2.2)"),
        "--eight-speeds": dict(**speeds, default=[1.0, 1.5, 2.0, 2.5],
                               help="figure-eight peak speeds, m/s (default 1 1.5 2 2.5)"),
        "--push-forces": dict(**speeds, default=[1.0, 2.0, 4.0, 6.0, 8.0],
                              help="push contact forces, N (default 1 2 4 6 8)"),
        "--n-max": dict(type=N_MAX_OPTION, default=8, help="module budget (default 8)"),
    }  # fmt: skip
    args = bench_args(
        argv,
        "python -m benchmarks.dynamics",
        "Certified minimum structures for a circle at increasing speed, a figure-eight with a "
        "payload and a push, flown in MuJoCo, against the static (hover-only) design; write "
        "report.md, dynamics.csv and modules_vs_speed.png into --out.",
        options,
        seed_help=None,
        out="results/dynamics",
        outputs=OUTPUTS,
    )
    if not (args.circle_speeds or args.eight_speeds or args.push_forces):
        raise ValueError("nothing to run: give --circle-speeds, --eight-speeds or --push-forces")
    t0 = time.perf_counter()
    cache: dict = {}
    rows = []
    for motion, name, value, task in motions(args):
        rows.append(row(motion, name, value, task, args.n_max, cache))
        r = rows[-1]
        print(f"{motion} {name}={value:g}: n_min {r['n_min']}, max err {r['max_err_cm']} cm, "
              f"static {r['static_n']} feasible {r['static_feasible']}", flush=True)  # fmt: skip
    out = Path(args.out)
    write_csv(rows, out / "dynamics.csv")
    plot(rows, out / "modules_vs_speed.png")
    write_text(out / "report.md", report(rows, args, time.perf_counter() - t0))
    print("\n".join(goal_lines(rows)))


if __name__ == "__main__":
    raise SystemExit(run_main(main, "dynamics"))
