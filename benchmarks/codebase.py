"""The shape of the code: Python in the wheel and the branches on a task's kind outside the task
model (the consolidation's goals, issue 33).

    python -m benchmarks.codebase --out results/codebase

Writes ``codebase.md`` and ``codebase.csv``: lines of Python per folder of the wheel
(``modquad_gym/``), split into docstrings, blank lines and the rest, with the goal of at most
20,000 lines; and every line outside the task model (``tasks/``, ``dynamics/``) that branches
on a task's kind, with the goal of at most 5. The start-up goals are
``python -m benchmarks.startup``'s, the env's speed ``python -m benchmarks.env``'s, repeated
code the ``duplicates`` tool's, import cycles ``tests/test_layers.py``'s.
"""

from __future__ import annotations

import ast
import re
from collections import Counter
from pathlib import Path

from benchmarks.common import (
    HelpFormatter,
    add_force,
    command_as_run,
    markdown_table,
    parse_bench_args,
    report_page,
    run_main,
    write_report,
)
from modquad_gym.core.options import OneLineParser, path_option

ROOT = Path(__file__).resolve().parents[1]
PACKAGE = ROOT / "modquad_gym"
TASK_MODEL = ("tasks", "dynamics")
"""The task model's folders: the kind is theirs to branch on."""
KIND_BRANCH = re.compile(
    r"\b(task|problem|self)\.kind\s*(==|!=|in\b)|\bargs\.task_kind\s*(==|!=)"
    r"|\bkind\s*(==|!=)\s*(\"(total|external|dynamic)\"|DYNAMIC\b)"
    r"|isinstance\([^)]*DynamicTask|\bis_dynamic\("
)
"""A test of a task's kind: its ``kind`` compared, or the dynamic task's class tested."""
LINES_GOAL = 20_000
BRANCHES_GOAL = 5


def kind_branches(package: Path = PACKAGE) -> list[tuple[str, int, str]]:
    """(file, 1-based line, text) of each line outside the task model that tests a task's kind
    (comments and docstrings are not code: only lines that parse as code count)."""
    found = []
    for path in sorted(package.rglob("*.py")):
        rel = path.relative_to(package)
        if rel.parts[0] in TASK_MODEL:
            continue
        source = path.read_text(encoding="utf-8")
        strings = _string_lines(source)
        for number, line in enumerate(source.splitlines(), 1):
            code = line.split("#", 1)[0]
            if number not in strings and KIND_BRANCH.search(code):
                found.append((f"modquad_gym/{rel}", number, line.strip()))
    return found


SOLVE_ARGV = ("solve", "--task", "example:screwdriver", "--json", "--quiet")
"""The traced call: the default search on a shipped example, as a user types it."""


def solve_path_files(argv: tuple[str, ...] = SOLVE_ARGV) -> list[str]:
    """The package's files whose code runs in a warm ``modquad solve`` (the second of two
    calls in one process, so imports and first-call caches are not counted): how many hands
    a task and its options pass through between the command line and the answer."""
    import contextlib
    import io
    import sys

    from modquad_gym.cli import main as modquad

    with contextlib.redirect_stdout(io.StringIO()):
        modquad(list(argv))
        seen: set[str] = set()

        def trace(frame, event, arg):
            if event == "call":
                seen.add(frame.f_code.co_filename)

        sys.setprofile(trace)
        try:
            modquad(list(argv))
        finally:
            sys.setprofile(None)
    root = str(PACKAGE.parent) + "/"
    return sorted(f.removeprefix(root) for f in seen if f.startswith(str(PACKAGE)))


def _string_lines(source: str) -> set[int]:
    """The lines that lie inside a string constant spanning several lines (docstrings)."""
    lines: set[int] = set()
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.Constant) and isinstance(node.value, str):
            if node.end_lineno and node.end_lineno > node.lineno:
                lines.update(range(node.lineno, node.end_lineno + 1))
    return lines


def line_counts(package: Path = PACKAGE) -> list[dict]:
    """Per folder of the package: files, lines, docstring lines, blank lines and the rest."""
    per: dict[str, Counter] = {}
    for path in sorted(package.rglob("*.py")):
        rel = path.relative_to(package)
        folder = rel.parts[0] if len(rel.parts) > 1 else "(top)"
        source = path.read_text(encoding="utf-8")
        lines = source.splitlines()
        docs = len(_docstring_lines(source))
        blank = sum(1 for line in lines if not line.strip())
        c = per.setdefault(folder, Counter())
        c.update(files=1, lines=len(lines), docstrings=docs, blank=blank,
                 code=len(lines) - docs - blank)  # fmt: skip
    rows = [{"folder": k, **v} for k, v in sorted(per.items(), key=lambda kv: -kv[1]["lines"])]
    total = sum((Counter(r) for r in ({k: v for k, v in r.items() if k != "folder"}
                                      for r in rows)), Counter())  # fmt: skip
    return [*rows, {"folder": "total", **total}]


def _docstring_lines(source: str) -> set[int]:
    lines: set[int] = set()
    for node in ast.walk(ast.parse(source)):
        body = getattr(node, "body", None)
        if not isinstance(body, list):
            continue
        for i, stmt in enumerate(body):
            first = i == 0 and isinstance(node, (ast.Module, ast.ClassDef, ast.FunctionDef))
            after_assign = i > 0 and isinstance(body[i - 1], (ast.Assign, ast.AnnAssign))
            if (
                (first or after_assign)
                and isinstance(stmt, ast.Expr)
                and (isinstance(stmt.value, ast.Constant) and isinstance(stmt.value.value, str))
            ):
                lines.update(range(stmt.lineno, stmt.end_lineno + 1))
    return lines


def main(argv: list[str] | None = None) -> int:
    p = OneLineParser(
        prog="python -m benchmarks.codebase",
        description="Lines of Python in the wheel and the branches on a task's kind outside "
        "the task model, against the consolidation's goals.",
        formatter_class=HelpFormatter,
    )
    p.add_argument(
        "--out", type=path_option, default=Path("results/codebase"), help="report folder"
    )
    add_force(p)
    args = parse_bench_args(p, argv, ("codebase.md", "codebase.csv"))
    counts = line_counts()
    branches = kind_branches()
    total = counts[-1]["lines"]
    met = {True: "met", False: "NOT met"}
    notes = (
        f"**Python in the wheel: {total:,} lines (goal <= {LINES_GOAL:,}: "
        f"{met[total <= LINES_GOAL]}).** Per folder of `modquad_gym/`: files, lines, "
        "docstring lines, blank lines and the rest (code and comments)."
    )
    listed = [{"file": f, "line": n, "code": f"`{t}`"} for f, n, t in branches]
    more = [
        f"**Branches on a task's kind outside the task model (`tasks/`, `dynamics/`): "
        f"{len(branches)} (goal <= {BRANCHES_GOAL}: {met[len(branches) <= BRANCHES_GOAL]}).**",
        "",
        markdown_table(listed) if listed else "None.",
    ]
    crossed = solve_path_files()
    more += [
        "",
        f"**Files of the package a warm `modquad {' '.join(SOLVE_ARGV)}` runs code in: "
        f"{len(crossed)}** (traced with `sys.setprofile`, the second call in one process):",
        "",
        ", ".join(f"`{f.removeprefix('modquad_gym/')}`" for f in crossed),
    ]
    command = command_as_run("codebase", argv)
    text = report_page("The shape of the code", command, notes, counts, *more)
    write_report(args.out, "codebase", counts, text)
    print(text)
    return 0


if __name__ == "__main__":
    raise SystemExit(run_main(main, "codebase"))
