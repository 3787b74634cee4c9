"""Someone else's agent scored like every method: the problem it is handed, the counted
evaluator it decides structures with, and how it is loaded from ``package.module:Name``."""

from __future__ import annotations

import importlib
import inspect
import sys
import time
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import numpy as np

from modquad_gym.core.interrupts import failure_line
from modquad_gym.geometry.structure import Structure
from modquad_gym.search import SearchResult
from modquad_gym.search.problem import SearchProblem
from modquad_gym.solvers.answers import (
    NotAllowedError,
    admissible,
    conform,
    decided_before,
    handed,
    rebuilt,
    reported_count,
)
from modquad_gym.solvers.problems import problem_for

__all__ = ["Evaluator", "ExternalSolver", "admissible", "conform", "load_solver"]

AGENT_ERRORS = (Exception, SystemExit)
"""What an outside agent's own code may raise while it is imported, made or asked to solve:
reported as one line naming it (``sys.exit`` in an agent must not end the benchmark silently);
Ctrl-C and SIGTERM still stop the command."""


class Evaluator:
    """The problem's exact decision, counted: what an outside agent is handed.

    ``modquad score --solver pkg:Agent`` makes one per task and passes it to the agent's
    ``solve(problem, evaluator)``; every configuration the agent decides through it is counted,
    so outside agents are charged for what they ask through it (a lower bound: an agent may
    decide structures by other means). It holds the problem without the task's ``meta`` (a
    held-out task's optimum and planted cells), and nothing else of the task.

    Args:
        problem: a :class:`SearchProblem`, or a task (a TaskRequirement, a DynamicTask, a (t, 6)
            wrench array) made into one with ``n_max`` and ``modules``.
        n_max: the tier's module budget: a structure of more modules is refused (ValueError).
        tier: the tier's name (``current``, ``large``, ``mixed``, ``dynamic``), or None.
        modules: the module types a structure may use (the tier's palette); default one type,
            ``TModule()``. A structure of another type is refused (ValueError).

    Attributes:
        evaluated: distinct configurations decided (a structure asked again is answered from
            memory and not counted again; structures are the same up to translation).
        oracle_calls: wrench-structure tests made (one per task wrench of each new structure).

    Both counts are read from what it decided (read-only attributes).
    """

    def __init__(
        self, problem: Any, n_max: int = 7, tier: str | None = None, modules: list | None = None
    ) -> None:
        if not isinstance(problem, SearchProblem):
            problem = SearchProblem(problem, n_max, modules=list(modules) if modules else None)
        self.problem = problem.without_meta()
        self.n_max = problem.n_max
        self.tier = tier
        self.modules = list(problem.palette)
        self.f_max = problem.f_max
        self._decided: dict[Any, np.ndarray] = {}

    @property
    def evaluated(self) -> int:
        """Distinct configurations decided."""
        return len(self._decided)

    @property
    def oracle_calls(self) -> int:
        """Wrench-structure tests made (one per task wrench of each structure decided)."""
        return sum(len(d) for d in self._decided.values())

    @property
    def task(self) -> Any:
        """The problem's task, without its ``meta``."""
        return self.problem.task

    def structure(self, structure: Any) -> Structure:
        """``structure`` (a Structure, or a list of (x, y) cells of the first module type) on
        the allowed types (:func:`conform`); ValueError beyond n_max or off the types."""
        return conform(structure, self.n_max, self.modules)

    def feasible(self, structure: Any) -> np.ndarray:
        """Bool (t,): can ``structure`` exert each wrench of the task (its own weight added
        for self-weight tasks; its own mass and inertia for dynamic ones; after every failure
        of the problem's ``fault``)? The problem's exact decision
        (:meth:`SearchProblem.decide`); counted on the first ask of each structure."""
        s = self.structure(structure)
        if s not in self._decided:  # one test per rotor wrench of this structure
            self._decided[s] = np.asarray(self.problem.decide(s), dtype=bool)
        return self._decided[s].copy()

    def evaluate(self, structure: Any) -> bool:
        """Can ``structure`` exert every wrench of the task? (:meth:`feasible`, all of them.)"""
        return bool(self.feasible(structure).all())

    def seen(self, structure: Any) -> bool:
        """Has ``structure`` been decided through this evaluator?"""
        return self.structure(structure) in self._decided


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

    Per task the agent gets the :class:`SearchProblem` (a deep copy of the task without its
    ``meta``, named ``task-<k>`` for the k-th task this solver is handed; the tier's ``n_max``,
    module types and ``fault``) and, when its ``solve`` (or the function itself) takes a second
    argument or one named ``evaluator``, an :class:`Evaluator`: the problem's exact decision,
    which counts every configuration decided. It may return a :class:`SearchResult`, a
    :class:`~modquad_gym.geometry.Structure`, a list of (x, y) cells or None (no answer). The
    answer is rebuilt from its integer cells on the tier's own module types
    (:func:`~modquad_gym.solvers.answers.rebuilt`: none of its methods is called); one of a
    type off the tier's is no answer. ``evaluated`` and ``oracle_calls`` are the evaluator's
    counts (an answer not decided through it counts as one more configuration, and its wrench
    tests when within n_max), or the agent's own report (a SearchResult's, or its attributes)
    where that is larger. Seconds are timed here. The benchmark verifies every answer with its
    own copy of the task and counts one beyond n_max as a failure.
    """

    def __init__(
        self,
        agent: Any,
        name: str,
        n_max: int = 7,
        tier: str | None = None,
        modules=None,
        fault: str | None = None,
        takes_seed: bool = False,
    ) -> None:
        self.agent = agent
        self.takes_seed = takes_seed  # its constructor was told the run's seed
        self.name = name
        self.n_max = n_max
        self.tier = tier
        self.modules = list(modules) if modules else None
        self.fault = fault
        self._handed = 0  # tasks handed out so far: the next is named task-<this + 1>

    def _own(self, task: Any) -> SearchProblem:
        """The scorer's problem of ``task`` (never handed out): ``task``'s own when it is one
        (refused where it says otherwise than the budget, types or fault this solver was given,
        :func:`~modquad_gym.solvers.problems.problem_for`), else ``task`` with them."""
        settings = {"n_max": self.n_max, "modules": self.modules, "fault": self.fault}
        return problem_for(task, settings)

    def problem(self, task: Any, name: str = "task") -> SearchProblem:
        """The problem handed to the agent: a deep copy of the problem of ``task``, named
        ``name``, without the task's ``meta`` (:func:`~modquad_gym.solvers.answers.handed`)."""
        return handed(self._own(task), name)

    def evaluator(self, task: Any) -> Evaluator:
        """A fresh counted evaluator for ``task`` with this solver's budget and types."""
        return Evaluator(self.problem(task), tier=self.tier)

    def solve(self, task: Any) -> SearchResult:
        own = self._own(task)
        self._handed += 1
        given = handed(own, f"task-{self._handed}")
        evaluator = Evaluator(given, tier=self.tier)
        decided = evaluator._decided  # counted from here, not from attributes it may set
        t0 = time.perf_counter()
        answer, structure = self._ask(given, evaluator, getattr(task, "name", task))
        seconds = time.perf_counter() - t0
        plain, extra = self._answer(answer, structure, own, decided)
        source = answer if isinstance(answer, SearchResult) else self.agent
        counts = (len(decided) + extra[0], sum(len(d) for d in decided.values()) + extra[1])
        return SearchResult(
            structure=plain,
            n_modules=plain.n_modules if plain is not None else None,
            evaluated=max(counts[0], reported_count(source, "evaluated", self.name)),
            oracle_calls=max(counts[1], reported_count(source, "oracle_calls", self.name)),
            seconds=seconds,
            certified=False,
            method=self.name,
            n_max=own.n_max,
            fault=own.fault,
        )

    def _ask(self, given: SearchProblem, evaluator: Evaluator, task: Any) -> tuple[Any, Any]:
        """(the agent's answer to ``given``, the structure it holds); the agent's own failure
        is a ValueError naming it and ``task`` (the scorer's name of the task)."""
        try:
            fn = self.agent.solve if hasattr(self.agent, "solve") else self.agent
            if _second_required(fn):
                answer = fn(given, evaluator)
            elif _takes(fn, "evaluator"):
                answer = fn(given, evaluator=evaluator)
            else:
                answer = fn(given)
            structure = answer.structure if isinstance(answer, SearchResult) else answer
        except AGENT_ERRORS as exc:  # the agent's own failure (sys.exit too), in one line
            raise ValueError(
                f"solver {self.name!r} failed on task {task!r}: {type(exc).__name__}: {exc}"
            ) from exc
        return answer, structure

    def _answer(self, answer: Any, structure: Any, own: SearchProblem,
                decided: dict) -> tuple[Structure | None, tuple[int, int]]:  # fmt: skip
        """(the answer rebuilt on ``own``'s types, or None; the (configurations, oracle calls)
        it adds to what the evaluator ``decided``: none when decided there, else one
        configuration and, within n_max, one test per wrench)."""
        if structure is None:
            return None, (0, 0)
        try:
            plain = rebuilt(structure, list(own.palette))
        except NotAllowedError:  # off the tier's types: no answer, one configuration
            return None, (1, 0)
        except (TypeError, ValueError) as err:
            raise ValueError(
                f"solver {self.name!r} returned {type(answer).__name__}, not a SearchResult, "
                f"Structure, list of (x, y) cells or None: {err}"
            ) from None
        if decided_before(plain, list(decided)):
            return plain, (0, 0)
        if plain.n_modules > own.n_max:  # never decided: one configuration, no test
            return plain, (1, 0)
        return plain, (1, len(own.rotor_wrenches(plain)))


@contextmanager
def solver_named(flag: str) -> Iterator[None]:
    """A ValueError of :func:`load_solver` raised inside the block (``solver 'SPEC': ...``)
    names the command line's option ``flag`` instead (``--solver 'SPEC': ...``)."""
    try:
        yield
    except ValueError as exc:
        if not str(exc).startswith("solver "):
            raise
        raise ValueError(flag + str(exc).removeprefix("solver")) from exc


def load_solver(
    spec: str,
    n_max: int = 7,
    tier: str | None = None,
    modules=None,
    fault: str | None = None,
    seed: int | None = None,
) -> ExternalSolver:
    """The agent named ``"package.module:Name"``: a Solver instance, a class, or a function
    ``task -> answer`` (see :class:`ExternalSolver`). A class is made with the keywords among
    ``n_max``, ``tier``, ``modules`` (the module types allowed, default one type) and ``seed``
    that its constructor takes, so the agent is told the tier's budget and the run's seed. The
    module is looked up in the working folder first, as ``python -m`` does. A spec that cannot
    be made is a ValueError ``solver 'SPEC': ...`` (the command line names its option instead:
    :func:`solver_named`)."""
    if not isinstance(spec, str):
        raise ValueError(f"spec must be package.module:Name (a str), got {spec!r:.60}")
    module_name, sep, attr = spec.partition(":")
    if not sep or not module_name or not attr:
        raise ValueError(f"solver {spec!r}: write it as package.module:Name")
    if "/" in module_name or "\\" in module_name or module_name.endswith(".py"):  # not run
        raise ValueError(
            f"solver {spec!r}: a file path is not accepted; give module:Name, the module "
            "importable from the current folder (myagent:Agent for ./myagent.py)"
        )
    if module_name.split(".")[0] in sys.stdlib_module_names:  # os:system is not an agent
        raise ValueError(f"solver {spec!r}: {module_name} is a standard-library module")
    if "" not in sys.path and str(Path.cwd()) not in sys.path:
        sys.path.insert(0, str(Path.cwd()))  # like python -m: modules of the working folder
    try:
        module = importlib.import_module(module_name)
    except ImportError as err:
        raise ValueError(f"solver {spec!r}: cannot import {module_name!r}: {err}") from None
    except AGENT_ERRORS as err:  # its own code failed while it was imported
        raise ValueError(
            f"solver {spec!r}: importing {module_name} failed: {failure_line(err)}"
        ) from None
    try:
        obj = getattr(module, attr)
    except AttributeError:
        raise ValueError(f"solver {spec!r}: {module_name} has no {attr!r}") from None
    if isinstance(obj, type):
        told = {"n_max": n_max, "tier": tier, "modules": list(modules) if modules else None,
                "seed": seed}  # fmt: skip
        given = {k: v for k, v in told.items() if _takes(obj, k)}
        try:
            obj = obj(**given)
        except AGENT_ERRORS as err:  # its constructor failed, or wants what nobody passes
            raise ValueError(
                f"solver {spec!r}: making {attr}({', '.join(given)}) failed: {failure_line(err)}"
            ) from None
    if not (hasattr(obj, "solve") or callable(obj)):
        raise ValueError(f"solver {spec!r}: {attr} has no solve(task) and is not callable")
    name = str(getattr(obj, "name", attr))
    takes_seed = isinstance(getattr(module, attr), type) and _takes(getattr(module, attr), "seed")
    return ExternalSolver(obj, name=name, n_max=n_max, tier=tier, modules=modules, fault=fault,
                          takes_seed=takes_seed)  # fmt: skip
