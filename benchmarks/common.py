"""What the measurement scripts share: their option parsing (list options whose values each count
once, help that states the defaults) and running, the command as run, the machine line, a random
structure, a markdown table, a report's page and its writing, and the list of the scripts
(:func:`scripts`)."""

from __future__ import annotations

import argparse
import importlib
import io
import os
import shlex
import sys
from collections.abc import Callable
from contextlib import ExitStack
from contextvars import ContextVar
from pathlib import Path

import numpy as np

from modquad_gym.core import options as core_options
from modquad_gym.core.interrupts import run_command
from modquad_gym.core.options import DefaultsHelpFormatter, int_option, path_option, seed_option
from modquad_gym.core.outputs import OutputError, check_output_dir, write_csv, write_text
from modquad_gym.core.validation import read_regular_file
from modquad_gym.geometry.structure import Structure
from modquad_gym.scoring import machine_description, markdown_table

__all__ = [
    "Distinct",
    "HelpFormatter",
    "RawHelpFormatter",
    "add_force",
    "bench_args",
    "command_as_run",
    "check_task_rows",
    "hold_out",
    "int_option",
    "load_average",
    "machine_description",
    "made_by",
    "markdown_table",
    "parse_bench_args",
    "random_structure",
    "read_input_text",
    "refuse_as_script",
    "repeats",
    "report_page",
    "run_command",
    "run_main",
    "run_script",
    "scripts",
    "seed_option",
    "shown",
    "write_csv",
    "write_report",
    "write_text",
]


def scripts() -> dict[str, str]:
    """Every script of ``benchmarks/`` (a module with ``main``; ``python -m benchmarks.NAME``
    runs it) by name, with the first line of its docstring (what it measures), read without
    importing them."""
    import ast

    out = {}
    for path in sorted(Path(__file__).parent.glob("*.py")):
        tree = ast.parse(path.read_text(encoding="utf-8"))
        if any(isinstance(n, ast.FunctionDef) and n.name == "main" for n in tree.body):
            out[path.stem] = (ast.get_docstring(tree) or "").split("\n\n")[0].replace("\n", " ")
    return out


_RUN: ContextVar[ExitStack | None] = ContextVar("benchmark_run", default=None)
"""What the running script holds until it ends (:func:`run_main`): its ``--out`` folder."""


def run_main(
    main: Callable[[list[str] | None], object], name: str, argv: list[str] | None = None
) -> int:
    """``python -m benchmarks.NAME`` (``main``) with the options ``argv`` (default the command
    line's), run as :func:`~modquad_gym.core.interrupts.run_command` runs a command; the
    folders it holds (:func:`hold_out`) are let go when it ends."""
    with ExitStack() as held:
        run = _RUN.set(held)
        try:
            return run_command(main, f"python -m benchmarks.{name}", argv)
        finally:
            _RUN.reset(run)


def hold_out(folder: Path, names: tuple[str, ...] = (), force: bool = False,
             what: str = "--out") -> Path:  # fmt: skip
    """``folder`` checked as :func:`~modquad_gym.core.outputs.check_output_dir` checks it (none
    of ``names`` there unless ``force``) and, in a script :func:`run_main` runs, held until the
    script ends (:func:`~modquad_gym.core.outputs.hold_output_dir`): a second run into it is
    refused at once, not left to replace this run's files. An OutputError otherwise."""
    from modquad_gym.core.outputs import hold_output_dir

    held = _RUN.get()
    if held is None:  # main() called directly (a test, a notebook): checked only
        return check_output_dir(folder, names, force, what)
    return held.enter_context(hold_output_dir(folder, names, force, what))


def refuse_as_script(name: str) -> int:
    """What a helper module of the benchmarks does when run as a script: one line saying so
    and naming the scripts, exit status 2."""
    print(
        f"python -m benchmarks.{name}: error: a helper module of the benchmarks, not a "
        "script; run one of: " + ", ".join(f"benchmarks.{s}" for s in scripts()),
        file=sys.stderr,
    )
    return 2


def run_script(name: str, argv: list[str] | None = None) -> int:
    """:func:`run_main` of the script ``benchmarks.NAME`` (imported here)."""
    return run_main(importlib.import_module(f"benchmarks.{name}").main, name, argv)


def command_as_run(name: str, argv: list[str] | None = None) -> str:
    """``python -m benchmarks.NAME`` with the options ``argv`` (default the command line's) as
    given, quoted for a shell: the command a report names, which makes it again."""
    return shlex.join(
        ["python", "-m", f"benchmarks.{name}", *(sys.argv[1:] if argv is None else argv)]
    )


def repeats(values, key: Callable | None = None) -> list:
    """The values of ``values`` given more than once (compared by ``key(value)``, default the
    value), each once, in the order of their second appearance."""
    seen, twice = set(), {}
    for value in values:
        k = value if key is None else key(value)
        if k in seen:
            twice.setdefault(k, value)
        seen.add(k)
    return list(twice.values())


def shown(value) -> str:
    """An option's value as a command line writes it: a number in its shortest form, a tuple
    comma-separated (``none`` when empty), None as ``auto`` (the options whose default is the
    method's own)."""
    if value is None:
        return "auto"
    if isinstance(value, float):
        return f"{value:g}"
    if isinstance(value, tuple):
        return ",".join(map(shown, value)) or "none"
    return str(value)


class Distinct(argparse.Action):
    """``action=Distinct`` for a list option whose values each count once (a band, method or
    seed given twice would be run twice and counted twice in the report's totals): a repeat is
    argparse's one-line error naming the option and the value, exit 2 before any work. ``key``
    (an ``add_argument`` keyword) compares values by ``key(value)``, e.g. folders by their
    resolved path."""

    def __init__(self, *args, key: Callable | None = None, **kwargs):
        super().__init__(*args, **kwargs)
        self.key = key

    def __call__(self, parser, namespace, values, option_string=None):
        twice = repeats(values, self.key)
        if twice:
            raise argparse.ArgumentError(self, f"{shown(twice[0])} is given twice")
        setattr(namespace, self.dest, values)


class HelpFormatter(DefaultsHelpFormatter):
    """The benchmarks' ``--help``: each option's default stated once, as their own help texts
    state it, ``(default 16 32 64)`` (a list space-separated, as it is typed)."""

    def _get_help_string(self, action: argparse.Action) -> str:
        text = super()._get_help_string(action)
        tail = " (default: %(default)s)"
        if not text.endswith(tail):
            return text
        default = action.default
        if default == "":
            return text.removesuffix(tail)
        many = isinstance(default, (list, tuple)) and action.nargs not in (None, "?")
        value = " ".join(map(shown, default)) if many else shown(default)
        return f"{text.removesuffix(tail)} (default {value.replace('%', '%%')})".lstrip()


class RawHelpFormatter(argparse.RawDescriptionHelpFormatter, HelpFormatter):
    """:class:`HelpFormatter` keeping the description's own lines."""


def bench_args(argv: list[str] | None, prog: str, description: str, options: dict[str, dict],
               *, outputs: tuple[str, ...] = (), **kwargs) -> argparse.Namespace:  # fmt: skip
    """The options of one benchmark, its :func:`bench_parser` (with ``--force`` when it names
    ``outputs``, the files it writes into ``--out``) read by :func:`parse_bench_args`."""
    kwargs["force"] = kwargs.get("force", False) or bool(outputs)
    return parse_bench_args(bench_parser(prog, description, options, **kwargs), argv, outputs)


def bench_parser(
    prog: str,
    description: str,
    options: dict[str, dict],
    *,
    seed_help: str | None = "task seed (default 0)",
    out: str = "results",
    out_help: str = "report folder",
    force: bool = False,
    **parser_kwargs,
) -> argparse.ArgumentParser:
    """The parser of one benchmark: ``options`` maps each flag to its ``add_argument``
    keywords; every benchmark also takes ``--seed`` (unless ``seed_help`` is None), ``--out``
    (default ``out``; held for the run, :func:`hold_out`; a script may also claim it inside
    that hold, :func:`~modquad_gym.core.outputs.claim_output_dir`) and, with ``force``,
    ``--force``; ``--help`` states every default (:class:`HelpFormatter`)."""
    parser_kwargs.setdefault("formatter_class", HelpFormatter)
    parser = core_options.OneLineParser(prog=prog, description=description, **parser_kwargs)
    for flag, kwargs in options.items():
        parser.add_argument(flag, **kwargs)
    if seed_help is not None:
        parser.add_argument("--seed", type=seed_option, default=0, help=seed_help)
    parser.add_argument(
        "--out", type=path_option, default=Path(out), help=f"{out_help} (default {out})"
    )
    if force:
        add_force(parser)
    return parser


def add_force(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--force", action="store_true", help="replace existing reports (default: refuse)"
    )


def parse_bench_args(
    parser: argparse.ArgumentParser,
    argv: list[str] | None,
    outputs: tuple[str, ...] = (),
):
    """Parse ``argv``; when the benchmark has ``--out``, check that it is (or can become) a
    writable folder holding none of ``outputs`` (unless ``--force``) and that no other run
    holds it, and hold it for this run (:func:`hold_out`), before any work starts (an
    argparse error otherwise)."""
    args = parser.parse_args(argv)
    out = getattr(args, "out", None)
    if out is not None:
        force = getattr(args, "force", False)
        try:
            hold_out(out, outputs, force)
        except OutputError as exc:
            parser.error(str(exc))
    return args


def check_model(path: str, label: str) -> None:
    """Read the saved model at ``path`` now, so that a bad file fails before any work: a one-line
    ValueError beginning with ``label`` (the option as given) otherwise."""
    from modquad_gym.policy.models import read_model

    try:
        read_model(path)
    except ValueError as exc:
        raise ValueError(f"{label}: {exc}") from None


def random_structure(n: int, rng: np.random.Generator) -> Structure:
    """A random connected n-module structure (:func:`modquad_gym.tasks.random_cells`: grown one
    module at a time at a uniformly chosen free cell)."""
    from modquad_gym.tasks import random_cells

    return Structure(random_cells(rng, n))


def load_average(sep: str = " / ") -> str:
    """The 1-, 5- and 15-minute load averages joined by ``sep``: how busy the (often shared)
    machine was when a report was written."""
    return sep.join(f"{x:.2f}" for x in os.getloadavg())


def made_by(command: str, how: str = "", caveat: str = "") -> str:
    """A report's "Made by" sentence: ``command``, the machine, ``how`` it ran (text after the
    machine, e.g. ``"; one process"``), the load average at the end, then ``caveat``."""
    return (
        f"Made by `{command}` on {machine_description()}{how}; load average at the end "
        f"{load_average()}{caveat}."
    )


def report_page(
    title: str, command: str, notes: str, rows: list[dict], *more: str, how="", caveat=""
) -> str:
    """A report's markdown page: ``# title``, its :func:`made_by` sentence, ``notes`` (what the
    columns mean), the table of ``rows``, then the ``more`` lines."""
    made = made_by(command, how, caveat)
    return "\n".join([f"# {title}", "", made, "", notes, "", markdown_table(rows), "", *more])


MAX_INPUT_BYTES = 256 * 2**20
"""Largest file a benchmark reads back (an earlier run's rows, a report): far above any."""


def read_input_text(path: Path, option: str = "", what: str = "UTF-8 text") -> str:
    """The text of the file ``path`` that ``option`` names (an earlier run's CSV, a report),
    read as the package reads its files (:func:`~modquad_gym.core.validation.read_regular_file`):
    a folder, pipe or device is refused at once (a pipe would block the read forever), as is a
    missing file or one that is not UTF-8 (``not WHAT``); a one-line ValueError beginning with
    ``option`` (none when empty) and the path."""
    where = f"{option} {path}" if option else str(path)
    try:
        return read_regular_file(path, MAX_INPUT_BYTES).decode("utf-8-sig")
    except ValueError as exc:  # "PATH: not a regular file", "PATH: N bytes, more than ..."
        if isinstance(exc, UnicodeDecodeError):
            raise ValueError(f"{where}: not {what} ({exc.reason} at byte {exc.start})") from None
        raise ValueError(f"{option} {exc}".lstrip()) from None
    except OSError as exc:
        raise ValueError(f"{where}: {exc.strerror or exc}") from None


def csv_header(path: Path) -> tuple[str, ...]:
    """The header of the CSV file ``path`` as it stands (for a file whose columns grew over its
    versions); () where it cannot be read (:func:`read_rows_csv` names the file and why)."""
    import csv

    try:
        return tuple(next(csv.reader(read_input_text(path).splitlines()[:1]), ()))
    except (ValueError, csv.Error):
        return ()


def read_rows_csv(
    path: Path,
    option: str,
    columns,
    typed: Callable,
    what: str,
    empty_ok: bool = False,
    older: tuple = (),
) -> list[dict]:
    """The rows of an earlier run's CSV file ``path`` (header exactly ``columns``, or one of the
    ``older`` headers its earlier versions wrote), each made by ``typed(raw)`` (None, or a
    KeyError/TypeError/ValueError: not a row of ``what``); otherwise a one-line ValueError naming
    ``option`` (none when empty: the file alone), the file and the 1-based row after the
    header."""
    import csv

    where = f"{option} {path}" if option else str(path)
    text = read_input_text(path, option, "a CSV file")
    try:
        reader = csv.DictReader(io.StringIO(text, newline=""))
        if tuple(reader.fieldnames or ()) not in {tuple(c) for c in (columns, *older)}:
            raise ValueError(f"{where}: its header is not {','.join(columns)}")
        raws = list(reader)
    except csv.Error as exc:
        raise ValueError(f"{where}: not a CSV file ({exc})") from None
    rows = []
    for i, raw in enumerate(raws, start=1):
        try:  # a field beyond the header goes under the key None
            row = typed(raw) if None not in raw else None
        except (KeyError, TypeError, ValueError):
            row = None
        if row is None:
            raise ValueError(f"{where}: row {i}: not a row of {what}")
        rows.append(row)
    if not rows and not empty_ok:
        raise ValueError(f"{where}: no rows")
    return rows


def check_task_rows(rows: list[dict], methods, where: str, name: Callable | None = None) -> None:
    """Rows read back from an earlier run: one row per task and method (``name(row)``, default
    its ``method``), and every task with a row of each of ``methods`` (what the reports compare
    task by task). A one-line ValueError beginning with ``where`` (the option and file) naming
    the task otherwise."""
    name = name or (lambda r: r["method"])
    seen: dict[tuple, dict] = {}
    for r in rows:
        key = (r["task"], name(r))
        if key in seen:
            raise ValueError(f"{where}: task {r['task']} has two {name(r)} rows")
        seen[key] = r
    for task in dict.fromkeys(r["task"] for r in rows):
        have = next(name(r) for r in rows if r["task"] == task)
        for method in methods:
            if (task, method) not in seen:
                raise ValueError(f"{where}: task {task} has a {have} row and no {method} row")


def write_report(out: Path, stem: str, rows: list[dict], text: str) -> None:
    """A benchmark's report: ``rows`` to ``out/STEM.csv``, ``text`` to ``out/STEM.md``."""
    write_csv(rows, out / f"{stem}.csv")
    write_text(out / f"{stem}.md", text)


if __name__ == "__main__":
    raise SystemExit(refuse_as_script("common"))
