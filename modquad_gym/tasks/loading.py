"""The one way user input becomes a task: :func:`as_task` (a task object, anything with
``wrenches``, or a wrench array) and :func:`load_task` (any task file: a static task,
:class:`TaskRequirement`, or a dynamic one, :class:`~modquad_gym.dynamics.DynamicTask`, a JSON
object with a ``"trajectory"``). The searches, the environment, the learned solvers and the
command line all go through them."""

from __future__ import annotations

import os
from typing import Any

from modquad_gym.core.validation import check_wrenches
from modquad_gym.dynamics import DynamicTask
from modquad_gym.dynamics.task import is_dynamic_data
from modquad_gym.tasks.csvfile import check_csv_header, csv_rows_at_most
from modquad_gym.tasks.examples import resolve_task_path
from modquad_gym.tasks.files import (
    PathLike,
    TaskFileError,
    check_path,
    npy_rows,
    read_bytes,
    read_json,
)
from modquad_gym.tasks.requirement import TaskRequirement
from modquad_gym.tasks.wrenches import MAX_WRENCHES


def is_dynamic(task: object) -> bool:
    """True for a task whose wrenches depend on the structure's mass and inertia."""
    return isinstance(task, DynamicTask)


def as_task(
    task: Any, what: str | None = None, name: str = "task"
) -> TaskRequirement | DynamicTask:
    """``task`` as a task: a :class:`TaskRequirement` or :class:`DynamicTask` as it is (a search
    problem: its task, with the problem's ``f_max`` and kind); anything
    with ``wrenches`` (and, if it has them, ``f_max``, ``kind``, ``name``) or a (t, 6) wrench
    array (one 6-vector too) as a TaskRequirement named ``name``. A ValueError names what is
    wrong, after ``what:`` when ``what`` is given (a path too: :func:`load_task` reads one)."""
    if isinstance(task, (TaskRequirement, DynamicTask)):
        return task
    inner = getattr(task, "task", None)  # a search problem: the task it was built from
    if isinstance(inner, (TaskRequirement, DynamicTask)):
        return inner
    if isinstance(task, (str, bytes, os.PathLike)):  # else read as an array of characters
        shown = repr(str(task) if isinstance(task, os.PathLike) else task)
        shown = shown if len(shown) <= 60 else shown[:57] + "..."
        text = (
            f"{name} {shown}: a path is not a task; give modquad_gym.tasks.load_task(path) (a "
            "TaskRequirement or DynamicTask), a SearchProblem or a (t, 6) wrench array"
        )
        raise ValueError(text if what is None else f"{what}: {text}")
    fields: dict[str, Any] = {"name": name}
    W = task
    if hasattr(task, "wrenches"):
        W = task.wrenches
        fields.update({k: getattr(task, k) for k in ("f_max", "kind", "name") if hasattr(task, k)})
    try:
        return TaskRequirement(check_wrenches(W, allow_empty=False), **fields)
    except ValueError as exc:
        if what is None:
            raise
        raise ValueError(f"{what}: {exc}") from None


def load_task(path: PathLike, csv_header: str = "auto") -> TaskRequirement | DynamicTask:
    """The task in ``path`` (``example:NAME``: a shipped example), read once: a
    :class:`DynamicTask` for a JSON object with a ``"trajectory"`` key or ``"kind":
    "dynamic"``, else a :class:`TaskRequirement` (:meth:`TaskRequirement.load`). Errors are
    TaskFileErrors naming the file and the field (``trajectory.t: ...``, ``payload.mass:
    ...``)."""
    check_path(path)
    p = resolve_task_path(path)
    check_csv_header(csv_header, p)
    if p.suffix.lower() != ".json" or not p.is_file():
        return TaskRequirement.load(p, csv_header=csv_header)
    data = read_json(p)
    is_motion = is_dynamic_data(data)
    try:
        if is_motion:
            return DynamicTask.from_dict(data, default_name=p.stem)
        return TaskRequirement.from_dict(data, default_name=p.stem)
    except TaskFileError:
        raise
    except ValueError as exc:
        raise TaskFileError(f"{p}: {exc}") from None


def wrenches_at_most(
    path: PathLike, csv_header: str = "auto", most: int = MAX_WRENCHES
) -> int | None:
    """How many wrenches the task file ``path`` holds, where that is known before it is parsed:
    an ``.npy`` file's from its header (:func:`~.files.npy_rows`), a CSV file's from its lines
    of numbers, counted up to ``most + 1`` (:func:`~.csvfile.csv_rows_at_most`). None for a
    JSON file (parsed first, within its bounds) or a file neither can read (its loader names
    what is wrong)."""
    try:
        p = resolve_task_path(path)
        if not p.is_file():
            return None
        if p.suffix.lower() == ".npy":
            return npy_rows(p)
        if p.suffix.lower() == ".csv":
            return csv_rows_at_most(read_bytes(p), csv_header, most)
    except (ValueError, OSError):
        return None
    return None
