"""``modquad validate``: solve a task, then check the structure in MuJoCo (wrench bench and
hover; for a dynamic task also a flight along its trajectory,
:func:`modquad_gym.sim.validate_track.validate_trajectory`)."""

from __future__ import annotations

import argparse
import json
import sys

from modquad_gym.cli import common, solve  # common.load_task, solve.solver (tests replace them)
from modquad_gym.cli.common import add_command, add_csv_header, add_force, add_method
from modquad_gym.core.options import int_option, real_option

DEFAULT_HOVER_WRENCHES = 20
MAX_HOVER_SECONDS = 60.0
DEFAULT_LOAD_RAMP = 1.0
"""Seconds of the unknown-load ramp when ``--load-ramp-seconds`` is not given (the simulation
shortens it for segments shorter than the ramp)."""
MAX_ESTIMATED_SECONDS = 3600.0
"""Longest estimated run ``validate`` starts without ``--allow-long``."""
SECONDS_PER_SIMULATED_SECOND = 0.25
"""Wall seconds per simulated hover second on the reference machine (2 cores), for the
estimate ``validate`` prints before it starts."""

OUTPUT_NAMES = ("report.md", "validation.json", "hover.png", "bench_wrench.png", "rotor_inputs.png")
"""The files ``validate`` writes into ``--out`` (refused up front when they exist)."""
TRACK_NAMES = ("track_path.png", "track_inputs.png", "track.gif")
"""What a dynamic task's flight adds to ``--out``."""
SECONDS_PER_FLOWN_SECOND = 1.5
"""Wall seconds per simulated second of a trajectory flight (2 cores, pictures included)."""


def add_validate(sub) -> None:
    p = add_command(
        sub,
        "validate",
        cmd_validate,
        help="search, then MuJoCo wrench bench and hover",
        description="Solve the task, then validate the structure in MuJoCo: a "
        "wrench bench (measured vs commanded wrench) and a hover under each task "
        "wrench. Pictures and report.md go to --out.",
    )
    p.add_argument(
        "--task", required=True, metavar="FILE", help="task file (.json, .csv, .npy) to solve"
    )
    add_method(p)
    p.add_argument("--out", default="validation", help="output folder (default %(default)s)")
    p.add_argument("--json", action="store_true", help="print the summary as one JSON object")
    p.add_argument(
        "--infeasible-demo",
        action="store_true",
        help="also hover under a wrench scaled past the boundary: it saturates and drifts",
    )
    p.add_argument(
        "--max-hover-wrenches",
        type=int_option(1, 2**63 - 1),
        default=DEFAULT_HOVER_WRENCHES,
        help="hover under at most this many task wrenches: the half nearest the boundary "
        "(smallest margin) and a seeded sample of the rest; each is held for --hover-seconds "
        "simulated seconds after a take-off of the same length (default %(default)s)",
    )
    p.add_argument(
        "--all-wrenches",
        action="store_true",
        help="hover under every task wrench (a time estimate is printed first)",
    )
    p.add_argument(
        "--hover-seconds",
        type=real_option,
        default=2.0,
        help="simulated seconds per hover segment (default %(default)s), at most "
        f"{MAX_HOVER_SECONDS:g}",
    )
    p.add_argument(
        "--load-ramp-seconds",
        type=real_option,
        default=None,
        help="unknown-load hover: seconds over which the load moves from one task wrench to the "
        f"next, at most --hover-seconds (0: a step; default {DEFAULT_LOAD_RAMP:g}, shortened "
        "for short segments)",
    )
    p.add_argument(
        "--known-load-only",
        action="store_true",
        help="fly only the hover whose controller knows the applied load (feed-forward); by "
        "default a second hover estimates the load by integral action",
    )
    p.add_argument(
        "--allow-long",
        action="store_true",
        help=f"run even when the time estimate exceeds {MAX_ESTIMATED_SECONDS:,.0f} s "
        "(default: refuse before any simulation)",
    )
    add_csv_header(p)
    add_force(p)


def cmd_validate(args: argparse.Namespace) -> int:
    from modquad_gym.core.outputs import check_output_dir
    from modquad_gym.core.validation import check_int, check_real
    from modquad_gym.sim.validate import validate

    check_real(args.hover_seconds, "--hover-seconds", 0.05, MAX_HOVER_SECONDS)
    ramp = DEFAULT_LOAD_RAMP
    if args.load_ramp_seconds is not None:  # only a value the user gave is checked against theirs
        ramp = check_real(args.load_ramp_seconds, "--load-ramp-seconds", 0.0, args.hover_seconds)
    k = None if args.all_wrenches else check_int(args.max_hover_wrenches, "--max-hover-wrenches", 1)
    task = common.load_task(args.task, args.csv_header)
    dynamic = getattr(task, "kind", None) == "dynamic"
    common.check_task(task, args.task, common.palette(args))
    check_output_dir(args.out, OUTPUT_NAMES + (TRACK_NAMES if dynamic else ()), force=args.force)
    n_hover = task.n_wrenches if k is None else min(k, task.n_wrenches)
    flights = 1 if args.known_load_only else 2
    simulated = flights * (n_hover + 1) * args.hover_seconds
    estimate = simulated * SECONDS_PER_SIMULATED_SECOND
    if dynamic:
        simulated += task.trajectory.duration
        estimate += task.trajectory.duration * SECONDS_PER_FLOWN_SECOND
    if estimate > MAX_ESTIMATED_SECONDS and not args.allow_long:
        raise ValueError(
            f"{args.task}: hovering under {n_hover:,} wrenches takes about {estimate:,.0f} s, "
            f"more than {MAX_ESTIMATED_SECONDS:,.0f} s; hover under fewer "
            "(--max-hover-wrenches N) or give --allow-long"
        )
    print(
        f"validate: bench on {n_hover if dynamic else task.n_wrenches} wrenches, hover under "
        f"{n_hover}{', fly the trajectory' if dynamic else ''}: about {simulated:g} simulated s "
        f"(~{estimate:.0f} s here)",
        file=sys.stderr,
    )
    result = solve.solver(args, task)(task)
    if result.structure is None:
        record = {
            "task": args.task,
            "feasible": False,
            "cells": None,
            "bench_max_error": None,
            "hover_max_position_error_m": None,
        }
        if dynamic:
            record["track_max_position_error_m"] = None
        print(json.dumps(record) if args.json else f"no structure found for {args.task}")
        return 0
    if dynamic:
        from modquad_gym.sim.validate_track import validate_trajectory

        report = validate_trajectory(result.structure, task, out_dir=args.out,
                                     max_bench_wrenches=n_hover, hover_seconds=args.hover_seconds,
                                     unknown_load=not args.known_load_only)  # fmt: skip
        return show(args, report)
    report = validate(
        result.structure,
        task.wrenches,
        f_max=task.f_max,
        out_dir=args.out,
        include_infeasible_demo=args.infeasible_demo,
        max_hover_wrenches=k,
        hover_seconds=args.hover_seconds,
        unknown_load=not args.known_load_only,
        load_ramp_seconds=ramp,
        kind=task.kind,
    ).to_dict()
    return show(args, report)


def show(args: argparse.Namespace, report: dict) -> int:
    """Print the validation record (one JSON object with ``--json``)."""
    if args.json:
        print(json.dumps({"task": args.task, "method": args.method, **report}))
    else:
        for key, value in report.items():
            print(f"{key}: {value}")
    return 0
