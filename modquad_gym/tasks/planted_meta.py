"""A planted task's answer in ``meta``, and how a task holds it where a failure is required.

A planted task (:class:`~.generators.PlantedTasks`, :class:`~.generators.PlantedMixedTasks`,
the scale families) keeps its hidden structure and that structure's module count in ``meta``
(:data:`PLANTED_KEYS`). That structure satisfies the task intact: with a ``fault`` (a wrench
counts only when it survives any failure of a kind) it need not succeed, and its count is no
bound on the tolerant optimum (often larger). :func:`fault_meta` renames the keys ``intact_*``
there, so no key called ``optimum_upper_bound`` is offered where it is not one.
"""

from __future__ import annotations

from typing import Any

PLANTED_KEYS = ("planted_cells", "hidden_cells", "hidden_modules", "optimum_upper_bound")
"""The ``meta`` keys of a planted answer: the hidden structure (cells, module types) and its
count."""


def fault_meta(task: Any, fault: str | None) -> Any:
    """``task`` as it is held under ``fault``: without a fault, or without a planted answer,
    ``task`` itself; with both, a copy (:meth:`relabelled`: the same wrenches, name and kind)
    whose :data:`PLANTED_KEYS` are renamed ``intact_*``."""
    meta = task.meta
    if fault is None or not any(key in meta for key in PLANTED_KEYS):
        return task
    renamed = {(f"intact_{k}" if k in PLANTED_KEYS else k): v for k, v in meta.items()}
    return task.relabelled(task.name, renamed)
