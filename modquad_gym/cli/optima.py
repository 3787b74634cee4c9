"""``modquad optima``: certified optima of many tasks as a resumable JSON-lines dataset."""

from __future__ import annotations

import argparse
from pathlib import Path

from modquad_gym.cli import common  # commands call common.load_task (tests replace it)
from modquad_gym.cli.common import (
    add_command,
    add_csv_header,
    add_modules,
    add_n_max,
    add_workers,
    batch_status,
    palette_of,
    report_error,
)
from modquad_gym.cli.given import refuse_ignored
from modquad_gym.core.interrupts import one_line

SUITES_DIR = Path(__file__).resolve().parents[1] / "data" / "suites"
"""The suites shipped with the package (``--suite NAME``)."""


def add_optima(sub) -> None:
    p = add_command(
        sub,
        "optima",
        cmd_optima,
        help="certified optima of many tasks as a JSON-lines dataset (resumable)",
        description="For each task (static ones: a dynamic task is refused), the certified "
        "minimum module count and every optimal structure, one JSON object per line appended to "
        "--out as tasks finish: task, path (a task file's, relative to the dataset's folder), "
        "name, digest, n_max, optimum, structures (lists of [x, y] cells), count, evaluated, "
        "oracle_calls, seconds. Rerunning into the same file, from any folder, skips the tasks "
        "it holds (a task file matched by its resolved path) and recomputes an unfinished last "
        "line, so an interrupted run loses nothing it wrote; a line that is not such a record, "
        "or a second record of one task, is refused with its line number, and so is another "
        "--n-max than the file's (one dataset, one n_max). One run writes a file at a time, "
        "whatever path or link names it. "
        "Spread over Ray workers (RAY_ADDRESS=HOST:PORT modquad optima ... runs on a cluster).",
    )
    src = p.add_mutually_exclusive_group(required=True)
    src.add_argument(
        "--suite",
        metavar="NAME|FILE",
        help="a shipped suite (heldout_planted, heldout_paper), a suite JSON file, or "
        "example:NAME, a suite shipped as an example (e.g. example:suite_small), as for "
        "`modquad score --suite`",
    )
    src.add_argument(
        "--task",
        "--tasks",  # its former name, as no other command spells it: still accepted
        dest="task",
        action="append",
        metavar="DIR|GLOB|FILE",
        help="a folder of task files, a quoted glob or a file, as for `modquad solve`; repeat "
        "for several (--tasks, its former name, deprecated, still works)",
    )
    p.add_argument("--out", required=True, metavar="FILE.jsonl", help="the dataset file")
    add_n_max(p, "largest module count searched (default %(default)s, at most 16)")
    add_modules(
        p,
        "comma-separated module types every structure mixes, one per cell, as for `modquad "
        "solve` (e.g. t45,t45m,flat): each record adds palette and modules (each structure's "
        "type names, in its cells' order), and a dataset holds one palette (default: the "
        "paper's T-module alone, no such keys)",
    )
    add_workers(p, "every local core, or every CPU of the cluster")
    p.add_argument(
        "--quiet",
        action="store_true",
        help="no progress on stderr (a bar over the tasks; with --workers 1, or a single task, "
        "also the exhaustive search's bar per level, as `modquad solve --method exhaustive` "
        "shows it, for the task being searched)",
    )
    add_csv_header(p)
    p.add_argument(
        "--force",
        action="store_true",
        help="empty --out and start over (a file that is not an optima dataset, or holds "
        "another n_max, is otherwise refused; a file that another run is writing, by any path "
        "or link, is refused even so)",
    )


def suite_path(name: str) -> Path:
    """``--suite``: a suite file, ``example:NAME`` (a shipped example, as
    :func:`~modquad_gym.tasks.load_suite` reads it), or the name of a shipped suite."""
    from modquad_gym.tasks.examples import PREFIX, example_path

    if name.startswith(PREFIX):
        try:
            return example_path(name)
        except ValueError as exc:
            raise ValueError(f"--suite {name}: {exc}") from None
    path = Path(name)
    if not path.suffix and not path.exists():
        path = SUITES_DIR / f"{name}.json"
        if not path.exists():
            names = ", ".join(sorted(p.stem for p in SUITES_DIR.glob("*.json")))
            raise ValueError(f"--suite: no suite {name!r} (shipped: {names})")
    return path


def sources(args: argparse.Namespace) -> list:
    """(label, task) for each task of ``--suite`` or ``--task``; a task file that cannot be
    read is a (label, Failed) entry, reported with the others' results. A dynamic task is
    refused at once (optima takes static tasks), naming its file or suite."""
    from modquad_gym.core.distributed import Failed
    from modquad_gym.scoring.optima import static_sources
    from modquad_gym.tasks import TaskRequirement, load_suite, task_files

    if args.suite:
        path = suite_path(args.suite)
        tasks = load_suite(path)
        for i, task in enumerate(tasks, 1):
            if not isinstance(task, TaskRequirement):
                raise ValueError(
                    f"optima takes static tasks: {path} task {i} ({task.name}) is a dynamic task"
                )
        return [(f"{path.name}#{i}", t) for i, t in enumerate(tasks, 1)]
    out = []
    for p in task_files(args.task, what="--task"):
        try:
            out.append((str(p), common.load_task(p, args.csv_header)))
        except (ValueError, OSError) as exc:
            out.append((str(p), Failed(str(p), one_line(exc))))
    static_sources(out)  # a dynamic task, or a file given twice by two paths: refused now
    return out


def cmd_optima(args: argparse.Namespace) -> int:
    from modquad_gym.core.distributed import Engine, Failed
    from modquad_gym.core.outputs import check_output_file
    from modquad_gym.core.validation import check_int
    from modquad_gym.scoring.optima import build_dataset
    from modquad_gym.search.problem import EXACT_MODULES

    if args.suite:
        refuse_ignored(args, ["csv_header"], "applies to --task files, not to --suite")
    n_max = check_int(args.n_max, "--n-max", low=1, high=EXACT_MODULES)
    palette = palette_of(args.modules)  # a bad --modules: refused before any work
    out = check_output_file(args.out, force=True, what="--out")  # resumed, or new
    tasks = sources(args)
    if all(isinstance(task, Failed) for _, task in tasks):  # nothing to do: nothing created
        if len(tasks) == 1:
            raise ValueError(tasks[0][1].error)
        for _, failure in tasks:
            report_error(failure.error)
        return batch_status(tasks, len(tasks))
    with Engine(args.workers, args.ray_address, option="--workers") as engine:
        run = build_dataset(tasks, out, n_max, engine, progress=not args.quiet, fresh=args.force,
                            modules=palette)  # fmt: skip
    for failure in run.failed:
        report_error(failure.error)
    dropped = ", an unfinished last line dropped" if run.dropped_bytes else ""
    print(
        f"{out}: {run.written} records written, {run.skipped} already there{dropped}"
        + (f", {len(run.failed)} tasks failed" if run.failed else "")
    )
    return batch_status(run.failed, len(tasks))
