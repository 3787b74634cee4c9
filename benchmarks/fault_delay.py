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
``--render`` flies nothing: it writes report.md and margin_rule.png again from the flights.csv in
``--out`` (:mod:`benchmarks.fault_delay_report`), the page naming the commands that flew them.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import modquad_gym as mq
from benchmarks.common import (
    Distinct,
    bench_parser,
    command_as_run,
    int_option,
    parse_bench_args,
    read_input_text,
    read_rows_csv,
    run_main,
    write_csv,
)
from benchmarks.fault_delay_report import CALIBRATION_SEED0, FAULTS, render
from modquad_gym.cli.common import time_limit_option
from modquad_gym.cli.given import typed_options
from modquad_gym.core.options import real_option
from modquad_gym.core.outputs import check_output_dir
from modquad_gym.oracle.failures import check_fault_margin
from modquad_gym.scoring.suites import draw_task
from modquad_gym.tasks import GENERATORS, make_generator

SOURCES = ("paper", "planted", "motions")


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


COLUMNS = ("task", "fault", "required_margin", "modules", "certified", "worst_fault_margin",
           "cells", "delay_s", "max_error_cm", "within_5cm", "why_not", "command")  # fmt: skip
"""The columns of flights.csv, in order (what ``--update`` reads back)."""
OLDER_COLUMNS = tuple(c for c in COLUMNS if c not in ("cells", "why_not"))
"""The columns of a flights.csv written before the cells and the verdict's reason were kept."""
OUTPUTS = ("report.md", "flights.csv", "margin_rule.png")
MAX_DELAY = 1.0
"""Longest delay flown (s): the hover flies 3 s after the failure, so the delay lies within it."""


def read_flights(path: Path, option: str = "--update") -> list[dict]:
    """The rows of an earlier flights.csv, numbers and booleans restored; a one-line ValueError
    naming ``option``, the file and the 1-based row for anything :func:`fly` never writes."""
    return read_rows_csv(path, option, COLUMNS, typed_flight, "benchmarks.fault_delay",
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
    ``--update`` keeps (``--render``: the flights it renders)."""
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
        "--render": dict(action="store_true",
                         help="fly nothing: write report.md and margin_rule.png again from the "
                              "flights.csv in --out (no other option but --out and --force)"),
    }  # fmt: skip
    parser = bench_parser("python -m benchmarks.fault_delay", __doc__.split("\n\n")[0], options,
                          seed_help=None, out="results/fault_delay", force=True)  # fmt: skip
    args = parse_bench_args(parser, argv)
    if args.render:
        given = typed_options(parser, sys.argv[1:] if argv is None else argv)
        flown = [f for f in options if f != "--render" and f[2:].replace("-", "_") in given]
        if flown:
            raise ValueError(f"--render: flies nothing, so not with {', '.join(flown)}")
        old = _earlier(args, "--render", "to render")
        if not old:
            raise ValueError(f"--render: {args.out / 'flights.csv'} holds no flight to render")
        return args, old
    if args.skip >= args.tasks:
        raise ValueError(f"--skip {args.skip}: must be below --tasks {args.tasks}")
    if not any(d > 0 for d in args.delays):
        raise ValueError("--delays: give one delay above 0 at least (the rule is fitted on them)")
    if args.update:
        return args, _earlier(args, "--update", "to add to (run once without it)")
    check_output_dir(args.out, OUTPUTS, args.force)
    return args, []


def _earlier(args: argparse.Namespace, option: str, why: str) -> list[dict]:
    """The flights of flights.csv in ``--out``, which ``option`` reads (and replaces only with
    ``--update``), once the report and the figure it writes may be replaced (``--force``)."""
    if not (args.out / "flights.csv").is_file():
        raise ValueError(f"{option}: no flights.csv in {args.out} {why}")
    flights = read_flights(args.out / "flights.csv", option)
    check_output_dir(args.out, OUTPUTS[::2], args.force)
    return flights


def main(argv: list[str] | None = None) -> int:
    args, old = parse_args(argv)
    command = command_as_run("fault_delay", argv)
    if args.render:
        page = args.out / "report.md"
        kept = read_input_text(page, "--render") if page.is_file() else ""
        print(render(args.out, old, command, kept))
        return 0
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
    print(render(args.out, flights))
    return 0


if __name__ == "__main__":
    raise SystemExit(run_main(main, "fault_delay"))
