"""One interface for every way of answering a task: the searches and the learned PPO agent.

A :class:`Solver` maps a task (a TaskRequirement or a (t, 6) wrench array) to a
:class:`~modquad_gym.search.SearchResult` (structure, module count, configurations evaluated,
oracle calls, seconds, ...), so the command line, the benchmark and the tests treat all methods
alike. Torch and SB3 load only when a PPO solver is made (:mod:`agents.ppo`).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any, Protocol, runtime_checkable

from modquad_gym.search import SEARCHES, SearchResult

METHODS = ("exhaustive", "centrosymmetric", "greedy", "random", "ppo")
"""Names understood by :func:`make_solver`."""

DEFAULT_MODEL = Path(__file__).resolve().parents[1] / "results" / "ppo_default" / "model.zip"
"""The default PPO model shipped in the repository (its config.json lies beside it)."""


@runtime_checkable
class Solver(Protocol):
    """Anything with a ``name`` that turns a task into a verified :class:`SearchResult`."""

    name: str

    def solve(self, task: Any) -> SearchResult: ...


class SearchSolver:
    """A search of :mod:`modquad_gym.search` behind the :class:`Solver` interface."""

    def __init__(self, method: str, n_max: int = 7, seed: int = 0) -> None:
        if method not in SEARCHES:
            raise ValueError(f"unknown search {method!r}; choose one of {', '.join(SEARCHES)}")
        self.name = method
        self.n_max = n_max
        self.seed = seed
        self._fn = SEARCHES[method]

    def solve(self, task: Any) -> SearchResult:
        if self.name == "random":
            return self._fn(task, n_max=self.n_max, seed=self.seed)
        return self._fn(task, n_max=self.n_max)

    def __repr__(self) -> str:
        return f"SearchSolver({self.name!r}, n_max={self.n_max}, seed={self.seed})"


def make_solver(
    method: str,
    n_max: int = 7,
    model: str | Path | None = None,
    seed: int = 0,
    samples: int = 0,
) -> Solver:
    """The solver for ``method`` (one of :data:`METHODS`).

    ``model`` (a PPO .zip, default :data:`DEFAULT_MODEL`) and ``samples`` (extra stochastic
    rollouts, best verified structure kept) apply to ``"ppo"`` only; ``seed`` seeds the random
    search and PPO's sampled rollouts.
    """
    if method not in METHODS:
        raise ValueError(f"unknown method {method!r}; choose one of {', '.join(METHODS)}")
    if method == "ppo":
        from .ppo import PPOSolver

        return PPOSolver(model=model, n_max=n_max, seed=seed, samples=samples)
    if model is not None:
        raise ValueError(f"--model applies to method 'ppo' only, not {method!r}")
    return SearchSolver(method, n_max=n_max, seed=seed)
