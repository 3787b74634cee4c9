"""The ``modquad`` command line: solve tasks, generate task files, draw structures, validate in
MuJoCo, and run the benchmarks. ``modquad COMMAND --help`` explains each command.

Exit codes: 0 on success (an infeasible task is a result, not an error); 2 for every expected
failure (a task file that cannot be read, a bad option value, an output path that exists or
cannot be written, a missing optional dependency, a closed output pipe), reported as one line
``modquad: error: ...`` naming the file or option; 130 when interrupted (Ctrl-C).
"""

from __future__ import annotations

import argparse
import functools
import importlib
import json
import os
import sys
from pathlib import Path

from .agents.solvers import LEARNED, METHOD_HELP, METHODS
from .extras import EXTRA_OF, missing_extra_message
from .options import int_option, real_option, seed_option

N_MAX_OPTION = int_option(1, 2**63 - 1)
"""``--n-max``: any positive integer parses; each search says how far it can go."""

MAX_WORKERS = 256
"""Most processes ``solve --workers`` accepts."""

SUITES_DIR = Path(__file__).resolve().parent / "data" / "suites"


EXTERNAL_F_MAX = 2.0
"""Default rotor thrust limit (N) of generated ``external`` tasks: with 0.3 kg modules a flat
module lifts 8 N against its 2.94 N weight, a T-module 5.66 N."""

DEFAULT_HOVER_WRENCHES = 20
MAX_HOVER_SECONDS = 60.0
SECONDS_PER_SIMULATED_SECOND = 0.25
"""Wall seconds per simulated hover second on the reference machine (2 cores), for the
estimate ``validate`` prints before it starts."""


def _load_task(path: str, csv_header: str = "auto"):
    from .tasks import TaskRequirement

    return TaskRequirement.load(path, csv_header=csv_header)


def _parse_cells(text: str) -> list:
    """``--cells`` as a list of [x, y] pairs, or a ValueError naming the option."""
    try:
        cells = json.loads(text)
    except (json.JSONDecodeError, RecursionError):
        raise ValueError(f"--cells: not JSON: {text!r} (e.g. '[[0,0],[1,0]]')") from None
    if not isinstance(cells, list):
        raise ValueError(f"--cells: expected a JSON list of [x, y] pairs, got {text!r}")
    return cells


def _palette_of(text: str | None):
    """``--modules`` text as a list of module types, or None when not given."""
    if text is None:
        return None
    from .module import palette

    try:
        return palette(text)
    except ValueError as exc:  # "modules: ..." -> "--modules: ..."
        raise ValueError(f"--{exc}") from None


def _palette(args):
    """``--modules`` as a list of module types, or None when not given."""
    return _palette_of(getattr(args, "modules", None))


@functools.lru_cache(maxsize=4)
def _make_solver(method, n_max, model, seed, modules_text, workers, address, progress: bool):
    """The solver for ``--method`` (PPO lives in the agents package, searches here); cached, so
    a worker process that solves many tasks loads a PPO model once."""
    modules = _palette_of(modules_text)
    if method in LEARNED:
        if modules is not None:
            raise ValueError("--modules: the PPO agent builds one-type structures only")
        from modquad_gym.agents.solvers import make_solver

        return make_solver(method, n_max=n_max, model=model, seed=seed).solve
    from .search import SEARCHES

    fn = SEARCHES[method]
    typed = {} if modules is None else {"modules": modules}
    if method == "random":
        return lambda task: fn(task, n_max=n_max, seed=seed, **typed)
    if method == "exhaustive":
        return lambda task: fn(
            task, n_max=n_max, workers=workers, address=address, progress=progress, **typed
        )
    return lambda task: fn(task, n_max=n_max, **typed)


def _solver(args, workers=1):
    """The solver of ``args`` (``workers`` share the levels of one exhaustive search)."""
    progress = not (getattr(args, "json", False) or getattr(args, "quiet", False))
    modules = getattr(args, "modules", None)
    address = getattr(args, "ray_address", None)
    return _make_solver(
        args.method, args.n_max, args.model, args.seed, modules, workers, address, progress
    )


def _solve_file(options: tuple, path: Path):
    """Load and solve one task file (the unit of work of a batch): (task, result)."""
    method, n_max, model, seed, modules, csv_header = options
    task = _load_task(path, csv_header)
    result = _make_solver(method, n_max, model, seed, modules, 1, None, False)(task)
    return task, result


def cmd_solve(args) -> int:
    from .distributed import Engine, Failed
    from .tasks import task_files

    _palette(args)  # a bad --modules is refused before any work
    paths = task_files(args.task)
    engine = Engine(args.workers, args.ray_address, local_default=1)
    if len(paths) == 1 or not engine.use_ray:
        return _solve_here(args, paths, engine.workers or engine.cluster_cpus())
    # a batch: tasks spread over the workers, each search in one process
    options = (args.method, args.n_max, args.model, args.seed, args.modules, args.csv_header)
    failed: list[Failed] = []
    printed = 0
    done: dict[int, object] = {}

    def show_in_order(i: int, outcome) -> None:
        nonlocal printed
        done[i] = outcome
        while printed in done:
            outcome = done.pop(printed)
            if isinstance(outcome, Failed):
                failed.append(outcome)
                print(f"modquad: error: {outcome.error}", file=sys.stderr, flush=True)
            else:
                _print_result(args, paths[printed], *outcome)
            printed += 1

    # by its module's name (not __main__ under `python -m`), so Ray workers import it
    solve_file = importlib.import_module("modquad_gym.cli")._solve_file
    with engine:
        engine.map(
            functools.partial(solve_file, options),
            paths,
            labels=[str(p) for p in paths],
            catch=True,
            progress=not (args.json or args.quiet),
            desc="tasks",
            on_result=show_in_order,
        )
    return _batch_status(failed, len(paths))


def _solve_here(args, paths: list[Path], workers: int) -> int:
    """Solve in this process, one task after the other (a single task's exhaustive search may
    still split its large levels over ``workers``)."""
    solve = _solver(args, workers=workers if len(paths) == 1 else 1)
    failed = []
    for path in paths:
        try:
            task = _load_task(path, args.csv_header)
        except (ValueError, OSError) as exc:
            if len(paths) == 1:
                raise
            failed.append(exc)
            print(f"modquad: error: {_one_line(exc)}", file=sys.stderr, flush=True)
            continue
        _print_result(args, path, task, solve(task))
    return _batch_status(failed, len(paths))


def _batch_status(failed: list, total: int) -> int:
    if not failed:
        return 0
    print(f"modquad: error: {len(failed)} of {total} tasks failed (above)", file=sys.stderr)
    return 2


def _print_result(args, path, task, result) -> None:
    if args.json:
        record = {"task": str(path), "name": task.name, **result.to_dict()}
        print(json.dumps(record), flush=True)
        return
    kind = "" if task.kind == "total" else f" ({task.kind})"
    print(f"task {task.name!r} ({path}): {task.n_wrenches} wrenches{kind}, method {args.method}")
    if result.structure is None:
        print(f"  no structure of up to {args.n_max} modules satisfies the task")
    else:
        cert = " (certified minimum)" if result.certified else ""
        print(f"  {result.n_modules} modules{cert}: cells {list(result.structure.cells)}")
        if result.palette:
            print(f"  module types: {[m.name for m in result.structure.modules]}")
        print("  " + result.structure.to_text().replace("\n", "\n  "))
    print(
        f"  configurations evaluated: {result.evaluated}, oracle calls: "
        f"{result.oracle_calls}, seconds: {result.seconds:.3f}",
        flush=True,
    )


def cmd_optima(args) -> int:
    from .distributed import Engine, Failed
    from .optima import build_dataset
    from .outputs import check_output_file
    from .search.exhaustive import MAX_MODULES
    from .tasks import load_suite, task_files
    from .validation import check_int

    n_max = check_int(args.n_max, "--n-max", low=1, high=MAX_MODULES)
    out = check_output_file(args.out, force=True, what="--out")
    if args.suite:
        path = Path(args.suite)
        if not path.suffix and not path.exists():
            path = SUITES_DIR / f"{args.suite}.json"
            if not path.exists():
                names = ", ".join(sorted(p.stem for p in SUITES_DIR.glob("*.json")))
                raise ValueError(f"--suite: no suite {args.suite!r} (shipped: {names})")
        sources = [(f"{path.name}#{i}", t) for i, t in enumerate(load_suite(path), 1)]
    else:
        sources = []
        for p in task_files(args.tasks, what="--tasks"):
            try:
                sources.append((str(p), _load_task(p, args.csv_header)))
            except (ValueError, OSError) as exc:
                sources.append((str(p), Failed(str(p), _one_line(exc))))
    if args.force:
        out.unlink(missing_ok=True)
    with Engine(args.workers, args.ray_address) as engine:
        run = build_dataset(sources, out, n_max, engine, progress=not args.quiet)
    for failure in run.failed:
        print(f"modquad: error: {failure.error}", file=sys.stderr)
    dropped = ", an unfinished last line dropped" if run.dropped_bytes else ""
    print(
        f"{out}: {run.written} records written, {run.skipped} already there{dropped}"
        + (f", {len(run.failed)} tasks failed" if run.failed else "")
    )
    return _batch_status(run.failed, len(sources))


def cmd_task_generate(args) -> int:
    import numpy as np

    from .outputs import check_output_file
    from .tasks import PaperTasks, PlantedTasks, ScrewdriverTask
    from .validation import check_f_max

    out = check_output_file(args.out, force=args.force, what="--out")
    f_max = 1.0 if args.f_max is None else check_f_max(args.f_max)
    if args.task_kind == "external" and args.f_max is None:
        f_max = EXTERNAL_F_MAX
    options = {"f_max": f_max, "kind": args.task_kind}
    generator = {"paper": PaperTasks, "planted": PlantedTasks, "screwdriver": ScrewdriverTask}[
        args.kind
    ](**options)
    task = generator(np.random.default_rng(args.seed))
    task.save(out)
    print(
        f"wrote {out}: {task.n_wrenches} wrenches ({args.kind}, kind {task.kind}, "
        f"f_max {task.f_max:g}, seed {args.seed})"
    )
    return 0


def cmd_show(args) -> int:
    from .outputs import check_output_file
    from .structure import Structure
    from .viz import save_structure_figure

    out = Path(args.out)
    if out.suffix.lower() != ".png":
        out = out.with_name(out.name + ".png")
    out = check_output_file(out, force=args.force, what="--out")
    modules = _palette(args)

    def from_cells() -> Structure:
        cells = _parse_cells(args.cells)
        if modules is None:
            return Structure(cells)
        if len(modules) == 1:
            return Structure(cells, module=modules[0])
        if len(modules) != len(cells):
            raise ValueError(
                f"--modules: with --cells give one type (all cells) or one per cell; got "
                f"{len(modules)} types for {len(cells)} cells"
            )
        return Structure(cells, modules=modules)

    if args.task:
        task = _load_task(args.task, args.csv_header)
        if args.cells:
            structure = from_cells()
        else:
            from .search import exhaustive_search

            typed = {} if modules is None else {"modules": modules}
            result = exhaustive_search(task, n_max=args.n_max, **typed)
            if result.structure is None:
                print(f"no structure of up to {args.n_max} modules satisfies {args.task}")
                return 0
            structure = result.structure
    else:
        if not args.cells:
            raise ValueError("give --cells (e.g. '[[0,0],[1,0]]') or --task")
        task = None
        structure = from_cells()
    save_structure_figure(structure, out, task=task)
    print(structure)
    print(f"wrote {out}")
    return 0


def cmd_validate(args) -> int:
    from .outputs import check_output_dir
    from .sim.validate import validate
    from .validation import check_int, check_real

    check_real(args.hover_seconds, "--hover-seconds", 0.05, MAX_HOVER_SECONDS)
    check_real(args.load_ramp_seconds, "--load-ramp-seconds", 0.0, args.hover_seconds)
    k = None if args.all_wrenches else check_int(args.max_hover_wrenches, "--max-hover-wrenches", 1)
    names = ("report.md", "validation.json", "hover.png", "bench_wrench.png", "rotor_inputs.png")
    check_output_dir(args.out, names, force=args.force)
    task = _load_task(args.task, args.csv_header)
    n_hover = task.n_wrenches if k is None else min(k, task.n_wrenches)
    flights = 1 if args.known_load_only else 2
    simulated = flights * (n_hover + 1) * args.hover_seconds
    print(
        f"validate: bench on {task.n_wrenches} wrenches, hover under {n_hover}: about "
        f"{simulated:g} simulated s (~{simulated * SECONDS_PER_SIMULATED_SECOND:.0f} s here)",
        file=sys.stderr,
    )
    result = _solver(args)(task)
    if result.structure is None:
        record = {
            "task": args.task,
            "feasible": False,
            "cells": None,
            "bench_max_error": None,
            "hover_max_position_error_m": None,
        }
        print(json.dumps(record) if args.json else f"no structure found for {args.task}")
        return 0
    report = validate(
        result.structure,
        task.wrenches,
        f_max=task.f_max,
        out_dir=args.out,
        include_infeasible_demo=args.infeasible_demo,
        max_hover_wrenches=k,
        hover_seconds=args.hover_seconds,
        unknown_load=not args.known_load_only,
        load_ramp_seconds=args.load_ramp_seconds,
        kind=task.kind,
    ).to_dict()
    if args.json:
        print(json.dumps({"task": args.task, "method": args.method, **report}))
    else:
        for key, value in report.items():
            print(f"{key}: {value}")
    return 0


def cmd_bench(args) -> int:
    module = {
        "oracle": "modquad_gym.bench.oracle",
        "search": "modquad_gym.bench.search",
        "env": "modquad_gym.bench.env",
        "paper": "modquad_gym.bench.paper",
        "scaling": "modquad_gym.bench.scaling",
        "level-bounds": "modquad_gym.bench.level_bounds",
        "distributed": "modquad_gym.bench.distributed",
        "heterogeneous": "modquad_gym.bench.heterogeneous",
        "agents": "modquad_gym.agents.benchmark",
    }[args.what]
    importlib.import_module(module).main(args.rest)
    return 0


def _print_help(parser: argparse.ArgumentParser):
    """A command function that prints ``parser``'s help (for a command given no action)."""

    def show(args) -> int:
        parser.print_help()
        return 0

    return show


def _version() -> str:
    from importlib import metadata

    try:
        return metadata.version("modquad_gym")
    except metadata.PackageNotFoundError:
        from . import __version__

        return __version__


def _add_csv_header(p: argparse.ArgumentParser) -> None:
    p.add_argument(
        "--csv-header",
        choices=("auto", "yes", "no"),
        default="auto",
        help="how a CSV task file's first row is read: auto (a row of names is a header; a "
        "row 0,1,2,3,4,5, as pandas writes column numbers, is refused as ambiguous), yes "
        "(skip the first row), no (every row is a wrench) (default %(default)s)",
    )


def _add_workers(p: argparse.ArgumentParser, default: str) -> None:
    p.add_argument(
        "--workers",
        type=int_option(1, MAX_WORKERS),
        default=None,
        help=f"parallel Ray tasks, 1 to {MAX_WORKERS} (1: everything in this process, no Ray); "
        f"default {default}",
    )
    p.add_argument(
        "--ray-address",
        default=None,
        metavar="ADDRESS",
        help="join this Ray cluster (HOST:PORT of `ray start --head`, or auto) instead of an "
        "embedded Ray on this machine (default: $RAY_ADDRESS)",
    )


MODULES_HELP = (
    "comma-separated module types to mix, one per cell, chosen by the search "
    "(stock names: t45 = the paper's T-module, t45m = its mirrored tilts, t30, t30m = "
    "30-degree tilts, flat = an untilted quadrotor); e.g. t45,t45m,flat. "
    "Default: every module is the paper's T-module"
)


def _add_modules(p: argparse.ArgumentParser, help_text: str = MODULES_HELP) -> None:
    p.add_argument("--modules", default=None, metavar="TYPES", help=help_text)


def _add_force(p: argparse.ArgumentParser) -> None:
    p.add_argument(
        "--force", action="store_true", help="replace existing output files (default: refuse)"
    )


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="modquad",
        description="Find the smallest modular multirotor (H-ModQuad) whose feasible wrenches "
        'contain a task\'s wrenches. Task files: JSON {"wrenches": [[fx,fy,fz,tx,ty,tz], ...], '
        '"f_max": 1.0, "name": "..."}, CSV with 6 columns, or .npy of shape (t, 6).',
    )
    parser.add_argument("--version", action="version", version=f"%(prog)s {_version()}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")

    def add_method(p, default="exhaustive"):
        p.add_argument(
            "--method",
            choices=METHODS,
            default=default,
            help="; ".join(f"{name}: {text}" for name, text in METHOD_HELP.items())
            + " (default %(default)s)",
        )
        p.add_argument(
            "--n-max",
            type=N_MAX_OPTION,
            default=7,
            help="largest module count (default %(default)s; the exhaustive search goes up to "
            "16, centrosymmetric to 21, greedy and random to 64)",
        )
        p.add_argument(
            "--model",
            default=None,
            help="PPO model .zip for --method ppo/ppo-guided (default: the model shipped with "
            "the package, modquad_gym/data/models/ppo_default/model.zip)",
        )
        p.add_argument(
            "--seed",
            type=seed_option,
            default=0,
            help="seed for the random search and PPO sampling, 0 to 2**63-1 (default %(default)s)",
        )
        _add_modules(p)

    p = sub.add_parser(
        "solve",
        help="find a structure for each task file",
        description="Find a structure for each task and print it as a grid "
        "(@ marks the first module), with the module count, configurations "
        "evaluated and seconds. An infeasible task is reported with exit code 0.",
    )
    p.add_argument(
        "--task",
        action="append",
        required=True,
        metavar="FILE",
        help="task file (.json, .csv, .npy), a folder of task files, or a quoted glob such as "
        "'tasks/*.json'; repeat for several",
    )
    add_method(p)
    p.add_argument(
        "--json",
        action="store_true",
        help="print one JSON object per task per line: cells, n_modules, evaluated, "
        "oracle_calls, feasible, certified, seconds (and modules, the type of each cell, "
        "with --modules)",
    )
    p.add_argument(
        "--quiet",
        action="store_true",
        help="no progress bar (the exhaustive search shows one per level on stderr)",
    )
    _add_workers(
        p,
        "1, or every CPU of the cluster given by --ray-address / RAY_ADDRESS. Several tasks are "
        "spread over the workers (each search in one process; a task file that cannot be read "
        "is reported and the others go on, exit code 2 at the end); a single task's exhaustive "
        "search splits its levels of 100,000 structures or more (11 modules and up). The "
        "answers do not depend on the number of workers",
    )
    _add_csv_header(p)
    p.set_defaults(func=cmd_solve)

    p = sub.add_parser(
        "optima",
        help="certified optima of many tasks as a JSON-lines dataset (resumable)",
        description="For each task, the certified minimum module count and every optimal "
        "structure, one JSON object per line appended to --out as tasks finish: task, name, "
        "digest, n_max, optimum, structures (lists of [x, y] cells), count, evaluated, "
        "oracle_calls, seconds. Rerunning into the same file skips the tasks it holds and "
        "recomputes an unfinished last line, so an interrupted run loses nothing it wrote. "
        "Spread over Ray workers (RAY_ADDRESS=HOST:PORT modquad optima ... runs on a cluster).",
    )
    src = p.add_mutually_exclusive_group(required=True)
    src.add_argument(
        "--suite",
        metavar="NAME|FILE",
        help="a shipped suite (heldout_planted, heldout_paper) or a suite JSON file",
    )
    src.add_argument(
        "--tasks",
        action="append",
        metavar="DIR|GLOB|FILE",
        help="a folder of task files, a quoted glob or a file; repeat for several",
    )
    p.add_argument("--out", required=True, metavar="FILE.jsonl", help="the dataset file")
    p.add_argument(
        "--n-max",
        type=N_MAX_OPTION,
        default=7,
        help="largest module count searched (default %(default)s, at most 16)",
    )
    _add_workers(p, "every local core, or every CPU of the cluster")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    _add_csv_header(p)
    p.add_argument("--force", action="store_true", help="discard --out's records and start over")
    p.set_defaults(func=cmd_optima)

    p = sub.add_parser(
        "task",
        help="task files (generate)",
        description="Work with task files. `modquad task generate --help` explains the "
        "options of each action.",
    )
    tsub = p.add_subparsers(dest="task_command", metavar="ACTION")
    p.set_defaults(func=_print_help(p))  # `modquad task` alone: this command's help
    g = tsub.add_parser(
        "generate",
        help="write a generated task file",
        description="Write a seeded task: paper-like random wrenches (Sec. VI, "
        "f_z reading documented in modquad_gym.tasks), a planted task (wrenches "
        "inside a hidden random structure), or the screwdriver of Fig. 1.",
    )
    g.add_argument(
        "--kind",
        choices=("paper", "planted", "screwdriver"),
        required=True,
        help="paper: 80 random wrenches as in Sec. VI; planted: wrenches inside a hidden "
        "random structure (a .json file keeps its cells in meta.planted_cells); "
        "screwdriver: the two wrenches of Fig. 1 (the seed is ignored)",
    )
    g.add_argument(
        "--seed",
        type=seed_option,
        default=0,
        help="seed of the random generator (0 to 2**63-1): the same seed writes the same task "
        "(default %(default)s)",
    )
    g.add_argument(
        "--task-kind",
        choices=("total", "external"),
        default="total",
        help="total: the wrench the rotors produce, gravity folded into f_z (the paper's); "
        "external: the wrench applied to the environment, in SI units; the rotors add the "
        "structure's weight (default %(default)s)",
    )
    g.add_argument(
        "--f-max",
        type=real_option,
        default=None,
        help=f"rotor thrust limit written to the task (default 1, or {EXTERNAL_F_MAX:g} N for "
        "--task-kind external)",
    )
    g.add_argument("--out", required=True, help="output file; format from suffix .json/.csv/.npy")
    _add_force(g)
    g.set_defaults(func=cmd_task_generate)

    p = sub.add_parser(
        "show",
        help="draw a structure (top view + torque-space projection)",
        description="Draw a structure given by --cells, or the exhaustive "
        "search's answer for --task, as a PNG.",
    )
    p.add_argument("--cells", help="JSON list of [x, y] cells, e.g. '[[0,0],[1,0],[0,1]]'")
    p.add_argument("--task", help="task file: solve it (exhaustive) unless --cells is given")
    p.add_argument(
        "--n-max",
        type=N_MAX_OPTION,
        default=7,
        help="largest module count the exhaustive search tries for --task (default %(default)s)",
    )
    p.add_argument(
        "--out",
        default="structure.png",
        help="PNG path; '.png' is added when missing (default %(default)s)",
    )
    _add_modules(
        p,
        "comma-separated module types: with --task the palette the search mixes; with "
        "--cells one type for every cell or one per cell, in order (e.g. t45,flat,t45m)",
    )
    _add_csv_header(p)
    _add_force(p)
    p.set_defaults(func=cmd_show)

    p = sub.add_parser(
        "validate",
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
        default=1.0,
        help="unknown-load hover: seconds over which the load moves from one task wrench to the "
        "next (0: a step; default %(default)s)",
    )
    p.add_argument(
        "--known-load-only",
        action="store_true",
        help="fly only the hover whose controller knows the applied load (feed-forward); by "
        "default a second hover estimates the load by integral action",
    )
    _add_csv_header(p)
    _add_force(p)
    p.set_defaults(func=cmd_validate)

    p = sub.add_parser(
        "bench",
        help="run a benchmark (writes results/)",
        description="Run a benchmark; options after the name go to it "
        "(e.g. `modquad bench oracle --help`).",
    )
    p.add_argument(
        "what",
        choices=(
            "oracle",
            "search",
            "scaling",
            "level-bounds",
            "distributed",
            "heterogeneous",
            "env",
            "paper",
            "agents",
        ),
        help="oracle: feasibility methods compared; search: exhaustive search vs an LP "
        "reference; scaling: the exhaustive search level by level up to 14 modules; "
        "level-bounds: regenerate the shipped level bounds; heterogeneous: mixing module "
        "types and self-weight against one type; distributed: a batch and a large search "
        "serially and on Ray with 1 and 2 CPUs; "
        "env: environment steps/s; paper: the paper's Sec. VI experiment; "
        "agents: PPO vs the searches on held-out tasks",
    )
    p.add_argument(
        "rest",
        nargs=argparse.REMAINDER,
        metavar="OPTIONS",
        help="options passed on to the benchmark (see `modquad bench WHAT --help`)",
    )
    p.set_defaults(func=cmd_bench)
    return parser


def _one_line(exc: BaseException) -> str:
    """An expected failure as one line naming the file or option."""
    if isinstance(exc, OSError) and exc.filename and exc.strerror:
        return f"{exc.filename}: {exc.strerror}"
    if isinstance(exc, ModuleNotFoundError) and (exc.name or "").split(".")[0] in EXTRA_OF:
        return missing_extra_message(exc.name)
    return " ".join(str(exc).split()) or type(exc).__name__


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    if not getattr(args, "func", None):
        parser.print_help()
        return 0
    try:
        return args.func(args)
    except KeyboardInterrupt:
        print("modquad: interrupted", file=sys.stderr)
        return 130
    except BrokenPipeError:
        # the reader closed our output (e.g. `| head -1`): stop writing, say so once
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        print("modquad: error: output closed before the end (broken pipe)", file=sys.stderr)
        return 2
    except (ValueError, OSError, ImportError, MemoryError, OverflowError) as exc:
        print(f"modquad: error: {_one_line(exc)}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
