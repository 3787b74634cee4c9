"""Calibrate the fault margin a detection delay needs: structures designed with a required
margin after the failure, flown in MuJoCo through their smallest-margin failure with the
controller told of it D seconds late.

    python -m benchmarks.fault_delay --tasks 4 --out results/fault_delay --force

For ``--tasks`` tasks drawn from each task source of ``--sources`` (the paper-like, planted and
random-motion generators by default) with the calibration's own seeds ``CALIBRATION_SEED0 + i`` (a
range no suite, validation set or training stream uses: no held-out task is seen) and each fault
(rotor, module): the default search's minimum structure for every required margin of ``--margins``
(certified where its exact levels finish within ``--time-limit``); every distinct structure is
flown through its smallest-margin failure only
(:func:`modquad_gym.sim.fault_flight.fly_with_failure` with ``failure="worst"``: a hover under the
wrench that failure leaves with the smallest margin, or a dynamic task's trajectory, then a hold at
its last point) at every delay of ``--delays``, and judged by the flight's verdict (within 5 cm
from the failure on, never stopped, settled at its end: :mod:`~modquad_gym.sim.fault_verdict`). The
rule :func:`modquad_gym.oracle.fault_delay.margin_for_delay` is read off the flights, for each
fault on its own: at each delay, the largest worst margin among the structures that did not hold,
and a line through the origin above every one of them (the rule takes 1.25 times its slope, rounded
up). A design that does not hold even with the failure known at once (the delay 0, flown by
default) is left out of the fit, since what fails it is not the delay (the report gives the fit
with it too). ``--skip`` and ``--update`` add new tasks to an earlier run's flights.csv (each row
names its command). Writes flights.csv, report.md and margin_rule.png into ``--out`` (an existing
one is replaced only with ``--force``; ``--update`` replaces the flights.csv it adds to).
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

import modquad_gym as mq
from benchmarks.common import (
    Distinct,
    bench_args,
    command_as_run,
    int_option,
    load_average,
    machine_description,
    read_rows_csv,
    run_main,
    write_csv,
    write_text,
)
from modquad_gym.cli.common import time_limit_option
from modquad_gym.core.options import real_option
from modquad_gym.core.outputs import check_output_dir, save_figure
from modquad_gym.oracle.failures import check_fault_margin
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
                             "worst_fault_margin": round(worst, 5),
                             "cells": json.dumps([list(c) for c in r.structure.cells]),
                             "_task": task, "_structure": r.structure})  # fmt: skip
                print(f"{task.name} {fault} mu={mu}: {r.n_modules} modules, worst margin "
                      f"{worst:.4f}", file=sys.stderr)  # fmt: skip
    return rows


def fly(rows: list[dict], delays) -> list[dict]:
    """Each design flown at each delay through its smallest-margin failure: the largest position
    error after the failure, the verdict and, where it did not hold, why."""
    from modquad_gym.sim.fault_flight import fly_with_failure

    out = []
    for row in rows:
        for delay in delays:
            f = fly_with_failure(row["_structure"], row["_task"], row["fault"],
                                 detection_delay_s=delay, failure="worst")  # fmt: skip
            err = f.max_position_error_m
            out.append({**{k: v for k, v in row.items() if not k.startswith("_")},
                        "delay_s": delay, "max_error_cm": round(100 * err, 3),
                        "within_5cm": bool(f.within_goal),
                        "why_not": f.verdict_words()})  # fmt: skip
    return out


def not_the_delays(flights: list[dict], fault: str) -> set:
    """The ``fault`` designs (task, required margin) whose flight with the failure known at once
    (D = 0, where flown) did not hold: what fails them is not the delay, so their flights say
    nothing of the margin a delay needs."""
    return {(r["task"], r["required_margin"]) for r in flights
            if r["fault"] == fault and r["delay_s"] == 0 and not r["within_5cm"]}  # fmt: skip


def fit(flights: list[dict], delays, fault: str, control: bool = True) -> tuple[dict, float | None]:
    """Per delay the largest worst margin of a ``fault`` flight that did not hold (0 when
    none), and the smallest slope c with c * D above every one of them (None: no ``fault``
    flight). With ``control``, the designs that did not hold at D = 0 are left out
    (:func:`not_the_delays`)."""
    void = not_the_delays(flights, fault) if control else set()
    needed = {}
    for d in delays:
        lost = [r["worst_fault_margin"] for r in flights
                if r["fault"] == fault and r["delay_s"] == d and not r["within_5cm"]
                and (r["task"], r["required_margin"]) not in void]  # fmt: skip
        needed[d] = max(lost, default=0.0)
    if not any(r["fault"] == fault for r in flights):
        return needed, None
    return needed, max((needed[d] / d for d in delays if d > 0), default=0.0)


COLUMNS = ("task", "fault", "required_margin", "modules", "certified", "worst_fault_margin",
           "cells", "delay_s", "max_error_cm", "within_5cm", "why_not", "command")  # fmt: skip
"""The columns of flights.csv, in order (what ``--update`` reads back)."""
OLDER_COLUMNS = tuple(c for c in COLUMNS if c not in ("cells", "why_not"))
"""The columns of a flights.csv written before the cells and the verdict's reason were kept."""
OUTPUTS = ("report.md", "flights.csv", "margin_rule.png")
MAX_DELAY = 1.0
"""Longest delay flown (s): the hover flies 3 s after the failure, so the delay lies within it."""


def read_flights(path: Path) -> list[dict]:
    """The rows of an earlier flights.csv, numbers and booleans restored; a one-line ValueError
    naming the file and the 1-based row for anything :func:`fly` never writes."""
    return read_rows_csv(path, "--update", COLUMNS, typed_flight, "benchmarks.fault_delay",
                         older=(OLDER_COLUMNS,))  # fmt: skip


def typed_flight(raw: dict) -> dict | None:
    """A row of flights.csv typed as :func:`fly` writes it; None for values it never writes."""
    flags = {"True": True, "False": False}
    row = {**{c: raw.get(c, "") for c in COLUMNS}, "modules": int(raw["modules"]),
           "certified": flags[raw["certified"]],
           "within_5cm": flags[raw["within_5cm"]]}  # fmt: skip
    for key in ("required_margin", "worst_fault_margin", "delay_s", "max_error_cm"):
        row[key] = real_option(raw[key])
    ranges = (0 <= row["required_margin"] < 1 and 0 <= row["delay_s"] <= MAX_DELAY
              and row["max_error_cm"] >= 0 and row["modules"] >= 1)  # fmt: skip
    return row if ranges and row["fault"] in FAULTS and row["task"] else None


def plot(path: Path, flights: list[dict], slopes: dict, delays) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, len(FAULTS), figsize=(10, 4), sharey=True)
    for ax, fault in zip(axes, FAULTS):
        for ok, mark, label in ((True, "o", "within 5 cm"), (False, "x", "beyond 5 cm")):
            pts = [(r["delay_s"], r["worst_fault_margin"]) for r in flights
                   if r["within_5cm"] == ok and r["fault"] == fault]  # fmt: skip
            if pts:
                x, y = np.array(pts).T
                ax.scatter(1000 * x, y, marker=mark, label=label, alpha=0.6)
        if slopes[fault] is not None:
            d = np.linspace(0, max(delays), 20)
            ax.plot(1000 * d, slopes[fault] * d, "k--", label=f"fit: mu = {slopes[fault]:.2f} D")
        ax.set_title(f"{fault} failure" + ("" if slopes[fault] is not None else " (no flights)"))
        ax.set_xlabel("detection delay D (ms)")
        if ax.get_legend_handles_labels()[0]:  # a fault with no flight has nothing to name
            ax.legend(fontsize=8)
    axes[0].set_ylabel("worst fault margin of the design")
    fig.tight_layout()
    save_figure(fig, path)
    plt.close(fig)


def margin_option(text: str) -> float:
    """An argparse ``type`` for a required fault margin: a number in [0, 1)."""
    try:
        return check_fault_margin(real_option(text))
    except ValueError as exc:
        raise argparse.ArgumentTypeError(str(exc).removeprefix("fault_margin ")) from None


margin_option.__name__ = "margin"


def delay_option(text: str) -> float:
    """An argparse ``type`` for a detection delay flown: seconds in [0, :data:`MAX_DELAY`]."""
    value = real_option(text)
    if not 0.0 <= value <= MAX_DELAY:
        raise argparse.ArgumentTypeError(f"must lie in [0, {MAX_DELAY:g}] s, got {value:g}")
    return value


delay_option.__name__ = "delay"


def parse_args(argv: list[str] | None) -> tuple[argparse.Namespace, list[dict]]:
    """The options, checked before any work (one line, exit 2), and the earlier flights that
    ``--update`` keeps."""
    options = {
        "--tasks": dict(type=int_option(1, 1000), default=4, help="tasks per source (default 4)"),
        "--skip": dict(type=int_option(0, 999), default=0,
                       help="leave out the first SKIP tasks of each source (new tasks for a run "
                            "that adds to an earlier one)"),
        "--sources": dict(nargs="+", action=Distinct, default=list(SOURCES),
                          choices=list(GENERATORS),
                          help="task generators (default: paper planted motions)"),
        "--margins": dict(type=margin_option, nargs="+", action=Distinct,
                          default=[0.0, 0.02, 0.05, 0.1, 0.15],
                          help="required fault margins, each in [0, 1)"),
        "--delays": dict(type=delay_option, nargs="+", action=Distinct,
                         default=[0.0, 0.01, 0.02, 0.03, 0.05],
                         help=f"detection delays flown (s), each in [0, {MAX_DELAY:g}], one at "
                              "least above 0 (the rule is fitted on them); 0 flies the control: "
                              "a design that fails with the failure known at once is left out "
                              "of the fit (default 0 0.01 0.02 0.03 0.05)"),
        "--n-max": dict(type=int_option(1, 128), default=12, help="module budget (default 12)"),
        "--time-limit": dict(type=time_limit_option, default=10.0,
                             help="seconds per search (default 10)"),
        "--update": dict(action="store_true",
                         help="keep the flights of flights.csv in --out (other tasks) and fit on "
                              "all (it replaces that file; the report and figure need --force)"),
    }  # fmt: skip
    args = bench_args(argv, "python -m benchmarks.fault_delay", __doc__.split("\n\n")[0],
                      options, seed_help=None, out="results/fault_delay", force=True)  # fmt: skip
    if args.skip >= args.tasks:
        raise ValueError(f"--skip {args.skip}: must be below --tasks {args.tasks}")
    if not any(d > 0 for d in args.delays):
        raise ValueError("--delays: give one delay above 0 at least (the rule is fitted on them)")
    old = []
    if args.update:
        if not (args.out / "flights.csv").is_file():
            raise ValueError(f"--update: no flights.csv in {args.out} to add to (run once "
                             "without it)")  # fmt: skip
        old = read_flights(args.out / "flights.csv")
    check_output_dir(args.out, OUTPUTS[::2] if args.update else OUTPUTS, args.force)
    return args, old


def main(argv: list[str] | None = None) -> int:
    args, old = parse_args(argv)
    command = command_as_run("fault_delay", argv)
    tasks = [
        draw_task(make_generator(src), CALIBRATION_SEED0 + 1000 * k + i, f"{src}-cal-{i}")
        for k, src in enumerate(args.sources)
        for i in range(args.skip, args.tasks)
    ]
    new = fly(designs(tasks, args.margins, args.n_max, args.time_limit), args.delays)
    names = {t.name for t in tasks}
    made = [{**r, "command": command} for r in new]
    flights = [{c: r.get(c, "") for c in COLUMNS}
               for r in [*(r for r in old if r["task"] not in names), *made]]  # fmt: skip
    if not flights:
        raise ValueError(f"no structure of up to --n-max {args.n_max} modules for any task, "
                         "fault and margin: nothing flown, nothing written")  # fmt: skip
    write_csv(flights, args.out / "flights.csv")
    delays = sorted({r["delay_s"] for r in flights})
    fits = {fault: fit(flights, delays, fault) for fault in FAULTS}
    plot(args.out / "margin_rule.png", flights, {f: fits[f][1] for f in FAULTS}, delays)
    text = report(flights, fits, delays, args.sources)
    write_text(args.out / "report.md", text)
    print(text)
    return 0


def verdict_words() -> str:
    """How each flight was flown and judged, in words, from the constants the flights used."""
    from modquad_gym.sim import fault_verdict as v
    from modquad_gym.sim.fault_flight import FAULT_BEFORE_S, FAULT_SECONDS

    return (
        "Each design flies its smallest-margin failure only (`fly_with_failure(..., "
        'failure="worst")`; `modquad validate` flies every failure by default): a hover holds '
        f"{FAULT_BEFORE_S:g} s, the failure strikes and it flies {FAULT_SECONDS:g} s more; a "
        "trajectory flies to its end, then holds its last point (at rest) until "
        f"{FAULT_SECONDS:g} s after the failure and at least {2 * v.SETTLE_WINDOW_S:g} s after "
        "the end, so that the settling windows judge the hold. *Within 5 cm* is the flight's "
        "verdict (`modquad_gym.sim.fault_verdict`): never stopped, within "
        f"{100 * v.GOAL_M:g} cm from the failure on, and settled at its end (the last "
        f"{v.SETTLE_WINDOW_S:g} s window's largest error not above the window before's by more "
        f"than {100 * v.SETTLE_GROWTH:g} % + {1000 * v.SETTLE_FLOOR_M:g} mm, and a working rotor "
        "off its limits in the last window). *Not settled* counts the flights within 5 cm that "
        "the settling test alone failed (flights.csv, column why_not)."
    )


def control_lines(flights: list[dict], delays) -> list[str]:
    """The designs left out of the fit (they fail with the failure known at once) and the fit
    with them, per fault; nothing when no delay 0 was flown."""
    if 0 not in delays:
        return ["No flight with the failure known at once (delay 0): every flight is fitted."]
    lines = []
    for fault in FAULTS:
        void = sorted(not_the_delays(flights, fault))
        designs = {(r["task"], r["required_margin"]) for r in flights if r["fault"] == fault}
        with_them = fit(flights, delays, fault, control=False)[1]
        why = {(r["task"], r["required_margin"]): r["why_not"] for r in flights
               if r["fault"] == fault and r["delay_s"] == 0}  # fmt: skip
        named = "; ".join(f"{t} margin {m:g} ({why[t, m] or 'beyond 5 cm'})" for t, m in void)
        lines.append(f"- {fault}: {len(void)} of {len(designs)} designs do not hold with the "
                     f"failure known at once, left out of the fit" + (f": {named}" if void else "")
                     + ("" if with_them is None else f"; with them the fit would be "
                        f"{with_them:.3f} D"))  # fmt: skip
    return [
        "A design that does not hold even with the failure known at once (delay 0) fails "
        "for another reason than the delay (a flight that never settles, or saturates, "
        "whatever the delay), so its flights are left out of the fit:",
        "",
        *lines,
    ]


def binding(flights: list[dict], delays, fault: str) -> str:
    """The flight that sets ``fault``'s fit (the largest margin per second of delay of a flight
    that did not hold) and the fit without it, and without its task: whether one flight, or one
    task, alone sets the rule."""
    void = not_the_delays(flights, fault)
    lost = [r for r in flights if r["fault"] == fault and not r["within_5cm"] and r["delay_s"] > 0
            and (r["task"], r["required_margin"]) not in void]  # fmt: skip
    if not lost:
        return ""
    top = max(lost, key=lambda r: r["worst_fault_margin"] / r["delay_s"])
    rest = fit([r for r in flights if r is not top], delays, fault)[1] or 0.0
    task = fit([r for r in flights if r["task"] != top["task"]], delays, fault)[1] or 0.0
    why = f", {top['why_not']}" if top.get("why_not") else ""
    return (f"; set by {top['task']} (margin {top['worst_fault_margin']:.4g}, {top['modules']} "
            f"modules) at {1000 * top['delay_s']:g} ms ({top['max_error_cm']:.2f} cm{why}); "
            f"without that flight the fit would be {rest:.3f} D, without that task's flights "
            f"{task:.3f} D")  # fmt: skip


def report(flights: list[dict], fits: dict, delays: list[float], sources) -> str:
    """The report page: the commands, how the flights were judged, the flights per fault and
    delay, the fit, the flight that sets it, and the rule (a fault with no flight, where no
    design was found within n_max, says so)."""
    commands = list(dict.fromkeys(r["command"] for r in flights))
    lines = [
        "# The fault margin a detection delay needs",
        "",
        f"Made by {', then '.join(f'`{c}`' for c in commands)} on {machine_description()} "
        f"(shared with other work: the searches' time limits bought less search; load average "
        f"when this page was written {load_average()}).",
        "",
        f"{len({r['task'] for r in flights})} tasks drawn from the sources "
        f"{', '.join(sources)} with the calibration's own seeds ({CALIBRATION_SEED0:,} + "
        "1000 k + i, disjoint from every suite), faults rotor and module, designs for required "
        f"margins {sorted({r['required_margin'] for r in flights})} ({len(flights)} flights of "
        f"{len({(r['task'], r['fault'], r['required_margin']) for r in flights})} designs), each "
        f"flown through its smallest-margin failure at delays "
        f"{[f'{1000 * d:g} ms' for d in delays]}.",
        "",
        verdict_words(),
        "",
        "| fault | delay | flights | within 5 cm | not settled | largest worst margin fitted "
        "(not held) | largest error (cm) |",
        "|---|---|---|---|---|---|---|",
    ]
    for fault in FAULTS:
        for dl in delays:
            rs = [r for r in flights if r["delay_s"] == dl and r["fault"] == fault]
            worst = f"{max(r['max_error_cm'] for r in rs):.2f}" if rs else "-"
            needed = f"{fits[fault][0][dl]:.4f}" if rs else "-"
            unsettled = sum(str(r.get("why_not", "")).startswith("not settled") for r in rs)
            unsettled = unsettled if rs else "-"
            lines.append(f"| {fault} | {1000 * dl:g} ms | {len(rs)} | "
                         f"{sum(r['within_5cm'] for r in rs)} | {unsettled} | {needed} | "
                         f"{worst} |")  # fmt: skip
    lines += ["", *control_lines(flights, delays)]
    lines += ["", "Fit through the origin above every threshold, and the rule "
              f"(modquad_gym.oracle.fault_delay.DELAY_SLOPES: {SAFETY:g} times the fit, rounded "
              f"up to 0.05), for D up to {max(delays):g} s (the delays flown):", ""]  # fmt: skip
    for fault in FAULTS:
        slope = fits[fault][1]
        if slope is None:
            lines.append(f"- {fault}: no flights (no design within n_max), no fit")
            continue
        rule = np.ceil(round(SAFETY * slope / 0.05, 9)) * 0.05
        lines.append(f"- {fault}: fit mu = {slope:.3f} D, rule mu = {rule:.2f} D"
                     f"{binding(flights, delays, fault)}")  # fmt: skip
    return "\n".join([*lines, "", "![rule](margin_rule.png)", ""])


if __name__ == "__main__":
    raise SystemExit(run_main(main, "fault_delay"))
