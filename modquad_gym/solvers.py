"""One interface for every way of answering a task: the searches and the learned PPO agent.

A :class:`Solver` maps a task (a TaskRequirement or a (t, 6) wrench array) to a
:class:`~modquad_gym.search.SearchResult` (structure, module count, configurations evaluated,
oracle calls, seconds, ...), so the command line, the benchmark and the tests treat all methods
alike. Torch and SB3 load only when a PPO solver is made (:mod:`modquad_gym.policy.ppo`).
"""

from __future__ import annotations

import importlib
import sys
import time
from pathlib import Path
from typing import Any, Protocol, runtime_checkable

from modquad_gym.geometry.structure import Structure
from modquad_gym.search import SEARCHES, SearchResult

METHOD_HELP = {
    "exhaustive": "the certified minimum (exhaustive search)",
    "centrosymmetric": "the paper's Algorithm 2",
    "greedy": "baseline: the child satisfying most wrenches",
    "random": "baseline: random dockings",
    "anytime": "the default: the exhaustive search's answer where it finishes within "
    "--time-limit, else the best structure found by local moves with its proved lower bound "
    "(up to 64 modules)",
    "ppo": "the learned agent (the shipped model unless --model)",
    "ppo-guided": "best-first search ordered by the learned policy, certified at the lower bound",
}
"""The one table of solver names (the CLI's ``--method`` choices and help, the benchmark's
default methods): every search of :data:`modquad_gym.search.SEARCHES`, then the learned ones."""
assert list(METHOD_HELP)[: len(SEARCHES)] == list(SEARCHES)
METHODS = tuple(METHOD_HELP)
"""Names understood by :func:`make_solver`."""
LEARNED = tuple(m for m in METHODS if m not in SEARCHES)


@runtime_checkable
class Solver(Protocol):
    """Anything with a ``name`` that turns a task into a verified :class:`SearchResult`."""

    name: str

    def solve(self, task: Any) -> SearchResult: ...


class SearchSolver:
    """A search of :mod:`modquad_gym.search` behind the :class:`Solver` interface."""

    def __init__(self, method: str, n_max: int = 7, seed: int = 0, modules=None) -> None:
        if method not in SEARCHES:
            raise ValueError(f"unknown search {method!r}; choose one of {', '.join(SEARCHES)}")
        self.name = method
        self.n_max = n_max
        self.seed = seed
        self._fn = SEARCHES[method]
        self._kwargs = {"modules": list(modules)} if modules else {}
        if method in ("random", "anytime"):
            self._kwargs["seed"] = seed

    def solve(self, task: Any) -> SearchResult:
        return self._fn(task, n_max=self.n_max, **self._kwargs)

    def __repr__(self) -> str:
        return f"SearchSolver({self.name!r}, n_max={self.n_max}, seed={self.seed})"


def make_solver(
    method: str,
    n_max: int = 7,
    model: str | Path | None = None,
    seed: int = 0,
    samples: int = 0,
    modules=None,
    guided: dict | None = None,
) -> Solver:
    """The solver for ``method`` (one of :data:`METHODS`).

    ``model`` (a PPO .zip, default :data:`DEFAULT_MODEL`) and ``samples`` (extra stochastic
    rollouts, best verified structure kept) apply to ``"ppo"`` only; ``seed`` seeds the random
    search and PPO's sampled rollouts; ``modules`` (a list of module types) makes the searches
    search over shapes x type assignments, and must be the palette a learned model was
    trained with; ``guided`` holds :class:`~.guided.GuidedSolver` keywords (budget, branching,
    dive) for ``"ppo-guided"``.
    """
    if method not in METHODS:
        raise ValueError(f"unknown method {method!r}; choose one of {', '.join(METHODS)}")
    if method in LEARNED:
        if method == "ppo-guided":
            from modquad_gym.policy.guided import GuidedSolver

            solver = GuidedSolver(model=model, n_max=n_max, **(guided or {}))
        else:
            from modquad_gym.policy.ppo import PPOSolver

            solver = PPOSolver(model=model, n_max=n_max, seed=seed, samples=samples)
        trained = solver.env.palette or [solver.env.module]
        same = [m.digest for m in modules or []] == [m.digest for m in trained]
        if modules and not same or not modules and len(trained) > 1:
            given = ",".join(m.name for m in modules) if modules else "one type"
            raise ValueError(
                f"--model {solver.model_path or 'given'}: trained with the module types "
                f"{','.join(m.name for m in trained)}, not {given}: give --model of one trained "
                "with them "
                "(the mixed tier's, t45,t45m,flat: modquad_gym/data/models/ppo_mixed/model.zip)"
            )
        return solver
    if model is not None:
        raise ValueError(f"--model applies to {', '.join(LEARNED)} only, not {method!r}")
    return SearchSolver(method, n_max=n_max, seed=seed, modules=modules)


class ExternalSolver:
    """Someone else's agent behind the :class:`Solver` interface.

    ``agent.solve(task)`` (or ``agent(task)`` for a plain function) may return a
    :class:`SearchResult`, a :class:`~modquad_gym.geometry.Structure`, a list of (x, y) cells,
    or None (no answer). Anything but a SearchResult is timed here and counts 0 configurations
    evaluated and 0 oracle calls unless the agent reports ``evaluated``/``oracle_calls``
    attributes. The benchmark verifies every answer with the exact oracle.
    """

    def __init__(self, agent: Any, name: str, n_max: int = 7) -> None:
        self.agent = agent
        self.name = name
        self.n_max = n_max

    def solve(self, task: Any) -> SearchResult:
        t0 = time.perf_counter()
        fn = self.agent.solve if hasattr(self.agent, "solve") else self.agent
        answer = fn(task)
        seconds = time.perf_counter() - t0
        if isinstance(answer, SearchResult):
            return answer
        structure = answer if isinstance(answer, Structure) or answer is None else None
        if structure is None and answer is not None:
            try:
                structure = Structure([tuple(c) for c in answer])
            except (TypeError, ValueError) as err:
                raise ValueError(
                    f"solver {self.name!r} returned {type(answer).__name__}, not a SearchResult, "
                    f"Structure, list of (x, y) cells or None: {err}"
                ) from None
        return SearchResult(
            structure=structure,
            n_modules=structure.n_modules if structure is not None else None,
            evaluated=int(getattr(self.agent, "evaluated", 0)),
            oracle_calls=int(getattr(self.agent, "oracle_calls", 0)),
            seconds=seconds,
            certified=False,
            method=self.name,
            n_max=self.n_max,
        )


def load_solver(spec: str, n_max: int = 7) -> Solver:
    """The agent named ``"package.module:Name"``: a Solver instance, a class made with no
    arguments, or a function ``task -> answer`` (see :class:`ExternalSolver`). The module is
    looked up in the working folder first, as ``python -m`` does."""
    module_name, sep, attr = spec.partition(":")
    if not sep or not module_name or not attr:
        raise ValueError(f"--solver {spec!r}: write it as package.module:Name")
    if "" not in sys.path and str(Path.cwd()) not in sys.path:
        sys.path.insert(0, str(Path.cwd()))  # like python -m: modules of the working folder
    try:
        module = importlib.import_module(module_name)
    except ImportError as err:
        raise ValueError(f"--solver {spec!r}: cannot import {module_name!r}: {err}") from None
    try:
        obj = getattr(module, attr)
    except AttributeError:
        raise ValueError(f"--solver {spec!r}: {module_name} has no {attr!r}") from None
    if isinstance(obj, type):
        obj = obj()
    if not (hasattr(obj, "solve") or callable(obj)):
        raise ValueError(f"--solver {spec!r}: {attr} has no solve(task) and is not callable")
    return ExternalSolver(obj, name=str(getattr(obj, "name", attr)), n_max=n_max)
