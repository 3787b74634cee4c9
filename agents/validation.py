"""How a training run is judged while it learns: the optimal share on certified validation tasks.

The validation tasks (seeds ``VALIDATION_SEED0 + i``, never training or held-out tasks) carry
their certified optimum (:func:`certified_validation`). :class:`OptimalEval` (built by
:func:`optimal_eval_class`) is sb3-contrib's ``MaskableEvalCallback`` that also evaluates when
PPO starts (step 0: the cloned policy) and records, per validation task (in the tasks' order),
whether its episode ended with the optimal module count (``optimal`` in ``evaluations.npz``). The
best checkpoint is the one with the highest optimal share, then success rate, then mean return
(:func:`~modquad_gym.scoring.fine_tuning.best_index`); the run keeps it only when it solves
significantly more tasks optimally than the cloned start
(:func:`~modquad_gym.scoring.fine_tuning.kept_index`), since the best of many noisy evaluations
beats its start by luck alone.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from modquad_gym.core.extras import import_optional
from modquad_gym.scoring.fine_tuning import best_index


def certified_validation(
    n: int, source: str, n_max: int, modules: Any = None, fault: str | None = None
) -> list:
    """The first ``n`` validation tasks of ``source`` with their certified optimum within
    ``n_max`` modules in ``meta["optimum"]`` (None: no structure of up to ``n_max`` modules;
    with ``fault``, among the structures that survive it)."""
    from modquad_gym.scoring.suites import validation_tasks, with_optimum

    return [with_optimum(t, n_max, modules, fault) for t in validation_tasks(n, source)]


def episode_optimal(info: dict, optimum: int | None) -> bool:
    """Whether a finished episode is optimal: it succeeded with ``optimum`` modules, or no
    structure of up to n_max modules exists (``optimum`` None) and none could do better."""
    if optimum is None:
        return not info.get("success", False)
    return bool(info.get("success", False)) and int(info["n_modules"]) == int(optimum)


def optimal_eval_class():
    """:class:`OptimalEval`, built on first use so importing this module needs no SB3."""
    MaskableEvalCallback = import_optional(
        "sb3_contrib.common.maskable.callbacks"
    ).MaskableEvalCallback

    class OptimalEval(MaskableEvalCallback):
        """MaskableEvalCallback that also evaluates when training starts (``at_start``), records
        each validation task's optimality (``optima``: task name -> certified optimum, in the order
        ``evaluations.npz`` keeps; every evaluation plays each task once) and
        keeps as ``best_model.zip`` the evaluation :func:`best_index` picks."""

        def __init__(self, *args: Any, optima: dict, at_start: bool = True, **kwargs: Any):
            self.save_best_to = kwargs.pop("best_model_save_path", None)
            super().__init__(*args, **kwargs)
            self.optima = optima
            self.at_start = at_start
            self.evaluations_optimal: list[list[bool]] = []
            self._optimal_buffer: dict[str, bool] = {}
            self.best_evaluation = -1

        def _on_training_start(self) -> None:
            super()._on_training_start()
            if self.at_start:
                self._on_step()  # n_calls == 0: an evaluation runs

        def _log_success_callback(self, locals_: dict, globals_: dict) -> None:
            super()._log_success_callback(locals_, globals_)
            if locals_["done"]:
                info = locals_["info"]
                name = info.get("task_name")
                self._optimal_buffer[name] = episode_optimal(info, self.optima.get(name))

        def _on_step(self) -> bool:
            before = len(self.evaluations_timesteps)
            self._optimal_buffer = {}
            go_on = super()._on_step()
            if len(self.evaluations_timesteps) > before:  # one flag per task, in task order
                row = [self._optimal_buffer[name] for name in self.optima]
                self.evaluations_optimal.append(row)
                share = float(np.mean(row))
                self.logger.record("eval/optimal_share", share)
                self._save_log()
                best = best_index(self._arrays())
                if best == len(self.evaluations_timesteps) - 1 != self.best_evaluation:
                    self.best_evaluation = best
                    if self.save_best_to is not None:
                        self.model.save(Path(self.save_best_to) / "best_model")
            return go_on

        def _arrays(self) -> dict:
            arrays = {"timesteps": np.array(self.evaluations_timesteps),
                      "results": np.array(self.evaluations_results),
                      "ep_lengths": np.array(self.evaluations_length),
                      "optimal": np.array(self.evaluations_optimal)}  # fmt: skip
            if self.evaluations_successes:
                arrays["successes"] = np.array(self.evaluations_successes)
            return arrays

        def _save_log(self) -> None:
            if self.log_path is not None:
                np.savez(self.log_path, **self._arrays())

    return OptimalEval
