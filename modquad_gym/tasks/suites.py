"""Suites: several tasks in one JSON file ``{"name": ..., "tasks": [task dicts...]}``; a task
dict with a ``"trajectory"`` is a dynamic task (:class:`~modquad_gym.dynamics.DynamicTask`)."""

from __future__ import annotations

import json
from collections.abc import Sequence
from pathlib import Path

from modquad_gym.core.outputs import write_text
from modquad_gym.dynamics import DynamicTask
from modquad_gym.tasks.files import (
    SUITE_KEYS,
    PathLike,
    TaskFileError,
    read_json,
    task_json,
    unknown_key_message,
)
from modquad_gym.tasks.requirement import TaskRequirement


def load_suite(path: PathLike) -> list[TaskRequirement | DynamicTask]:
    """Read a suite: a JSON file ``{"name": ..., "tasks": [task dicts...]}`` (task dicts as in
    :meth:`TaskRequirement.to_dict`, or :meth:`DynamicTask.to_dict` for those with a
    ``"trajectory"``; extras such as ``"optimum"`` live in each task's ``meta``).
    Raises TaskFileError naming the file and the 1-based task (and row), or an unknown key."""
    path = Path(path)
    if not path.exists():
        raise FileNotFoundError(f"suite file not found: {path}")
    data = read_json(path)
    if not isinstance(data, dict) or not isinstance(data.get("tasks"), list):
        raise TaskFileError(f'{path}: a suite is a JSON object with a "tasks" list')
    for key in data:
        if key not in SUITE_KEYS:
            raise TaskFileError(
                f"{path}: {unknown_key_message(key, SUITE_KEYS)}; a suite's keys are "
                f"{', '.join(SUITE_KEYS)}"
            )
    if not data["tasks"]:
        raise TaskFileError(f"{path}: the suite has no tasks")
    tasks = []
    for i, item in enumerate(data["tasks"], 1):
        try:
            dynamic = isinstance(item, dict) and "trajectory" in item
            kind = DynamicTask if dynamic else TaskRequirement
            tasks.append(kind.from_dict(item, default_name=f"{path.stem}-{i}"))
        except ValueError as exc:
            raise TaskFileError(f"{path}: task {i}: {exc}") from None
    return tasks


def save_suite(
    tasks: Sequence[TaskRequirement | DynamicTask], path: PathLike, name: str | None = None
) -> Path:
    """Write ``tasks`` as a suite JSON file (see :func:`load_suite`); name defaults to the stem."""
    path = Path(path)
    tasks = list(tasks)
    if not tasks or not all(isinstance(t, (TaskRequirement, DynamicTask)) for t in tasks):
        raise ValueError("save_suite needs a non-empty sequence of TaskRequirement or DynamicTask")
    body = ",\n".join("    " + task_json(t.to_dict(), indent="    ") for t in tasks)
    head = json.dumps(name if name is not None else path.stem)
    write_text(path, f'{{\n  "name": {head},\n  "tasks": [\n{body}\n  ]\n}}\n')
    return path
