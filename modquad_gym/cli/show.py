"""``modquad show``: draw a structure (given, or a search's answer: ``--method``, ``--n-max`` and
``--time-limit`` as in ``modquad solve``, with its solver) as a PNG and/or an interactive,
self-contained HTML page."""

from __future__ import annotations

import argparse
import json
from pathlib import Path

from modquad_gym.cli import common, solve  # common.load_task, solve.solver (tests replace them)
from modquad_gym.cli.common import (
    FAULT_HELP,
    add_command,
    add_csv_header,
    add_fault,
    add_force,
    add_method,
    check_fault_method,
    fault_margin_of,
    no_structure,
    palette,
)
from modquad_gym.cli.given import SEARCH_OPTIONS, refuse_ignored
from modquad_gym.cli.quiet import add_quiet
from modquad_gym.core.options import nonempty_option


def add_show(sub) -> None:
    p = add_command(
        sub,
        "show",
        cmd_show,
        help="draw a structure (top view, feasible forces and torques; PNG or HTML)",
        description="Draw a structure given by --cells, or the answer of a search for --task "
        "(--method, --n-max up to 128, --time-limit, --modules, --fault as in `modquad solve`): "
        "a PNG (top view; "
        "with --task also the feasible forces and torques, projections of the 6-D feasible "
        "set, with the task's wrenches coloured by 6-D feasibility) and/or, "
        "with --html, one self-contained interactive page (3-D structure with thrust "
        "directions, the same projections to turn and zoom; no network needed).",
    )
    p.add_argument(
        "--cells",
        type=nonempty_option,
        help="JSON list of [x, y] cells, e.g. '[[0,0],[1,0],[0,1]]'",
    )
    p.add_argument(
        "--task",
        help="task file: solve it with --method (as `modquad solve`) unless --cells is given",
    )
    add_method(
        p,
        modules_help="comma-separated module types: with --task the palette the search mixes; "
        "with --cells one type for every cell or one per cell, in order (e.g. t45,flat,t45m)",
    )
    add_fault(p, FAULT_HELP.partition("; --json")[0])  # solve's: the search designs for it
    p.add_argument(
        "--out",
        default=None,
        help="PNG path; '.png' is added when missing (default structure.png, none with --html)",
    )
    p.add_argument(
        "--html",
        default=None,
        metavar="OUT.html",
        help="also (or, without --out, only) write the interactive page here (needs plotly: "
        "pip install 'modquad_gym[viz]')",
    )
    p.add_argument(
        "--layout",
        choices=("row", "grid"),
        default="row",
        help="with --task, how the PNG arranges its three views: row (side by side, for a "
        "screen) or grid (the top view above the two projections, about 8 inches wide: "
        "readable on a narrow page such as the documentation); refused where there is no such "
        "PNG (no --task, or --html without --out)",
    )
    add_quiet(p)
    add_csv_header(p)
    add_force(p)


def parse_cells(text: str) -> list:
    """``--cells`` as a list of [x, y] pairs, or a ValueError naming the option."""
    try:
        cells = json.loads(text)
    except (json.JSONDecodeError, RecursionError):
        raise ValueError(f"--cells: not JSON: {text!r} (e.g. '[[0,0],[1,0]]')") from None
    if not isinstance(cells, list):
        raise ValueError(f"--cells: expected a JSON list of [x, y] pairs, got {text!r}")
    return cells


def structure_from_cells(text: str, modules, check=None):
    """The structure of ``--cells`` with ``--modules``: one type for all cells or one per cell,
    refused by ``check(structure)`` (a ValueError; default: too large to draw)."""
    from modquad_gym.geometry.structure import Structure

    cells = parse_cells(text)
    if modules is not None and len(modules) not in (1, len(cells)):
        raise ValueError(
            f"--modules: with --cells give one type (all cells) or one per cell; got "
            f"{len(modules)} types for {len(cells)} cells"
        )
    typed = {} if modules is None else {"modules": modules}
    if modules is not None and len(modules) == 1:
        typed = {"module": modules[0]}
    if check is None:
        from modquad_gym.viz.drawing import check_drawable as check
    try:
        structure = Structure(cells, **typed)
        check(structure)
    except ValueError as exc:  # not connected, overlapping, too large to draw ...
        raise ValueError(f"--cells: {exc}") from None
    return structure


def cmd_show(args: argparse.Namespace) -> int:
    from modquad_gym.core.extras import require
    from modquad_gym.core.outputs import check_outputs

    if args.cells:  # --cells gives the structure: nothing is searched for
        refuse_ignored(args, SEARCH_OPTIONS, "applies to a search for --task, not with --cells "
                       "(which gives the structure)")  # fmt: skip
    if not args.task:
        refuse_ignored(args, ["csv_header"], "applies to a --task file")
    check_fault_method(args)  # --fault that the method cannot honour, a bad --fault-margin:
    fault_margin_of(args)  # refused before any work, as by solve
    out = args.out if args.out is not None or args.html is not None else "structure.png"
    if not args.task or out is None:  # the picture of --layout's three views is not drawn
        why = (
            "--html alone writes no PNG" if args.task else "without --task it is the top view only"
        )
        refuse_ignored(args, ["layout"], f"applies with --task to the PNG ({why})")
    if out is not None:
        out = Path(out)
        if out.name in ("", ".", ".."):  # Path("") is Path("."): no name to add ".png" to
            raise ValueError(f"--out: {args.out!r} is not a file name (e.g. structure.png)")
        if out.exists() and not out.is_file():  # /dev/null, a folder: no picture beside it
            raise ValueError(f"--out: {out} exists and is not a regular file (a folder, device, "
                             "pipe or socket); give the picture's file name")  # fmt: skip
        if out.suffix.lower() != ".png":
            out = out.with_name(out.name + ".png")
    # both checked before any work or write (--out X --html X would write X, then refuse)
    out = check_outputs({"--out": out, "--html": args.html}, force=args.force).get("--out")
    require(*(["matplotlib"] if out is not None else []), *(["plotly"] if args.html else []))
    task, structure, result = shown(args)  # the search runs only when pictures can be drawn
    if structure is None:  # as export: the file asked for is not written, so not a success
        raise no_structure(args, "nothing to draw, no file written", result)
    if out is not None:
        from modquad_gym.viz.drawing import save_structure_figure

        save_structure_figure(structure, out, task=task, layout=args.layout, force=args.force,
                              what="--out")  # fmt: skip
        print(f"wrote {out}")
        if task is not None and args.fault:  # the sets drawn are the intact structure's
            print(f"{out}: green where the intact structure exerts a wrench; it was designed to "
                  f"exert each after any {args.fault} failure (modquad validate --fault flies "
                  "one)")  # fmt: skip
    if args.html is not None:
        from modquad_gym.viz.interactive import save_structure_page

        page = save_structure_page(structure, args.html, task, args.force, what="--html")
        print(f"wrote {page}")
    return 0


def shown(args: argparse.Namespace):
    """(task or None, structure to draw or None when the search finds none, the search's
    result or None when none ran)."""
    modules = palette(args)
    if not args.task:
        if not args.cells:
            raise ValueError("give --cells (e.g. '[[0,0],[1,0]]') or --task")
        structure = structure_from_cells(args.cells, modules)
        print(structure)
        return None, structure, None
    task = common.load_task(args.task, args.csv_header)
    if args.cells:
        structure = structure_from_cells(args.cells, modules)
        print(structure)
        return task, structure, None
    common.check_task(task, args.task, modules)
    result = solve.solver(args, task)(task)
    solve.print_result(args, args.task, task, result)  # as `modquad solve` prints it
    return task, result.structure, result
