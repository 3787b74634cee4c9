"""The ``modquad`` command line: solve tasks, generate task files, draw structures, validate in
MuJoCo, and run the benchmarks. ``modquad COMMAND --help`` explains each command.

Exit codes: 0 on success (an infeasible task is a result, not an error), 2 for bad input (a
task file that cannot be read, an unknown option).
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

METHODS = ("exhaustive", "centrosymmetric", "greedy", "random", "ppo")


def _load_task(path: str):
    from .tasks import TaskRequirement

    return TaskRequirement.load(path)


def _solver(args):
    """The solver for ``--method`` (PPO lives in the agents package, searches here)."""
    if args.method == "ppo":
        from agents.solvers import make_solver

        return make_solver("ppo", n_max=args.n_max, model=args.model, seed=args.seed).solve
    from .search import SEARCHES

    fn = SEARCHES[args.method]
    if args.method == "random":
        return lambda task: fn(task, n_max=args.n_max, seed=args.seed)
    if args.method == "exhaustive":
        progress = not (getattr(args, "json", False) or getattr(args, "quiet", False))
        workers = getattr(args, "workers", 1)
        return lambda task: fn(task, n_max=args.n_max, workers=workers, progress=progress)
    return lambda task: fn(task, n_max=args.n_max)


def cmd_solve(args) -> int:
    tasks = [(path, _load_task(path)) for path in args.task]
    solve = _solver(args)
    for path, task in tasks:
        result = solve(task)
        if args.json:
            record = {"task": str(path), "name": task.name, **result.to_dict()}
            print(json.dumps(record), flush=True)
            continue
        print(f"task {task.name!r} ({path}): {task.n_wrenches} wrenches, method {args.method}")
        if result.structure is None:
            print(f"  no structure of up to {args.n_max} modules satisfies the task")
        else:
            cert = " (certified minimum)" if result.certified else ""
            print(f"  {result.n_modules} modules{cert}: cells {list(result.structure.cells)}")
            print("  " + result.structure.to_text().replace("\n", "\n  "))
        print(
            f"  configurations evaluated: {result.evaluated}, oracle calls: "
            f"{result.oracle_calls}, seconds: {result.seconds:.3f}"
        )
    return 0


def cmd_task_generate(args) -> int:
    import numpy as np

    from .tasks import make_generator

    generator = make_generator(args.kind)
    task = generator(np.random.default_rng(args.seed))
    out = Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    task.save(out)
    print(f"wrote {out}: {task.n_wrenches} wrenches ({args.kind}, seed {args.seed})")
    return 0


def cmd_show(args) -> int:
    from .structure import Structure
    from .viz import save_structure_figure

    if args.task:
        task = _load_task(args.task)
        if args.cells:
            structure = Structure(json.loads(args.cells))
        else:
            from .search import exhaustive_search

            result = exhaustive_search(task, n_max=args.n_max)
            if result.structure is None:
                print(f"no structure of up to {args.n_max} modules satisfies {args.task}")
                return 0
            structure = result.structure
    else:
        if not args.cells:
            raise ValueError("give --cells (e.g. '[[0,0],[1,0]]') or --task")
        task = None
        structure = Structure(json.loads(args.cells))
    out = Path(args.out)
    save_structure_figure(structure, out, task=task)
    print(structure)
    print(f"wrote {out}")
    return 0


def cmd_validate(args) -> int:
    from .sim.validate import validate

    if not args.hover_seconds > 0:
        raise ValueError(f"--hover-seconds must be > 0, got {args.hover_seconds}")
    if not args.load_ramp_seconds >= 0:
        raise ValueError(f"--load-ramp-seconds must be >= 0, got {args.load_ramp_seconds}")
    task = _load_task(args.task)
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
        max_hover_wrenches=args.max_hover_wrenches,
        hover_seconds=args.hover_seconds,
        unknown_load=not args.known_load_only,
        load_ramp_seconds=args.load_ramp_seconds,
    )
    if args.json:
        print(json.dumps({"task": args.task, "method": args.method, **report}))
    else:
        for key, value in report.items():
            print(f"{key}: {value}")
    return 0


def cmd_bench(args) -> int:
    import importlib

    module = {
        "oracle": "modquad_gym.bench.oracle",
        "search": "modquad_gym.bench.search",
        "env": "modquad_gym.bench.env",
        "paper": "modquad_gym.bench.paper",
        "scaling": "modquad_gym.bench.scaling",
        "agents": "agents.benchmark",
    }[args.what]
    importlib.import_module(module).main(args.rest)
    return 0


def _print_help(parser: argparse.ArgumentParser):
    """A command function that prints ``parser``'s help (for a command given no action)."""

    def show(args) -> int:
        parser.print_help()
        return 0

    return show


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="modquad",
        description="Find the smallest modular multirotor (H-ModQuad) whose feasible wrenches "
        'contain a task\'s wrenches. Task files: JSON {"wrenches": [[fx,fy,fz,tx,ty,tz], ...], '
        '"f_max": 1.0, "name": "..."}, CSV with 6 columns, or .npy of shape (t, 6).',
    )
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")

    def add_method(p, default="exhaustive"):
        p.add_argument(
            "--method",
            choices=METHODS,
            default=default,
            help="exhaustive: certified minimum; centrosymmetric: paper Algorithm 2; "
            "greedy/random: baselines; ppo: the learned agent (default %(default)s)",
        )
        p.add_argument(
            "--n-max",
            type=int,
            default=7,
            help="largest module count (default %(default)s; the exhaustive search goes up to "
            "16, the constructive baselines to 64)",
        )
        p.add_argument(
            "--model",
            default=None,
            help="PPO model .zip for --method ppo (default: the model shipped in "
            "results/ppo_default/model.zip)",
        )
        p.add_argument(
            "--seed",
            type=int,
            default=0,
            help="seed for the random search and PPO sampling (default %(default)s)",
        )

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
        help="task file (.json, .csv, .npy); repeat for several tasks",
    )
    add_method(p)
    p.add_argument(
        "--json",
        action="store_true",
        help="print one JSON object per task per line: cells, n_modules, evaluated, "
        "oracle_calls, feasible, certified, seconds",
    )
    p.add_argument(
        "--quiet",
        action="store_true",
        help="no progress bar (the exhaustive search shows one per level on stderr)",
    )
    p.add_argument(
        "--workers",
        type=int,
        default=1,
        help="processes sharing each large level of the exhaustive search (levels of 100,000 "
        "structures or more, i.e. 11 modules and up); the answer is the same for any number "
        "(default %(default)s)",
    )
    p.set_defaults(func=cmd_solve)

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
        type=int,
        default=0,
        help="seed of the random generator: the same seed writes the same task "
        "(default %(default)s)",
    )
    g.add_argument("--out", required=True, help="output file; format from suffix .json/.csv/.npy")
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
        type=int,
        default=7,
        help="largest module count the exhaustive search tries for --task (default %(default)s)",
    )
    p.add_argument("--out", default="structure.png", help="PNG path (default %(default)s)")
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
        type=int,
        default=None,
        help="hover under at most this many task wrenches, the first ones in the file "
        "(default: all); each is held for --hover-seconds simulated seconds, after a take-off "
        "of the same length",
    )
    p.add_argument(
        "--hover-seconds",
        type=float,
        default=2.0,
        help="simulated seconds per hover segment (default %(default)s)",
    )
    p.add_argument(
        "--load-ramp-seconds",
        type=float,
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
    p.set_defaults(func=cmd_validate)

    p = sub.add_parser(
        "bench",
        help="run a benchmark (writes results/)",
        description="Run a benchmark; options after the name go to it "
        "(e.g. `modquad bench oracle --help`).",
    )
    p.add_argument(
        "what",
        choices=("oracle", "search", "scaling", "env", "paper", "agents"),
        help="oracle: feasibility methods compared; search: exhaustive search vs an LP "
        "reference; scaling: the exhaustive search level by level up to 14 modules; "
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


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    if not getattr(args, "func", None):
        parser.print_help()
        return 0
    try:
        return args.func(args)
    except (ValueError, FileNotFoundError) as exc:
        print(f"modquad: error: {exc}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
