"""Every success of a ``modquad score`` run verified again in a fresh process.

An outside agent runs in the scorer's process (docs/benchmarks.md, protocol item 2), so it can
replace the scorer's own check (``judged`` of :mod:`.agents`, ``verified`` of :mod:`.verdicts`)
and have any answer counted. :func:`recheck` therefore hands every success row, its cells and
the suite it comes from to a new interpreter (``python -m modquad_gym.scoring.recheck_child``,
the rows as JSON on its input, run from the package's own folder: it imports modquad_gym and
never the agent's module nor the caller's ``__main__``), which reads each task again from its suite
file (or draws the validation task again from its seed), rebuilds the structure from the row's
cells on the tier's module types and decides it with the exact oracle, the ``fault`` included.
One disagreement stops the run before anything is written. What the fresh process cannot see
stays honour-based: the seconds, configurations and oracle calls measured in the agent's
process.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import time
from pathlib import Path

from modquad_gym.scoring.scores import Row

Source = tuple
"""Where a suite's tasks come from: ``("file", path)`` or ``("validation", n, task source)``."""

REFUSED = "the agent's process verified an answer the exact oracle refuses"
"""The start of the line that stops a run whose rows a fresh process does not confirm."""

FAILED = "the fresh process that re-checks the answers failed to run"
"""The start of the line that stops a run whose re-check process gave no verdicts (its own
error, not a refusal of any answer)."""


def suite_sources(paths: list | None, tier, validation: int | None) -> dict[str, Source]:
    """Where each scored suite comes from: the ``--suite`` ``paths`` (by file stem), the
    tier's validation draws (``validation`` tasks), or the tier's held-out suite files."""
    from modquad_gym.scoring.suites import SUITES_DIR
    from modquad_gym.tasks.examples import resolve_task_path

    if paths:  # example:NAME resolved here: the fresh process reads the shipped file itself
        return {Path(p).stem: ("file", str(resolve_task_path(p))) for p in paths}
    if validation:
        return {"validation": ("validation", int(validation), tier.source or "mixed")}
    return {name: ("file", str(SUITES_DIR / f"{name}.json")) for name in tier.suites}


def recheck(rows: list[Row], per_task: int, sources: dict[str, Source], n_max: int,
            modules: str | None, fault: str | None) -> tuple[int, float]:  # fmt: skip
    """Verify every success of ``rows`` in a fresh process (module docstring): (rows checked,
    seconds, the process's start included); ValueError naming the first method and task whose
    answer it refuses. ``rows`` are in :func:`~.agents.run_benchmark`'s order, ``per_task``
    (the methods) rows per task, task by task through each suite: a row's task is found by its
    place in its suite (names repeat within a suite), and its name checked."""
    t0 = time.perf_counter()
    seen: dict[str, int] = {}
    wins = []
    for r in rows:
        place = seen.get(r.suite, 0)
        seen[r.suite] = place + 1
        if r.success:
            wins.append((r.suite, place // per_task, r.task, r.method, r.n_modules, r.cells))
    if not wins:
        return 0, 0.0
    verdicts = _in_fresh_process(wins, sources, n_max, modules, fault)
    for (suite, _, task, method, *_), why in zip(wins, verdicts):
        if why:
            raise ValueError(
                f"{REFUSED}: {method} on task {task!r} of {suite}: {why} (re-checked in a "
                "fresh process; nothing written)"
            )
    return len(wins), time.perf_counter() - t0


def _in_fresh_process(wins, sources, n_max, modules, fault) -> list[str]:
    """:func:`verdicts_of` in a new interpreter started in the folder holding this package
    (so it imports this modquad_gym, and nothing of the caller's folder); ValueError when it
    fails (:data:`FAILED` and its last error line: no answer was judged)."""
    absolute = {
        k: (v[0], os.path.abspath(v[1])) if v[0] == "file" else v for k, v in sources.items()
    }
    given = dict(wins=wins, sources=absolute, n_max=n_max, modules=modules, fault=fault)
    text = json.dumps(given, default=lambda o: o.tolist())  # numpy numbers as Python's
    home = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
    run = subprocess.run(
        [sys.executable, "-m", "modquad_gym.scoring.recheck_child"], input=text, cwd=home,
        capture_output=True, text=True,
    )  # fmt: skip
    try:
        verdicts = json.loads(run.stdout.strip().splitlines()[-1]) if run.returncode == 0 else None
    except (IndexError, ValueError):
        verdicts = None
    if not isinstance(verdicts, list) or len(verdicts) != len(wins):
        why = (run.stderr.strip().splitlines() or [f"exit code {run.returncode}"])[-1]
        raise ValueError(f"{FAILED}: {why} (nothing written)")
    return verdicts


def verdicts_of(wins: list[tuple], sources: dict[str, Source], n_max: int,
                modules: str | None, fault: str | None) -> list[str]:  # fmt: skip
    """In the fresh process: for each (suite, task index, task name, method, modules, cells), ""
    when the cells are a success on the suite's own task, else why not."""
    from modquad_gym.geometry.module import palette
    from modquad_gym.scoring.verdicts import judged, structure_of
    from modquad_gym.search.problem import DEFAULT_MODULE

    types, typed = (palette(modules), True) if modules else ([DEFAULT_MODULE], False)
    tasks = {name: _tasks(source) for name, source in sources.items()}
    out = []
    for suite, index, name, _, size, cells in wins:
        task = tasks[suite][index] if index < len(tasks.get(suite, ())) else None
        if task is None or task.name != name:
            out.append(f"the suite has no task {name!r} at place {index + 1}")
            continue
        answer = structure_of(cells, types, typed)
        if answer is None or answer.n_modules != size:
            out.append(f"its cells {cells} are not the {size}-module answer it reports")
        elif not judged(answer, task, n_max, types, fault):
            after = "" if fault is None else f", or not after every single {fault} failure"
            count = f"{size} module{'s' if size != 1 else ''}"
            out.append(f"its {count} at {cells} do not exert every task wrench{after}")
        else:
            out.append("")
    return out


def _tasks(source: Source) -> list:
    """The tasks of one suite ``source``, read or drawn again here."""
    if source[0] == "validation":
        from modquad_gym.scoring.suites import validation_tasks

        return validation_tasks(source[1], source[2])
    from modquad_gym.tasks import load_suite

    return load_suite(source[1])
