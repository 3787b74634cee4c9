"""Where PPO fine-tuning trains: fresh training tasks, and a share of tasks the cloned policy
does not solve optimally.

After cloning, the policy is already optimal on most fresh tasks (about 87 % on the current
tier), so most PPO episodes repeat what it knows and the advantages there are noise. Before PPO,
:func:`missed_tasks` lets the cloned policy play ``focus_tasks`` fresh training tasks (drawn
from ``default_rng([seed, 3])``: never validation or held-out tasks) and keeps those where its
greedy episode fails or uses more modules than the certified optimum; :class:`FocusedTasks` then
draws ``focus_percent`` % of the PPO episodes from them and the rest fresh from the generator,
so PPO's own episodes land where the cloned policy is wrong.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any

import numpy as np

from agents.validation import episode_optimal
from modquad_gym.search import exhaustive_search


def missed_tasks(
    policy: Any, env: Any, tasks: Sequence[Any], n_max: int, modules: Any = None,
    progress: bool = False,
) -> list:  # fmt: skip
    """The tasks on which ``policy``'s deterministic episode in ``env`` (an assembly env) is not
    optimal (:func:`~agents.validation.episode_optimal` against the certified search)."""
    kwargs = {"modules": list(modules)} if modules else {}
    kwargs |= {"fault": env.fault} if getattr(env, "fault", None) is not None else {}
    missed = []
    iterator = tasks
    if progress:
        from tqdm.auto import tqdm

        iterator = tqdm(tasks, desc="cloned policy on fresh tasks", unit="task")
    for task in iterator:
        obs, _ = env.reset(options={"task": task})
        done, info = False, {}
        while not done:
            action, _ = policy.predict(obs, action_masks=env.action_masks(), deterministic=True)
            obs, _, terminated, truncated, info = env.step(int(action))
            done = terminated or truncated
        optimum = exhaustive_search(task, n_max=n_max, **kwargs).n_modules
        if not episode_optimal(info, optimum):
            missed.append(task)
    return missed


class FocusedTasks:
    """A task generator for PPO: with probability ``percent`` / 100 one of ``missed`` (drawn
    with the env's rng), else a fresh task of ``generator``."""

    def __init__(self, generator: Callable, missed: Sequence[Any], percent: int,
                 name: str = "focused") -> None:  # fmt: skip
        self.generator = generator
        self.missed = list(missed)
        self.p = percent / 100 if self.missed else 0.0
        self.name = name

    def __call__(self, rng: np.random.Generator) -> Any:
        if self.p and rng.random() < self.p:
            return self.missed[int(rng.integers(len(self.missed)))]
        return self.generator(rng)
