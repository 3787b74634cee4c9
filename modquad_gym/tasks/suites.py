"""Suites: several tasks in one JSON file ``{"name": ..., "tasks": [task dicts...]}``; a task
dict with a ``"trajectory"`` (or ``"kind": "dynamic"``) is a dynamic task
(:class:`~modquad_gym.dynamics.DynamicTask`)."""

from __future__ import annotations

import json
from collections.abc import Iterable, Sequence
from pathlib import Path

from modquad_gym.core.outputs import check_output_file, write_text
from modquad_gym.core.validation import check_flag
from modquad_gym.dynamics import DynamicTask
from modquad_gym.dynamics.task import is_dynamic_data
from modquad_gym.tasks.examples import resolve_task_path
from modquad_gym.tasks.files import (
    SUITE_KEYS,
    PathLike,
    TaskFileError,
    check_path,
    read_json,
    task_json,
    unknown_key_message,
)
from modquad_gym.tasks.requirement import TaskRequirement


def load_suite(path: PathLike) -> list[TaskRequirement | DynamicTask]:
    """Read a suite: a JSON file ``{"name": ..., "tasks": [task dicts...]}`` (task dicts as in
    :meth:`TaskRequirement.to_dict`, or :meth:`DynamicTask.to_dict` for those with a
    ``"trajectory"``; extras such as ``"optimum"`` live in each task's ``meta``);
    ``example:NAME`` reads a shipped example suite (as :meth:`TaskRequirement.load` does).
    Raises TaskFileError naming the file and the 1-based task (and row), or an unknown key."""
    check_path(path)
    path = resolve_task_path(path)
    if not path.exists():
        raise FileNotFoundError(f"suite file not found: {path}")
    if not path.is_file():
        raise TaskFileError(f"{path}: not a regular file")
    data = read_json(path)
    if not isinstance(data, dict) or not isinstance(data.get("tasks"), list):
        raise TaskFileError(f'{path}: a suite is a JSON object with a "tasks" list')
    for key in data:
        if key not in SUITE_KEYS:
            raise TaskFileError(
                f"{path}: {unknown_key_message(key, SUITE_KEYS)}; a suite's keys are "
                f"{', '.join(SUITE_KEYS)}"
            )
    if not isinstance(data.get("name", ""), str):
        raise TaskFileError(f"{path}: the suite's name must be a string, got {data['name']!r:.60}")
    if not data["tasks"]:
        raise TaskFileError(f"{path}: the suite has no tasks")
    tasks = []
    for i, item in enumerate(data["tasks"], 1):
        try:
            dynamic = is_dynamic_data(item)
            kind = DynamicTask if dynamic else TaskRequirement
            tasks.append(kind.from_dict(item, default_name=f"{path.stem}-{i}"))
        except ValueError as exc:
            raise TaskFileError(f"{path}: task {i}: {exc}") from None
    return tasks


def save_suite(
    tasks: Sequence[TaskRequirement | DynamicTask],
    path: PathLike,
    name: str | None = None,
    force: bool = False,
) -> Path:
    """Write ``tasks`` (a list or another iterable of tasks, not one task) as a suite JSON
    file, ``path`` a ``.json`` file (see :func:`load_suite`); ``name`` (a string) defaults to
    the stem. An existing file is replaced only with ``force=True`` (as
    :meth:`TaskRequirement.save`). A ValueError names the argument that is wrong (or what in a
    task's ``meta`` JSON cannot hold) before the file is touched."""
    check_path(path)
    force = check_flag(force, "force")
    path = Path(path)
    if path.suffix.lower() != ".json":
        raise ValueError(f"path: a suite is a .json file, got {str(path)!r}")
    if isinstance(tasks, (TaskRequirement, DynamicTask)):
        raise ValueError("tasks must be a list of tasks, got one task (save_suite([task], ...))")
    if isinstance(tasks, (str, bytes, dict)) or not isinstance(tasks, Iterable):
        raise ValueError(f"tasks must be a non-empty list of tasks, got {tasks!r:.60}")
    tasks = list(tasks)
    if not tasks:
        raise ValueError("tasks must be a non-empty list of tasks, got none")
    for i, t in enumerate(tasks, 1):
        if not isinstance(t, (TaskRequirement, DynamicTask)):
            raise ValueError(
                f"tasks: task {i} is of type {type(t).__name__}, not a TaskRequirement or a "
                "DynamicTask"
            )
    if name is not None and not isinstance(name, str):
        raise ValueError(f"name must be a string or None, got {name!r}")
    path = check_output_file(path, force=force, what="path")
    body = ",\n".join("    " + task_json(t.to_dict(), indent="    ") for t in tasks)
    head = json.dumps(name if name is not None else path.stem)
    write_text(path, f'{{\n  "name": {head},\n  "tasks": [\n{body}\n  ]\n}}\n')
    return path
