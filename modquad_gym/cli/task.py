"""``modquad task generate``: write a seeded task file (``task motion``, a dynamic one:
:mod:`.task_motion`)."""

from __future__ import annotations

import argparse

from modquad_gym.cli.common import add_command, add_force, f_max_option, print_help
from modquad_gym.cli.given import refuse_ignored
from modquad_gym.cli.task_motion import add_motion
from modquad_gym.core.options import int_option, seed_option
from modquad_gym.geometry.cells import MAX_MODULES
from modquad_gym.tasks import GENERATE_KINDS, TASK_KINDS
from modquad_gym.tasks.generators import EXTERNAL_F_MAX

UNSEEDED = ("screwdriver",)
"""The kinds that draw nothing at random: ``--seed`` typed with them is refused."""


def add_task(sub) -> None:
    """``task`` and its actions (``task`` alone prints its help)."""
    p = sub.add_parser(
        "task",
        help="task files (generate, motion, example)",
        description="Work with task files. `modquad task ACTION --help` explains the "
        "options of an action (e.g. `modquad task generate --help`).",
    )
    p.set_defaults(func=print_help(p))
    actions = p.add_subparsers(dest="task_command", metavar="ACTION")
    add_generate(actions)
    add_motion(actions)
    add_example(actions)


def add_generate(tsub) -> None:
    g = add_command(
        tsub,
        "generate",
        cmd_task_generate,
        help="write a generated task file",
        description="Write a seeded task: paper-like random wrenches (Sec. VI, "
        "f_z reading documented in modquad_gym.tasks), a planted task (wrenches "
        "inside a hidden random structure), or the screwdriver of Fig. 1.",
    )
    g.add_argument(
        "--kind",
        choices=GENERATE_KINDS,
        required=True,
        help="the named task generator drawn from, as in Python (make_generator(KIND), or "
        "KIND-external with --task-kind external; the file is "
        "modquad_gym.tasks.generated_task(KIND, SEED, ...) saved): "
        "paper: 80 random wrenches as in Sec. VI (paper-external: 40, f_z in [1, 5]); planted: "
        "wrenches inside a hidden "
        "random structure (a .json file keeps its cells in meta.planted_cells, hidden, for "
        "benchmarks; the task's name is neutral: planted-seedS); "
        "screwdriver: the two wrenches of Fig. 1 (fixed: it takes no --seed)",
    )
    g.add_argument(
        "--seed",
        type=seed_option,
        default=0,
        help="seed of the random generator (0 to 2**63-1): the same seed writes the same task "
        "(default %(default)s); paper and planted only (screwdriver draws nothing at random)",
    )
    g.add_argument(
        "--task-kind",
        choices=TASK_KINDS,
        default="total",
        help="total: the wrench the rotors produce, gravity folded into f_z (the paper's); "
        "external: the wrench applied to the environment, in SI units; the rotors add the "
        "structure's weight (default %(default)s)",
    )
    g.add_argument(
        "--f-max",
        type=f_max_option,
        default=None,
        help=f"rotor thrust limit written to the task (default 1, or {EXTERNAL_F_MAX:g} N for "
        "--task-kind external, the named external generators' f_max: a 0.3 kg T-module lifts "
        "at most 2.83 N at 1 N per rotor, less than its weight)",
    )
    g.add_argument(
        "--n-modules",
        type=int_option(1, MAX_MODULES),
        default=None,
        metavar="N",
        help=f"planted: the hidden structure's module count, 1 to {MAX_MODULES} (the searches' "
        "limit; default: 2 to 6 at random)",
    )
    g.add_argument("--out", required=True, help="output file; format from suffix .json/.csv/.npy")
    add_force(g)


def cmd_task_generate(args: argparse.Namespace) -> int:
    from modquad_gym.core.outputs import check_output_file
    from modquad_gym.core.validation import check_f_max
    from modquad_gym.oracle import check_task_scale
    from modquad_gym.tasks import generated_task

    if args.kind in UNSEEDED:
        refuse_ignored(args, ["seed"], f"--kind {args.kind} draws nothing at random")
    out = check_output_file(args.out, force=args.force, what="--out")
    f_max = None if args.f_max is None else check_f_max(args.f_max)
    if args.n_modules is not None and args.kind != "planted":
        raise ValueError("--n-modules applies to --kind planted only")
    try:  # a file `solve` would refuse is not written (the generators check their scale)
        task = generated_task(args.kind, args.seed, args.task_kind, f_max, args.n_modules)
        check_task_scale(task.wrenches, task.f_max)
    except ValueError as exc:  # the other options are checked by argparse
        if f_max is None:  # the named generator's own f_max: no option to blame
            raise
        text = str(exc).removeprefix(f"f_max = {f_max:g}")  # "f_max = 1e-300 is too small..."
        raise ValueError(f"--f-max {f_max:g}{'' if text != str(exc) else ': '}{text}") from None
    task.save(out, force=args.force, what="--out")  # checked before the work, and now again
    seed = "" if args.kind in UNSEEDED else f", seed {args.seed}"
    print(
        f"wrote {out}: {task.n_wrenches} wrenches ({args.kind}, kind {task.kind}, "
        f"f_max {task.f_max:g}{seed})"
    )
    return 0


def add_example(tsub) -> None:
    from modquad_gym.tasks import example_names

    e = add_command(
        tsub,
        "example",
        cmd_task_example,
        help="copy a task file shipped with the package",
        description="Copy one of the example task files shipped with the package (they travel "
        "with the wheel); without NAME, list them. Any --task also reads them directly as "
        "example:NAME, e.g. `modquad solve --task example:screwdriver`.",
    )
    e.add_argument(
        "name",
        nargs="?",
        metavar="NAME",
        help=f"the example: {', '.join(example_names())} (default: list them)",
    )
    e.add_argument("--out", help="output file (default: print the file's path)")
    add_force(e)


def same_as(name: str, task) -> str:
    """`` (the same task as STEM, in another format)`` when the example ``name`` (``STEM.csv``)
    holds the wrenches of the example STEM; else ""."""
    import numpy as np

    from modquad_gym.tasks import TaskRequirement, example_names, example_path

    stem, dot, suffix = name.rpartition(".")
    if not dot or stem not in example_names():
        return ""
    other = TaskRequirement.load(example_path(stem))
    if not np.array_equal(other.wrenches, task.wrenches) or other.f_max != task.f_max:
        return ""
    return f" (the task {stem} as {suffix.upper()})"


def cmd_task_example(args: argparse.Namespace) -> int:
    import shutil

    from modquad_gym.core.outputs import atomic_write, check_output_file
    from modquad_gym.tasks import TaskRequirement, example_names, example_path, load_suite

    if args.force and args.out is None:  # nothing is written: it would be ignored
        copy = f"to copy {args.name}" if args.name is not None else "and NAME to copy an example"
        raise ValueError(f"--force replaces an existing --out; give --out {copy}")
    if args.name is None:
        if args.out is not None:  # it would be ignored: the list is printed, nothing written
            raise ValueError(f"--out {args.out}: name the example to copy (NAME), e.g. screwdriver")
        for name in example_names():
            try:
                task = TaskRequirement.load(example_path(name))
                what = f"{task.n_wrenches} wrenches{same_as(name, task)}"
            except ValueError:  # a suite file (load_suite reads it)
                what = f"a suite of {len(load_suite(example_path(name)))} tasks"
            print(f"{name:18s} {what}")
        return 0
    source = example_path(args.name)
    if args.out is None:
        print(source)
        return 0
    out = check_output_file(args.out, force=args.force, what="--out")
    if out.suffix.lower() != source.suffix.lower():
        raise ValueError(f"--out: {out} must end in {source.suffix} like the example {source.name}")
    atomic_write(out, lambda tmp: shutil.copyfile(source, tmp))  # a link at --out is replaced
    print(f"wrote {out} (example {args.name})")
    return 0
