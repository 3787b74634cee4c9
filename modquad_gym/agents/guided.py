"""Policy-guided search: best-first over dockings, ordered by a trained policy, decided exactly.

A node is a docking sequence from the single module at (0, 0); its priority is the sum of
``-log pi(a | s)`` along the sequence, so the policy's favourite structures come first. Each
popped structure is decided by the environment's exact oracle. The search stops with a
certificate as soon as it finds a feasible structure whose module count equals an exact lower
bound (the force bound and the level bounds of :mod:`modquad_gym.search.bounds`); otherwise it
returns the smallest feasible structure found within its budget of evaluated structures.
"""

from __future__ import annotations

import heapq
import time
from typing import Any

import numpy as np

from modquad_gym.oracle import feasible
from modquad_gym.search import SearchResult
from modquad_gym.search.bounds import force_lower_bound, level_excluded
from modquad_gym.structure import Structure, normalise
from modquad_gym.tasks import TaskRequirement
from modquad_gym.validation import check_int

from .ppo import PPOSolver


def lower_bound(W: np.ndarray, f_max: float, module, n_max: int) -> int:
    """The smallest module count no exact bound rules out (n_max + 1 when all are)."""
    n = max(1, force_lower_bound(W, module, f_max))
    while n <= n_max and level_excluded(W, f_max, module, n):
        n += 1
    return min(n, n_max + 1)


class GuidedSolver(PPOSolver):
    """Best-first search over dockings ordered by a MaskablePPO policy (see the module doc).

    Args:
        model, n_max, config: as for :class:`~.ppo.PPOSolver`.
        budget: most structures to evaluate per task.
        branching: children queued per expanded structure (the policy's most likely dockings).
    """

    def __init__(
        self,
        model: Any = None,
        n_max: int | None = 7,
        budget: int = 64,
        branching: int = 4,
        config: dict | None = None,
    ) -> None:
        super().__init__(model=model, n_max=n_max, config=config)
        self.budget = check_int(budget, "budget", low=1)
        self.branching = check_int(branching, "branching", low=1)
        self.name = "ppo-guided"

    def _replay(self, task: TaskRequirement, actions: tuple[int, ...]) -> tuple[dict, dict]:
        """Observation and info after docking ``actions`` from the initial module."""
        obs, info = self.env.reset(options={"task": task})
        for a in actions:
            obs, _, _, _, info = self.env.step(a)
        return obs, info

    def solve(self, task: Any) -> SearchResult:
        t0 = time.perf_counter()
        if not isinstance(task, TaskRequirement):
            task = TaskRequirement(task, name="task")
        W, f_max = np.asarray(task.wrenches, dtype=float), float(task.f_max)
        bound = lower_bound(W, f_max, self.env.module, self.n_max)
        best: Structure | None = None
        certified = bound > self.n_max  # every level ruled out: proven infeasible
        evaluated: set = set()
        queued: set = {((0, 0),)}
        heap: list[tuple[float, int, tuple[int, ...]]] = [(0.0, 0, ())]
        pushes, oracle_calls = 1, 0
        while heap and not certified and len(evaluated) < self.budget:
            cost, _, actions = heapq.heappop(heap)
            obs, info = self._replay(task, actions)
            cells = [tuple(c) for c in info["cells"]]
            n = len(cells)
            evaluated.add(normalise(cells))
            oracle_calls += int(info["oracle_calls"])
            if info["success"]:
                s = Structure(cells, module=self.env.module)
                if (best is None or n < best.n_modules) and bool(
                    feasible(s.configuration_matrix(), W, f_max, method="daqp").all()
                ):
                    best = s
                    certified = n <= bound
                continue  # a larger structure containing it cannot be smaller
            if n >= self.n_max or (best is not None and n + 1 >= best.n_modules):
                continue
            mask = self.env.action_masks()
            probs = self.probabilities(obs, mask)
            for a in np.argsort(-probs, kind="stable")[: self.branching]:
                if probs[a] <= 0.0:
                    break
                key = normalise([*cells, self.env.cell_of(int(a))])
                if key in queued:
                    continue
                queued.add(key)
                heapq.heappush(heap, (cost - float(np.log(probs[a])), pushes, (*actions, int(a))))
                pushes += 1
        if not certified:
            proof = ""
        elif best is not None:
            proof = "lower bound reached"
        else:
            proof = f"exact bounds rule out every level up to {self.n_max}"
        return self._result(best, len(evaluated), oracle_calls, t0, certified, proof)

    def __repr__(self) -> str:
        return (
            f"GuidedSolver(model={self.model_path!r}, n_max={self.n_max}, budget={self.budget}, "
            f"branching={self.branching})"
        )
