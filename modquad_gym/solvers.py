"""One interface for every way of answering a task: the searches and the learned PPO agent.

A :class:`Solver` maps a task (a TaskRequirement or a (t, 6) wrench array) to a
:class:`~modquad_gym.search.SearchResult` (structure, module count, configurations evaluated,
oracle calls, seconds, ...), so the command line, the benchmark and the tests treat all methods
alike. Torch and SB3 load only when a PPO solver is made (:mod:`modquad_gym.policy.ppo`).
"""

from __future__ import annotations

import importlib
import inspect
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
    "beam": "heuristic: beam search over growing structures (width 4, up to 64 modules)",
    "genetic": "heuristic: genetic algorithm over structures, after Su et al. 2024 (up to 64 "
    "modules)",
    "ppo": "the learned agent (the shipped model unless --model)",
    "ppo-guided": "best-first search ordered by the learned policy, certified at the lower bound",
}
"""The one table of solver names (the CLI's ``--method`` choices and help, the benchmark's
default methods): every search of :data:`modquad_gym.search.SEARCHES`, then the learned ones."""
assert list(METHOD_HELP)[: len(SEARCHES)] == list(SEARCHES)
METHODS = tuple(METHOD_HELP)
"""Names understood by :func:`make_solver` (besides the variants of the learned ones)."""
LEARNED = tuple(m for m in METHODS if m not in SEARCHES)


@runtime_checkable
class Solver(Protocol):
    """Anything with a ``name`` that turns a task into a verified :class:`SearchResult`."""

    name: str

    def solve(self, task: Any) -> SearchResult: ...


class SearchSolver:
    """A search of :mod:`modquad_gym.search` behind the :class:`Solver` interface.

    ``options`` (e.g. ``seed``, ``workers``, ``address``, ``progress``, ``time_limit``) go to the
    search where its signature takes them and are dropped otherwise, so one call site can make
    any search; ``modules`` (a list of module types) searches shapes x type assignments.
    """

    def __init__(self, method: str, n_max: int = 7, modules=None, **options: Any) -> None:
        if method not in SEARCHES:
            raise ValueError(f"unknown search {method!r}; choose one of {', '.join(SEARCHES)}")
        self.name = method
        self.n_max = n_max
        self.search = SEARCHES[method]
        takes = inspect.signature(self.search).parameters
        self.options = {k: v for k, v in options.items() if k in takes}
        if modules:
            self.options["modules"] = list(modules)

    def solve(self, task: Any) -> SearchResult:
        return self.search(task, n_max=self.n_max, **self.options)

    def __repr__(self) -> str:
        return f"SearchSolver({self.name!r}, n_max={self.n_max}, **{self.options!r})"


def make_solver(
    method: str,
    n_max: int = 7,
    model: Any = None,
    seed: int = 0,
    samples: int = 0,
    modules=None,
    guided: dict | None = None,
    **search_options: Any,
) -> Solver:
    """The one factory of solvers: ``method`` is a name of :data:`METHODS`, a variant of a
    learned one (``ppo-kN``: N sampled rollouts besides the deterministic one;
    ``ppo-guided[-bN][-wN][-nodive]``: the guided search with budget N, branching N, no dive)
    or ``package.module:Name`` (an outside agent, :func:`load_solver`).

    ``model`` (a PPO .zip, a loaded :class:`~modquad_gym.policy.policy.Policy`; default the
    shipped model) applies to the learned methods only; ``samples`` (extra stochastic rollouts)
    to ``"ppo"``; ``guided`` holds :class:`~modquad_gym.policy.guided.GuidedSolver` keywords;
    ``seed`` seeds the random search and PPO's sampled rollouts; ``modules`` (a list of module
    types) makes the searches search over shapes x type assignments and must be the palette a
    learned model was trained with; ``search_options`` go to the searches that take them
    (:class:`SearchSolver`).
    """
    if ":" in method:
        return load_solver(method, n_max=n_max)
    learned = learned_options(method)
    if learned is None:
        if method not in METHODS:
            raise ValueError(f"unknown method {method!r}; choose one of {', '.join(METHODS)}")
        if model is not None:
            raise ValueError(f"--model applies to {', '.join(LEARNED)} only, not {method!r}")
        return SearchSolver(method, n_max=n_max, modules=modules, seed=seed, **search_options)
    base, options = learned
    if search_options.get("time_limit") is not None:  # the one search option they honour
        options["time_limit"] = search_options["time_limit"]
    if base == "ppo-guided":
        from modquad_gym.policy.guided import GuidedSolver

        solver: Any = GuidedSolver(model=model, n_max=n_max, **{**(guided or {}), **options})
    else:
        from modquad_gym.policy.ppo import PPOSolver

        solver = PPOSolver(model=model, n_max=n_max, seed=seed, **{"samples": samples, **options})
    solver.policy.use_palette(modules)
    if method != "ppo":  # a variant keeps its full name (plain ppo with samples: ppo-kN)
        solver.name = method
    return solver


def learned_options(method: str) -> tuple[str, dict] | None:
    """(learned method, its keywords) of a learned method name or variant (see
    :func:`make_solver`); None for any other name; ValueError for a malformed variant."""
    if method.startswith("ppo-k"):
        k = method[len("ppo-k") :]
        if not k.isdigit():
            raise ValueError(f"bad method {method!r}; write ppo-kN with N an integer")
        return "ppo", {"samples": int(k)}
    if method == "ppo-guided" or method.startswith("ppo-guided-"):
        return "ppo-guided", guided_options(method)
    return (method, {}) if method in LEARNED else None


def guided_options(method: str) -> dict:
    """GuidedSolver keywords from ``ppo-guided[-bN][-wN][-nodive]`` (see :func:`make_solver`)."""
    options: dict = {}
    for part in method[len("ppo-guided") :].split("-")[1:]:
        if part == "nodive":
            options["dive"] = False
        elif part[:1] in ("b", "w") and part[1:].isdigit() and int(part[1:]) > 0:
            options["budget" if part[0] == "b" else "branching"] = int(part[1:])
        else:
            raise ValueError(
                f"bad method {method!r}: write ppo-guided with -bN (budget), -wN (branching) "
                "or -nodive, N a positive integer"
            )
    return options


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
        try:
            answer = fn(task)
        except Exception as exc:  # the agent's own failure, named in one line
            raise ValueError(
                f"solver {self.name!r} failed on task {getattr(task, 'name', task)!r}: "
                f"{type(exc).__name__}: {exc}"
            ) from exc
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
    if module_name.split(".")[0] in sys.stdlib_module_names:  # os:system is not an agent
        raise ValueError(f"--solver {spec!r}: {module_name} is a standard-library module")
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
