"""What PPO fine-tuning did, in words read off the run's own learning curve (the report never
claims a rise the numbers do not show)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np


def fine_tuning_words(evals: Path, w_module: float = 0.1) -> str:
    """What PPO fine-tuning did, in the numbers of the run's ``evaluations.npz`` (step 0: the
    cloned policy, when the run cloned first): in validation tasks solved optimally when the
    file records them (``optimal``; the kept model is the one :func:`best_index` picks),
    else in validation return, where a change below half of one module on one validation task
    (``w_module / n``, the reward's module cost) is reported as no rise: it is a partial share
    on a failed task, not a design."""
    data = np.load(evals)
    steps, ret = data["timesteps"], data["results"].mean(axis=1)
    has_success = "successes" in data and data["successes"].size
    success = data["successes"].mean(axis=1) if has_success else None
    if not len(steps):
        return ""
    n_tasks = data["results"].shape[1]
    start = "the cloned policy's" if steps[0] == 0 else "the first evaluation's"
    if "optimal" in data and data["optimal"].size:
        best = best_index(data)
        return _optimal_words(steps, data["optimal"].sum(axis=1), success, n_tasks, start, best)
    best = int(np.argmax(ret))  # the first evaluation of the highest mean return
    one_module = w_module / n_tasks

    def at(i: int) -> str:
        tail = f", success {f'{100 * float(success[i]):.1f} %'}" if success is not None else ""
        return f"{ret[i]:.4f} at step {int(steps[i])}{tail}"

    gain = ret[best] - ret[0]
    if gain < one_module / 2:
        return (
            f"PPO fine-tuning did not raise the validation return above {start} ({at(0)}) by "
            f"half a module on one of the {n_tasks} validation tasks ({one_module / 2:.4f}): "
            f"its best was {at(best)}, and it ended at {at(len(steps) - 1)} (learning curve)."
        )
    return (
        f"PPO fine-tuning raised the validation return from {start} {at(0)} to {at(best)} "
        f"({gain / one_module:.1f} modules over the {n_tasks} validation tasks) and ended at "
        f"{at(len(steps) - 1)} (learning curve); the kept model is the best."
    )


def best_index(data: Any) -> int:
    """The evaluation with the highest (optimal share, success rate, mean return), the first on
    ties; ``data``: an ``evaluations.npz`` (without ``optimal``: by mean return alone, as runs
    before the optimal share were kept)."""
    ret = np.asarray(data["results"], dtype=float).mean(axis=1)
    keys = [np.zeros_like(ret), np.zeros_like(ret), ret]
    for i, name in enumerate(("optimal", "successes")):
        if name in data and np.asarray(data[name]).size:
            keys[i] = np.asarray(data[name], dtype=float).mean(axis=1)
    rows = [tuple(np.round(k[i], 9) for k in keys) for i in range(len(ret))]
    return max(range(len(rows)), key=lambda i: (rows[i], -i))


def _optimal_words(steps, optimal, success, n_tasks: int, start: str, best: int) -> str:
    def at(i: int) -> str:
        tail = f", success {100 * float(success[i]):.1f} %" if success is not None else ""
        return f"{int(optimal[i])} of {n_tasks} optimal at step {int(steps[i])}{tail}"

    last = len(steps) - 1
    if optimal[best] <= optimal[0]:
        kept = "that first one" if best == 0 else f"step {int(steps[best])}'s (as many optimal)"
        return (
            f"PPO fine-tuning did not solve more validation tasks optimally than {start} "
            f"({at(0)}): it ended at {at(last)} (learning curve); the kept model is {kept}."
        )
    return (
        f"PPO fine-tuning raised the validation tasks solved optimally from {start} {at(0)} to "
        f"{at(best)} ({int(optimal[best] - optimal[0]):+d}) and ended at {at(last)} (learning "
        "curve); the kept model is the best validation checkpoint."
    )
