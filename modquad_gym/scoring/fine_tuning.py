"""What PPO fine-tuning did, in words read off the run's own learning curve (the report never
claims a rise the numbers do not show)."""

from __future__ import annotations

from pathlib import Path

import numpy as np


def fine_tuning_words(evals: Path, w_module: float = 0.1) -> str:
    """What PPO fine-tuning did to the validation return and success, in the numbers of the
    run's ``evaluations.npz`` (step 0: the cloned policy, when the run cloned first). A change
    below half of one module on one validation task (``w_module / n``, the reward's module
    cost) is reported as no rise: it is a partial share on a failed task, not a design."""
    data = np.load(evals)
    steps, ret = data["timesteps"], data["results"].mean(axis=1)
    has_success = "successes" in data and data["successes"].size
    success = data["successes"].mean(axis=1) if has_success else None
    if not len(steps):
        return ""
    best = int(np.argmax(ret))  # the first evaluation of the highest mean return
    n_tasks = data["results"].shape[1]
    one_module = w_module / n_tasks

    def at(i: int) -> str:
        tail = f", success {f'{100 * float(success[i]):.1f} %'}" if success is not None else ""
        return f"{ret[i]:.4f} at step {int(steps[i])}{tail}"

    start = "the cloned policy's" if steps[0] == 0 else "the first evaluation's"
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
