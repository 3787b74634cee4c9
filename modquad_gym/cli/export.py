"""``modquad export``: write a structure (given, or found for a task) as MJCF, URDF or JSON."""

from __future__ import annotations

import argparse
from pathlib import Path

from modquad_gym.cli import common  # commands call common.load_task (tests replace it)
from modquad_gym.cli.common import (
    FAULT_HELP,
    add_command,
    add_csv_header,
    add_fault,
    add_force,
    add_method,
    check_fault_method,
    f_max_option,
    fault_margin_of,
    no_structure,
    palette,
)
from modquad_gym.cli.given import SEARCH_OPTIONS, refuse_ignored
from modquad_gym.cli.quiet import add_quiet
from modquad_gym.core.options import nonempty_option


def add_export(sub) -> None:
    from modquad_gym.sim.export_formats import FORMATS, SUFFIXES

    p = add_command(
        sub,
        "export",
        cmd_export,
        help="write a structure as MJCF, URDF or JSON",
        description="Write a structure for other tools: the one given by --cells, or the one "
        "--method finds for --task (as `modquad solve` finds it, with --modules and --fault). "
        "mjcf: MuJoCo model (one free body, one actuator per rotor, "
        "ctrl = thrust in [0, f_max]); urdf: base_link with mass and inertia, one link and "
        "continuous joint per rotor (its frame's z-axis is the thrust direction), collision "
        "boxes and discs; json: rotor poses, directions, spins, c_tau, masses, inertia and the "
        "configuration matrix. Frame {S}: origin at the COM, z up, SI units, thrust in N. The "
        "file and this command state the thrust-to-weight ratio at --f-max and warn when the "
        "robot cannot lift itself: a default T-module (0.3 kg) needs --f-max 1.04 N to hover, "
        "about 2.1 N for a thrust-to-weight ratio of 2 (room to steer).",
    )
    p.add_argument(
        "--cells",
        type=nonempty_option,
        help="JSON list of [x, y] cells, e.g. '[[0,0],[1,0],[0,1]]'",
    )
    p.add_argument("--task", help="task file: export the structure --method finds for it")
    add_method(p)
    add_fault(p, FAULT_HELP.partition("; --json")[0])  # solve's: the search designs for it
    p.add_argument(
        "--format",
        choices=FORMATS,
        default=None,
        help="output format (default: from --out's suffix: "
        + ", ".join(f"{s} = {f}" for f, s in SUFFIXES.items())
        + "); a suffix of another format is refused (.xml also takes urdf)",
    )
    p.add_argument("--out", required=True, help="output file")
    p.add_argument(
        "--f-max",
        type=f_max_option,
        default=None,
        help="each rotor's largest thrust in N, up to 1e12, written to the model (default: the "
        "task's f_max, else 1, the searches' normalised unit, which leaves T-modules of 0.3 kg "
        "short of their weight)",
    )
    add_quiet(p)
    add_csv_header(p)
    add_force(p)


def found_structure(args: argparse.Namespace, task):
    """The structure ``--method`` finds for ``task``; a ValueError when it finds none."""
    from modquad_gym.cli.solve import solver

    result = solver(args, task)(task)
    if result.structure is None:
        raise no_structure(args, "nothing to export", result)
    return result.structure


def check_exportable(structure) -> None:
    """A ValueError when ``structure`` has more modules than the searches design
    (:data:`~modquad_gym.search.problem.MAX_MODULES`, the package's structure-size limit)."""
    from modquad_gym.search.problem import MAX_MODULES

    if structure.n_modules > MAX_MODULES:
        raise ValueError(
            f"a structure of {structure.n_modules:,} modules is larger than export takes: at "
            f"most {MAX_MODULES} modules, the searches' limit"
        )


def cmd_export(args: argparse.Namespace) -> int:
    from modquad_gym.cli.show import structure_from_cells
    from modquad_gym.core.extras import require
    from modquad_gym.core.outputs import check_output_file
    from modquad_gym.sim.export import lift_statement, save_structure
    from modquad_gym.sim.export_formats import export_format

    if bool(args.cells) == bool(args.task):
        raise ValueError("give either --cells (e.g. '[[0,0],[1,0]]') or --task")
    if args.cells:  # what finds a structure for --task means nothing beside --cells
        how = [*SEARCH_OPTIONS, "csv_header"]
        refuse_ignored(args, how, "applies with --task (a search finds the structure), not "
                       "with --cells (which gives it)")  # fmt: skip
    check_fault_method(args)  # --fault that the method cannot honour, a bad --fault-margin:
    fault_margin_of(args)  # refused before any work, as by solve
    check_output_file(args.out, force=args.force, what="--out")  # before any search
    fmt = export_format(args.out, args.format, names=("--out", "--format"))  # save_structure's rule
    if fmt == "mjcf":
        require("mujoco")  # the [sim] extra writes MJCF: said before any search, not after
    if fmt != "json":
        common.check_simulable_types(args)  # before any search
    f_max = args.f_max
    if args.cells:
        structure = structure_from_cells(args.cells, palette(args), check_exportable)
    else:
        if Path(args.task).is_dir():  # solve --task reads a folder; export writes one structure
            raise ValueError(
                f"--task {args.task} is a folder; export takes one task file (it writes one "
                "structure): name a file in it"
            )
        task = common.load_task(args.task, args.csv_header)
        common.check_task(task, args.task, palette(args))  # errors name the file
        structure = found_structure(args, task)
        f_max = task.f_max if f_max is None else f_max
    f_max = 1.0 if f_max is None else f_max
    out = save_structure(structure, Path(args.out), fmt, f_max, force=args.force, what="--out")
    print(f"wrote {out}: {structure.n_modules} modules, cells {list(structure.cells)}")
    print(lift_statement(structure, f_max))  # save_structure warned if it cannot lift itself
    return 0
