"""Reading any task file: a static task (:class:`TaskRequirement`) or a dynamic one
(:class:`~modquad_gym.dynamics.DynamicTask`, a JSON object with a ``"trajectory"``)."""

from __future__ import annotations

from pathlib import Path

from modquad_gym.dynamics import DynamicTask
from modquad_gym.tasks.files import PathLike, TaskFileError, read_json, read_text
from modquad_gym.tasks.requirement import TaskRequirement


def is_dynamic(task: object) -> bool:
    """True for a task whose wrenches depend on the structure's mass and inertia."""
    return isinstance(task, DynamicTask)


def load_task(path: PathLike, csv_header: str = "auto") -> TaskRequirement | DynamicTask:
    """The task in ``path``: a :class:`DynamicTask` for a JSON object with a ``"trajectory"``
    key, else :meth:`TaskRequirement.load`. Errors are TaskFileErrors naming the file and the
    field (``trajectory.t: ...``, ``payload.mass: ...``)."""
    p = Path(path)
    if p.suffix.lower() == ".json" and p.is_file() and '"trajectory"' in read_text(p):
        data = read_json(p)
        if isinstance(data, dict) and "trajectory" in data:
            try:
                return DynamicTask.from_dict(data, default_name=p.stem)
            except ValueError as exc:
                raise TaskFileError(f"{p}: {exc}") from None
    return TaskRequirement.load(path, csv_header=csv_header)
