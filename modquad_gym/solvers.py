"""One interface for every way of answering a task: the searches and the learned PPO agent.

A :class:`Solver` maps a task (a TaskRequirement or a (t, 6) wrench array) to a
:class:`~modquad_gym.search.SearchResult` (structure, module count, configurations evaluated,
oracle calls, seconds, ...), so the command line, the benchmark and the tests treat all methods
alike. Torch and SB3 load only when a PPO solver is made (:mod:`modquad_gym.policy.ppo`).
"""

from __future__ import annotations

import copy
import importlib
import inspect
import sys
import time
from pathlib import Path
from typing import Any, Protocol, runtime_checkable

import numpy as np

from modquad_gym.geometry.structure import Structure
from modquad_gym.policy.models import default_model
from modquad_gym.search import SEARCHES, SearchResult

METHOD_HELP = {
    "exhaustive": "the certified minimum (exhaustive search)",
    "centrosymmetric": "the paper's Algorithm 2",
    "greedy": "baseline: the child satisfying most wrenches",
    "random": "baseline: random dockings",
    "anytime": "the default: the exhaustive search's answer where it finishes within "
    "--time-limit, else the best structure found by local moves with its proved lower bound "
    "(up to 128 modules)",
    "beam": "heuristic: beam search over growing structures (width 4, up to 128 modules)",
    "genetic": "heuristic: genetic algorithm over structures, after Su et al. 2024 (up to 128 "
    "modules)",
    "milp": "the mixed-integer program solved by HiGHS, level by level from its LP relaxation's "
    "bound: certified where it finishes within --time-limit (up to 128 modules; no --fault)",
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

    ``options`` (``seed``, ``engine``, ``progress``, ``time_limit``, ...) go to the search where
    it takes them, so one call site makes any search (the anytime search on an engine with Ray
    gets the policy among its producers); ``modules``: shapes x type assignments."""

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
        if method == "anytime" and getattr(self.options.get("engine"), "use_ray", False):
            from modquad_gym.policy.guided import producers_with_policy

            self.options.setdefault("producers", producers_with_policy())

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
    tier: str | None = None,
    **search_options: Any,
) -> Solver:
    """The one factory of solvers: ``method`` is a name of :data:`METHODS`, a variant of a
    learned one (``ppo-kN``: N sampled rollouts besides the deterministic one;
    ``ppo-guided[-bN][-wN][-nodive]``: the guided search with budget N, branching N, no dive)
    or ``package.module:Name`` (an outside agent, :func:`load_solver`, told ``n_max``,
    ``tier`` and ``modules``).

    ``model`` (a PPO .zip or a loaded :class:`~modquad_gym.policy.policy.Policy`; default
    :func:`~modquad_gym.policy.default_model` of the budget and palette) applies to the learned
    methods only, ``samples`` (extra stochastic rollouts) to ``"ppo"``, ``guided``
    (:class:`~modquad_gym.policy.guided.GuidedSolver` keywords) to ``ppo-guided``; ``seed``
    seeds the random search and sampled rollouts; ``modules`` (module types) makes every method
    design over shapes x type assignments; ``search_options`` go to the searches that take them."""
    if ":" in method:
        return load_solver(method, n_max=n_max, tier=tier, modules=modules)
    learned = learned_options(method)
    if learned is None:
        if method not in METHODS:
            raise ValueError(f"unknown method {method!r}; choose one of {', '.join(METHODS)}")
        if model is not None:
            raise ValueError(f"--model applies to {', '.join(LEARNED)} only, not {method!r}")
        return SearchSolver(method, n_max=n_max, modules=modules, seed=seed, **search_options)
    base, options = learned
    model = default_model(n_max, modules) if model is None else model
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


class Evaluator:
    """The exact oracle on one task, counted by the benchmark: what an outside agent is handed.

    ``modquad score --solver pkg:Agent`` makes one per task and passes it to the agent's
    ``solve(task, evaluator)``; every configuration the agent decides through it is counted,
    so outside agents are charged like the searches and the learned methods (which count the
    structures they decide themselves).

    Args:
        task: the task (a :class:`~modquad_gym.tasks.TaskRequirement`, a
            :class:`~modquad_gym.dynamics.DynamicTask`, or a (t, 6) wrench array).
        n_max: the tier's module budget: a structure of more modules is refused (ValueError).
        tier: the tier's name (``current``, ``large``, ``mixed``, ``dynamic``), or None.
        modules: the module types a structure may use (the tier's palette); default one type,
            ``TModule()``. A structure of another type is refused (ValueError).

    Attributes:
        evaluated: distinct configurations decided (a structure asked again is answered from
            memory and not counted again; structures are the same up to translation).
        oracle_calls: wrench-structure tests made (one per task wrench of each new structure).
    """

    def __init__(
        self, task: Any, n_max: int = 7, tier: str | None = None, modules: list | None = None
    ) -> None:
        from modquad_gym.tasks import TaskRequirement

        if not hasattr(task, "rotor_wrenches"):
            task = TaskRequirement(np.atleast_2d(np.asarray(task, dtype=float)))
        self.task = task
        self.n_max = int(n_max)
        self.tier = tier
        self.modules = list(modules) if modules else [Structure([(0, 0)]).module]
        self.f_max = float(task.f_max)
        self.evaluated = 0
        self.oracle_calls = 0
        self._decided: dict[Any, np.ndarray] = {}

    def structure(self, structure: Any) -> Structure:
        """``structure`` (a Structure, or a list of (x, y) cells of the first module type) on
        the allowed types (:func:`conform`); ValueError beyond n_max or off the types."""
        return conform(structure, self.n_max, self.modules)

    def feasible(self, structure: Any) -> np.ndarray:
        """Bool (t,): can ``structure`` exert each wrench of the task (its own weight added
        for self-weight tasks; its own mass and inertia for dynamic ones)? Exact (the
        certified oracle the searches use); counted on the first ask of each structure."""
        from modquad_gym.oracle import Zonotope

        s = self.structure(structure)
        if s not in self._decided:
            W = self.task.rotor_wrenches(s)
            self.evaluated += 1
            self.oracle_calls += len(W)
            ok = Zonotope(s.configuration_matrix(), self.f_max).decide_certified(W)
            self._decided[s] = np.asarray(ok, dtype=bool)
        return self._decided[s].copy()

    def evaluate(self, structure: Any) -> bool:
        """Can ``structure`` exert every wrench of the task? (:meth:`feasible`, all of them.)"""
        return bool(self.feasible(structure).all())

    def seen(self, structure: Any) -> bool:
        """Has ``structure`` been decided through this evaluator?"""
        return self.structure(structure) in self._decided


def conform(structure: Any, n_max: int, modules: list) -> Structure:
    """``structure`` (a Structure, or a list of (x, y) cells of ``modules[0]``) rebuilt on the
    allowed ``modules`` (each module mapped to the allowed type holding the same data); a
    ValueError names a structure beyond ``n_max`` modules or a type not allowed."""
    if not isinstance(structure, Structure):
        structure = Structure([tuple(c) for c in structure], module=modules[0])
    if structure.n_modules > n_max:
        raise ValueError(f"{structure.n_modules} modules exceed this tier's n_max = {n_max}")
    types = []
    for module in structure.modules:
        same = [m for m in modules if m is module or _same_type(m, module)]
        if not same:
            names = ", ".join(m.name for m in modules)
            raise ValueError(f"module type {module.name!r} is not allowed here (types: {names})")
        types.append(same[0])
    return Structure(structure.cells, modules=types)


def _same_type(a: Any, b: Any) -> bool:
    """Do two module types hold the same rotor data, mass and inertia?"""
    return all(
        np.allclose(getattr(a, k), getattr(b, k), rtol=0, atol=1e-12)
        for k in ("positions", "directions", "spins", "c_tau", "side", "mass", "inertia")
    )


def hidden(task: Any) -> Any:
    """A shallow copy of ``task`` without its ``meta`` (held-out tasks carry their certified
    optimum and planted cells there): what an outside agent is given."""
    if not hasattr(task, "meta"):
        return task
    out = copy.copy(task)
    object.__setattr__(out, "meta", {})
    return out


def _takes(fn: Any, name: str) -> bool:
    """Does ``fn`` take the keyword argument ``name`` (by its name, or through ``**kwargs``)?"""
    try:
        params = inspect.signature(fn).parameters.values()
    except (TypeError, ValueError):
        return False
    return any(p.name == name or p.kind == p.VAR_KEYWORD for p in params)


def _second_required(fn: Any) -> bool:
    """Does ``fn`` need a second positional argument (one without a default)?"""
    try:
        params = list(inspect.signature(fn).parameters.values())
    except (TypeError, ValueError):
        return False
    positional = [p for p in params if p.kind in (p.POSITIONAL_ONLY, p.POSITIONAL_OR_KEYWORD)]
    return len(positional) > 1 and positional[1].default is inspect.Parameter.empty


class ExternalSolver:
    """Someone else's agent behind the :class:`Solver` interface, scored like every method.

    Per task the agent gets the task without its ``meta`` (:func:`hidden`) and, when its
    ``solve`` (or the function itself) takes a second argument or one named ``evaluator``, an
    :class:`Evaluator`: the exact oracle on that task, with the tier's ``n_max``, ``tier`` and
    module ``types``, which counts every configuration decided. It may return a
    :class:`SearchResult`, a :class:`~modquad_gym.geometry.Structure`, a list of (x, y) cells
    or None (no answer). ``evaluated`` and ``oracle_calls`` are the evaluator's counts (an
    answer never decided counts as one more), or the agent's own report (a SearchResult's, or
    its attributes) where that is larger. Seconds are timed here.
    The benchmark verifies every answer with the exact LP oracle and counts one beyond n_max
    or off the tier's module types as a failure.
    """

    def __init__(
        self, agent: Any, name: str, n_max: int = 7, tier: str | None = None, modules=None
    ) -> None:
        self.agent = agent
        self.name = name
        self.n_max = n_max
        self.tier = tier
        self.modules = list(modules) if modules else None

    def evaluator(self, task: Any) -> Evaluator:
        """A fresh counted evaluator for ``task`` with this solver's budget and types."""
        return Evaluator(task, self.n_max, self.tier, self.modules)

    def solve(self, task: Any) -> SearchResult:
        fn = self.agent.solve if hasattr(self.agent, "solve") else self.agent
        evaluator = self.evaluator(task)
        given = hidden(task)
        t0 = time.perf_counter()
        try:
            if _second_required(fn):
                answer = fn(given, evaluator)
            elif _takes(fn, "evaluator"):
                answer = fn(given, evaluator=evaluator)
            else:
                answer = fn(given)
        except Exception as exc:  # the agent's own failure, named in one line
            raise ValueError(
                f"solver {self.name!r} failed on task {getattr(task, 'name', task)!r}: "
                f"{type(exc).__name__}: {exc}"
            ) from exc
        seconds = time.perf_counter() - t0
        structure = answer.structure if isinstance(answer, SearchResult) else answer
        if structure is not None and not isinstance(structure, Structure):
            try:
                structure = Structure([tuple(c) for c in structure])
            except (TypeError, ValueError) as err:
                raise ValueError(
                    f"solver {self.name!r} returned {type(answer).__name__}, not a SearchResult, "
                    f"Structure, list of (x, y) cells or None: {err}"
                ) from None
        if structure is not None:
            try:
                evaluator.feasible(structure)  # its answer counts, once, as every method's does
            except ValueError:
                pass  # beyond n_max or off the types: the benchmark counts it a failure
        source = answer if isinstance(answer, SearchResult) else self.agent
        return SearchResult(
            structure=structure,
            n_modules=structure.n_modules if structure is not None else None,
            evaluated=max(evaluator.evaluated, int(getattr(source, "evaluated", 0) or 0)),
            oracle_calls=max(evaluator.oracle_calls, int(getattr(source, "oracle_calls", 0) or 0)),
            seconds=seconds,
            certified=False,
            method=self.name,
            n_max=self.n_max,
        )


def admissible(structure: Structure | None, n_max: int, modules=None) -> bool:
    """Is ``structure`` within the budget (at most ``n_max`` modules) and made of the allowed
    module types (``modules``; default one type, ``TModule()``)? None is not."""
    if structure is None:
        return False
    try:
        conform(structure, n_max, list(modules) if modules else [Structure([(0, 0)]).module])
    except ValueError:
        return False
    return True


def load_solver(spec: str, n_max: int = 7, tier: str | None = None, modules=None) -> Solver:
    """The agent named ``"package.module:Name"``: a Solver instance, a class, or a function
    ``task -> answer`` (see :class:`ExternalSolver`). A class is made with the keywords among
    ``n_max``, ``tier`` and ``modules`` (the module types allowed, default one type) that its
    constructor takes, so the agent is told the tier's budget. The module is looked up in the
    working folder first, as ``python -m`` does."""
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
        told = {"n_max": n_max, "tier": tier, "modules": list(modules) if modules else None}
        obj = obj(**{k: v for k, v in told.items() if _takes(obj, k)})
    if not (hasattr(obj, "solve") or callable(obj)):
        raise ValueError(f"--solver {spec!r}: {attr} has no solve(task) and is not callable")
    name = str(getattr(obj, "name", attr))
    return ExternalSolver(obj, name=name, n_max=n_max, tier=tier, modules=modules)
