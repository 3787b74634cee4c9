"""``modquad validate``: solve a task, then check the structure in MuJoCo (wrench bench and
hover; for a dynamic task also a flight along its trajectory,
:func:`modquad_gym.sim.validate_track.validate_trajectory`)."""

from __future__ import annotations

import argparse
import json
import sys

from modquad_gym.cli import common, solve  # common.load_task, solve.solver (tests replace them)
from modquad_gym.cli import validate_fault as fault  # --fault: flights through a failure
from modquad_gym.cli.common import add_command, add_csv_header, add_force, add_method
from modquad_gym.cli.given import refuse_ignored
from modquad_gym.cli.quiet import add_quiet
from modquad_gym.core.options import int_option, path_option, real_option

MAX_ESTIMATED_SECONDS = 3600.0
"""Longest estimated run ``validate`` starts without ``--allow-long``."""
SECONDS_PER_SIMULATED_SECOND = 0.25
"""Wall seconds per simulated hover second on the reference machine (2 cores), for the
estimate ``validate`` prints before it starts."""

MAX_PRINTED_CELLS = 8
"""Cells the console summary lists (all of them are in ``validation.json``)."""
SECONDS_PER_FLOWN_SECOND = 1.5
"""Wall seconds per simulated second of a trajectory flight (2 cores, pictures included)."""
SECONDS_PER_PICTURE = 2.0
"""Wall seconds to draw and write one picture of the report (a 47-module structure's, 2 cores)."""


def add_validate(sub) -> None:
    from modquad_gym.sim import hover_options as hover  # Python's defaults (sim: only when built)

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
    p.add_argument(
        "--out", type=path_option, default="validation", help="output folder (default %(default)s)"
    )
    p.add_argument(
        "--json",
        action="store_true",
        help="print the summary as one JSON object (a number with no finite value, such as the "
        "step headroom between two equal wrenches, which is unlimited, is null)",
    )
    p.add_argument(
        "--infeasible-demo",
        action="store_true",
        help="also hover under a wrench scaled past the boundary: it saturates and drifts",
    )
    p.add_argument(
        "--max-hover-wrenches",
        type=int_option(1, 2**63 - 1),
        default=hover.DEFAULT_HOVER_WRENCHES,
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
        default=hover.DEFAULT_HOVER_SECONDS,
        help="simulated seconds per hover segment (default %(default)s), "
        f"{hover.MIN_HOVER_SECONDS:g} to {hover.MAX_HOVER_SECONDS:g}",
    )
    p.add_argument(
        "--load-ramp-seconds",
        type=real_option,
        default=None,
        help="unknown-load hover: seconds over which the load moves from one task wrench to the "
        f"next, at most --hover-seconds (0: a step; default {hover.DEFAULT_LOAD_RAMP:g}, shortened "
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
    add_quiet(p, ", the hover a bar over its simulated seconds")
    add_csv_header(p)
    add_force(p)
    fault.add_fault_options(p)


def cmd_validate(args: argparse.Namespace) -> int:
    from modquad_gym.core.extras import require

    require("mujoco", "matplotlib")  # the [sim] extra, before any work or output

    from modquad_gym.core.outputs import check_output_dir
    from modquad_gym.sim.hover_options import CLI_NAMES, checked_hover  # Python's checks
    from modquad_gym.sim.validate import hold_out_dir  # Python's hold

    fault.check_fault_options(args)
    most = None if args.all_wrenches else args.max_hover_wrenches
    _, _, k = checked_hover(args.hover_seconds, args.load_ramp_seconds, most, CLI_NAMES)
    if args.all_wrenches:
        refuse_ignored(args, ["max_hover_wrenches"], "--all-wrenches hovers under every wrench")
    if args.known_load_only:
        refuse_ignored(args, ["load_ramp_seconds"], "it ramps the unknown load, whose hover "
                       "--known-load-only leaves out")  # fmt: skip
    task = common.load_task(args.task, args.csv_header)
    dynamic = getattr(task, "kind", None) == "dynamic"
    refuse_ignored(args, ["infeasible_demo", "load_ramp_seconds"] if dynamic else [],
                   f"applies to a static task; {args.task} is a dynamic one (flown along its "
                   "trajectory)")  # fmt: skip
    common.check_task(task, args.task, common.palette(args))
    common.check_simulable_types(args)
    names = output_names(args, dynamic)
    check_output_dir(args.out, names, force=args.force)
    n_hover = task.n_wrenches if k is None else min(k, task.n_wrenches)
    flights = 1 if args.known_load_only else 2
    simulated = flights * (n_hover + 1) * args.hover_seconds
    estimate = simulated * SECONDS_PER_SIMULATED_SECOND
    if dynamic:
        simulated += task.trajectory.duration
        estimate += task.trajectory.duration * SECONDS_PER_FLOWN_SECOND
    least = fault.least_modules(args, task) if args.fault else 1  # the structure's size unknown
    simulated += fault.fault_seconds(args, task, least)
    flights = fault.fault_wall_seconds(args, task, least)
    estimate += flights + SECONDS_PER_PICTURE * sum(name.endswith(".png") for name in names)
    if estimate > MAX_ESTIMATED_SECONDS and not args.allow_long:
        raise ValueError(
            f"{args.task}: hovering under {n_hover:,} wrenches"
            + fault.flights_words(args, least, flights)
            + f" takes about {estimate:,.0f} s, more than {MAX_ESTIMATED_SECONDS:,.0f} s; hover "
            f"under fewer (--max-hover-wrenches N){fault.fewer_words(args)} or give --allow-long"
        )
    print(
        f"validate: bench on {n_hover if dynamic else task.n_wrenches} wrenches, hover under "
        f"{n_hover}{', fly the trajectory' if dynamic else ''}: about {simulated:,.0f} simulated s "
        f"(~{estimate:.0f} s here){fault.search_seconds_text(args)}",
        file=sys.stderr,
    )
    with hold_out_dir(args.out, names, args.force, "--out"):  # a second run: refused at once
        return solve_and_fly(args, task, k, args.load_ramp_seconds, n_hover)


def output_names(args: argparse.Namespace, dynamic: bool) -> tuple[str, ...]:
    """Every file ``validate`` with these options writes into ``--out`` (refused up front when
    one exists, unless ``--force``), as the simulation names them: the bench, hovers and
    render of :func:`modquad_gym.sim.validate.output_names`, a dynamic task's flight
    (:data:`~modquad_gym.sim.validate_track.TRACK_FILES`) and the flights through a failure."""
    from modquad_gym.sim.validate import output_names as validation_names
    from modquad_gym.sim.validate_track import TRACK_FILES

    demo = args.infeasible_demo and not dynamic  # refused for a dynamic task anyway
    names = validation_names(unknown_load=not args.known_load_only, include_infeasible_demo=demo)
    return names + (TRACK_FILES if dynamic else ()) + fault.fault_output_names(args)


def solve_and_fly(args: argparse.Namespace, task, k: int | None, ramp: float | None,
                  n_hover: int):  # fmt: skip
    """The work of :func:`cmd_validate` once its options and ``--out`` are checked: solve, then
    bench, hover and (a dynamic task) fly the answer, writing into ``--out``; with ``--fault``
    the flights through a failure follow, and ``report.md`` and ``validation.json`` are written
    once, after them (a :class:`~modquad_gym.sim.validation_files.ReportPage` kept till then)."""
    from modquad_gym.sim.validate import validate
    from modquad_gym.sim.validation_files import ReportPage

    dynamic = getattr(task, "kind", None) == "dynamic"
    page = ReportPage() if args.fault is not None else None  # written by fault.fly_fault
    result = solve.solver(args, task)(task)
    if result.structure is not None:  # its failures counted, --failure K in range: before work
        fault.check_found(args, task, result.structure, MAX_ESTIMATED_SECONDS)

    def intact_solver(intact_args: argparse.Namespace):  # --fault: the intact minimum's search
        return solve.solver(intact_args, task)

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
        record |= fault.no_structure_keys(args)
        said = f"{result.status}: {result.describe(common.N_MAX_STEP)}"  # as solve says it
        print(json.dumps(record) if args.json else f"no structure found for {args.task}; {said}")
        return 0
    if dynamic:
        from modquad_gym.sim.validate_track import validate_trajectory

        report = validate_trajectory(result.structure, task, out_dir=args.out,
                                     max_bench_wrenches=n_hover, hover_seconds=args.hover_seconds,
                                     unknown_load=not args.known_load_only, force=args.force,
                                     progress=not args.quiet, command=made_by(args),
                                     page=page)  # fmt: skip
        report = with_lift(report, result.structure, task.f_max)
        return show(args, fault.fly_fault(args, task, result.structure, report, intact_solver,
                                          page))  # fmt: skip
    report = validate(
        result.structure,
        task,
        out_dir=args.out,
        include_infeasible_demo=args.infeasible_demo,
        max_hover_wrenches=k,
        hover_seconds=args.hover_seconds,
        unknown_load=not args.known_load_only,
        load_ramp_seconds=ramp,
        force=args.force,
        progress=not args.quiet,
        command=made_by(args),
        page=page,
    ).to_dict()
    report = with_lift(report, result.structure, task.f_max)
    return show(args, fault.fly_fault(args, task, result.structure, report, intact_solver, page))


def with_lift(report: dict, structure, f_max: float) -> dict:
    """``report`` with the structure's thrust-to-weight ratio at the task's ``f_max`` and the
    line ``modquad export`` prints on it (:func:`~modquad_gym.sim.export.lift_statement`); below
    1, why the hovers fly all the same: their external load holds it up."""
    from modquad_gym.sim.export import lift_statement, thrust_to_weight

    ratio, line = thrust_to_weight(structure, f_max), lift_statement(structure, f_max)
    if ratio < 1.0:
        line += ("; the hovers here apply its weight as part of their external load "
                 "d = -(w + gravity wrench), as export warns")  # fmt: skip
    return {**report, "thrust_to_weight": ratio, "lift": line}


def show(args: argparse.Namespace, report: dict) -> int:
    """Print the validation record: one JSON object with ``--json``, else a short summary
    (:func:`summary_lines`; every number is in ``validation.json`` and ``report.md``)."""
    if args.json:  # JSON: a number with no finite value (unlimited headroom) is null
        from modquad_gym.core.outputs import json_ready

        print(json.dumps(json_ready({"task": args.task, "method": args.method, **report})))
    else:
        print("\n".join(summary_lines(report) + fault.fault_lines(report)))
    return 0


def made_by(args: argparse.Namespace) -> str | None:
    """The command as run (None where it was not typed), which ``report.md`` names under its
    title (as every report under results/ does)."""
    import shlex

    from modquad_gym.cli.score import ARGV

    typed = getattr(args, ARGV, None)
    return None if typed is None else shlex.join(["modquad", *typed])


def _length(metres) -> str:
    """A distance in m (1 m and up), cm (1 cm and up) or mm, to 2 or 3 significant digits."""
    if metres is None:
        return "n/a"
    if metres >= 1.0:
        return f"{metres:.3g} m"
    return f"{100 * metres:.2g} cm" if metres >= 0.01 else f"{1000 * metres:.2g} mm"


def _share(fraction) -> str:
    return "n/a" if fraction is None else f"{100 * fraction:.3g} %"


def _row(index) -> object:
    """A 0-based task-row index of the record as the words number rows: from 1."""
    return index + 1 if isinstance(index, int) else index


def _number(x, spec: str = ".2g") -> str:
    return "n/a" if x is None else format(x, spec)


def summary_lines(r: dict) -> list[str]:
    """A validation record (:meth:`~modquad_gym.sim.report.ValidationReport.to_dict`, with the
    ``track_*`` keys of a flight) as a few lines a reader takes in at a glance."""
    cells = r.get("cells") or []
    if len(cells) > MAX_PRINTED_CELLS:  # every cell is in validation.json
        cells = f"{cells[:MAX_PRINTED_CELLS]}"[:-1] + ", ...]"
    names = r.get("modules") or []
    types = f", module types {', '.join(dict.fromkeys(names))}" if len(set(names)) > 1 else ""
    lines = [
        f"structure: {r.get('n_modules')} modules, {_number(r.get('mass_kg'), '.3g')} kg"
        f"{types}; cells {cells}",
        *([f"lift: {r['lift']}"] if r.get("lift") else []),
        f"task: {r.get('n_wrenches')} wrenches ({r.get('task_kind')}), {r.get('n_feasible')} "
        f"feasible, smallest margin {_number(r.get('min_margin'), '.3g')}"
        if r.get("task_kind") != "dynamic"
        else f"task: dynamic, {r.get('n_wrenches')} of its {r.get('trajectory_samples')} rotor "
        "wrenches (one per trajectory sample) sampled for the bench "
        f"and hovers ({r.get('n_feasible')} feasible), smallest margin along the trajectory "
        f"{_number(r.get('min_margin_trajectory'), '.3g')}",
        "bench: largest relative error, measured vs commanded wrench, "
        f"{_number(r.get('bench_max_error'))} (exact allocation), "
        f"{_number(r.get('bench_max_error_pinv_clip'))} (pseudo-inverse and clip: "
        f"{r.get('bench_pinv_clip_wrenches_missed')} wrenches missed)",
    ]
    hovers = r.get("hover_wrenches")
    lines.append(
        f"hover, load known: {hovers} wrenches x {_number(r.get('hover_seconds_per_wrench'), 'g')}"
        f" s: position error up to {_length(r.get('hover_max_position_error_m'))}, attitude "
        f"{_number(r.get('hover_max_attitude_error_rad'))} rad, saturated "
        f"{_share(r.get('saturated_fraction'))} of steps, {r.get('hover_diverged_segments')} "
        f"diverged, {r.get('hover_segments_within_1cm')} of {hovers} within 1 cm"
    )
    if "hover_unknown_load_max_position_error_m" in r:
        lines.append(
            "hover, load estimated: position error up to "
            f"{_length(r.get('hover_unknown_load_max_position_error_m'))}, attitude "
            f"{_number(r.get('hover_unknown_load_max_attitude_error_rad'))} rad, saturated "
            f"{_share(r.get('hover_unknown_load_saturated_fraction'))} of steps, "
            f"{r.get('hover_unknown_load_diverged_segments')} diverged, "
            f"{r.get('hover_unknown_load_segments_within_1cm')} of {hovers} within 1 cm, load "
            f"estimate error {_number(r.get('hover_unknown_load_max_load_estimate_error'))}"
        )
    demo = r.get("infeasible_demo")
    if isinstance(demo, dict):
        lines.append(
            f"infeasible demo (task row {_row(demo.get('from_task_row'))} scaled out of the set): "
            f"saturated {_share(demo.get('saturated_fraction'))} of steps, position error up to "
            f"{_length(demo.get('max_position_error_m'))}"
            f"{', diverged' if demo.get('diverged') else ''}"
        )
    if "track_max_position_error_m" in r:
        lines.append(
            f"flight: {_number(r.get('track_seconds'), '.3g')} s along the trajectory, position "
            f"error up to {_length(r.get('track_max_position_error_m'))} (rms "
            f"{_length(r.get('track_rms_position_error_m'))}), attitude "
            f"{_number(r.get('track_max_attitude_error_rad'))} rad, saturated "
            f"{_share(r.get('track_saturated_fraction'))} of steps"
            f"{', diverged' if r.get('track_diverged') else ''}"
        )
    files = [str(f) for f in (r.get("files") or {}).values()]
    if files:
        from os.path import basename, commonpath, dirname

        folder = commonpath([dirname(f) or "." for f in files])
        lines.append(f"wrote {folder}: {', '.join(basename(f) for f in files)}")
    return lines
