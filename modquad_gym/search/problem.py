"""One search problem: the task, the module budget, the thrust limit, the palette and the kind.

Every search (exhaustive, typed, centrosymmetric, greedy, random, anytime, beam, genetic) is a
function of a :class:`SearchProblem` and its own keyword options; :func:`search_entry` makes its
public entry point, which takes the task's arguments (``task, n_max, f_max, module, *,
modules, kind, fault``), validates them once (:meth:`SearchProblem.build`) and refuses an
option the search does not take, naming it. The limits every search shares live here:
:data:`MAX_MODULES`, :data:`EXACT_MODULES`, :data:`DEFAULT_TIME_LIMIT`.
Every kind of task is read through one interface: its ``decision_model`` (the rotor wrenches,
linear in a structure's mass and inertia), ``with_kind``, ``with_f_max`` and
``check_liftable``; :meth:`SearchProblem.rotor_wrenches` is the one place where a task becomes
the wrenches a structure's rotors must produce.
"""

from __future__ import annotations

import copy
import functools
import inspect
from collections.abc import Callable, Sequence

import numpy as np

from modquad_gym.core.validation import check_f_max, check_int, check_wrenches
from modquad_gym.geometry.cells import (  # noqa: F401 (the searches' limits, named here)
    EXACT_MODULES,
    MAX_MODULES,
)
from modquad_gym.geometry.module import ModuleType
from modquad_gym.geometry.structure import Structure
from modquad_gym.oracle import check_task_scale
from modquad_gym.oracle.faults import check_fault, check_fault_margin
from modquad_gym.search.checker import TaskChecker
from modquad_gym.search.fields import (  # noqa: F401 (the palette's names, kept here)
    DEFAULT_MODULE,
    MAX_TYPES,
    check_palette,
    says,
)
from modquad_gym.search.options import (  # noqa: F401 (the time limit's names, kept here)
    MAX_TIME_LIMIT,
    Relation,
    broken_relation,
    check_time_limit,
    checked_options,
    option_specs,
)
from modquad_gym.search.size import MAX_SEARCH_WRENCHES, check_search_size  # noqa: F401
from modquad_gym.tasks import as_task

DEFAULT_TIME_LIMIT = 60.0
"""Seconds a search takes at most by default (``modquad solve --time-limit``)."""

FAULT_BLOCK = 8
"""With a fault, the exact levels stop for the clock every this many structures (a structure
that passes the intact task is decided failure by failure: up to a tenth of a second for a
dynamic task of hundreds of samples)."""


class SearchProblem:
    """The one validated problem every solver acts on: a task and the answers it accepts.

    ``SearchProblem(task, n_max=7, f_max=None, module=None, *, modules=None, kind=None,
    fault=None)``: ``task`` anything :func:`~modquad_gym.tasks.as_task` takes (a task, anything
    with ``wrenches``, a (t, 6) wrench array); ``f_max`` and ``kind`` override the task's;
    ``module`` (one type, default the T-module) or ``modules`` (a palette); ``fault`` the
    single failure every answer must survive. Every field is checked here, once, and honoured
    by every solver it is handed to (a solver that cannot honour a field refuses the problem).
    Immutable.

    Attributes:
        wrenches: (t, 6) the task's structure-independent wrenches (its model's base; the
            problem's own copy: do not modify it).
        f_max: per-rotor thrust limit.
        n_max: the module budget: structures of 1..n_max modules are searched.
        palette: the module types, without repeats (one type for the paper's search).
        kind: the task's kind (``total``, ``external`` or ``dynamic``).
        typed: the caller gave a palette (``modules=``): results list each module's type.
        model: the task's rotor wrenches, linear in a structure's mass and inertia
            (:class:`~modquad_gym.dynamics.LinearWrenches`; a dynamic task's with repeated
            samples dropped).
        fault: None (every rotor works), ``"rotor"``, ``"module"``, ``"rotor2"`` or
            ``"rotor+module"``: a structure satisfies the task only when it still does after
            any failure of that kind (:func:`~modquad_gym.oracle.faults.tolerates`).
        fault_margin: the worst margin each task wrench must keep after the failure (0 with
            no fault; :func:`~modquad_gym.oracle.faults.fault_margin` measures it): thrust to
            spare while the controller does not yet know of the failure.
        task: the task it was built from, with the ``f_max`` and ``kind`` it was given.
    """

    __slots__ = ("wrenches", "f_max", "n_max", "palette", "kind", "typed", "model", "fault",
                 "fault_margin", "task")  # fmt: skip

    def __init__(
        self,
        task,
        n_max: int = 7,
        f_max: float | None = None,
        module: ModuleType | None = None,
        *,
        modules: Sequence[ModuleType] | None = None,
        kind: str | None = None,
        fault: str | None = None,
        fault_margin: float = 0.0,
    ) -> None:
        if isinstance(task, SearchProblem):
            raise TypeError("task is already a SearchProblem; use it as it is")
        if fault is not None:
            fault = check_fault(fault)
        fault_margin = check_fault_margin(fault_margin, fault)
        task = as_task(task).with_f_max(f_max).with_kind(kind)
        model = task.decision_model
        check_search_size(model.base, dynamic=task.per_structure)
        check_task_scale(model.base, task.f_max)  # absurd values: one clear error first
        check_task_scale(model.per_mass, task.f_max)
        n_max = check_int(n_max, "n_max", low=1)
        palette = tuple(check_palette(module, modules))
        task.check_liftable(palette)  # a payload no structure carries: refused before any work
        base = np.array(check_wrenches(model.base, allow_empty=False), dtype=float)  # a copy
        values = dict(wrenches=base, f_max=check_f_max(task.f_max), n_max=n_max,
                      palette=palette, kind=task.kind, typed=modules is not None, model=model,
                      fault=fault, fault_margin=fault_margin, task=task)  # fmt: skip
        for name, value in values.items():
            object.__setattr__(self, name, value)

    def __setattr__(self, name: str, value) -> None:
        raise AttributeError(f"a SearchProblem is immutable: {name} cannot be set")

    def __getstate__(self) -> dict:
        return {name: getattr(self, name) for name in self.__slots__}

    def __setstate__(self, state: dict) -> None:
        for name, value in state.items():
            object.__setattr__(self, name, value)

    def replace(self, **changes) -> SearchProblem:
        """A copy with some fields changed (``n_max``, ``fault``, ``fault_margin``), checked as
        at construction (no fault: no margin)."""
        unknown = sorted(set(changes) - {"n_max", "fault", "fault_margin"})
        if unknown:
            raise TypeError(
                f"SearchProblem.replace takes n_max, fault and fault_margin, not {unknown[0]!r}"
            )
        out = copy.copy(self)
        if "n_max" in changes:
            object.__setattr__(out, "n_max", check_int(changes["n_max"], "n_max", low=1))
        if "fault" in changes:
            fault = changes["fault"]
            object.__setattr__(out, "fault", None if fault is None else check_fault(fault))
            if out.fault is None:
                object.__setattr__(out, "fault_margin", 0.0)
        if "fault_margin" in changes:
            margin = check_fault_margin(changes["fault_margin"], out.fault)
            object.__setattr__(out, "fault_margin", margin)
        return out

    @classmethod
    def build(cls, task, n_max: int = 7, f_max: float | None = None,
              module: ModuleType | None = None, *, modules: Sequence[ModuleType] | None = None,
              kind: str | None = None, fault: str | None = None,
              fault_margin: float = 0.0) -> SearchProblem:  # fmt: skip
        """The same as the constructor (kept for callers of earlier versions)."""
        return cls(task, n_max, f_max, module, modules=modules, kind=kind, fault=fault,
                   fault_margin=fault_margin)  # fmt: skip

    def __repr__(self) -> str:
        types = ",".join(m.name for m in self.palette)
        fault = f", fault={self.fault!r}" if self.fault else ""
        if self.fault_margin:
            fault += f", fault_margin={self.fault_margin:g}"
        return (
            f"SearchProblem({self.task.name!r}: {len(self.wrenches)} wrenches, kind={self.kind}, "
            f"n_max={self.n_max}, f_max={self.f_max:g}, modules={types}{fault})"
        )

    @property
    def module(self) -> ModuleType:
        """The first palette type (the only one of a one-type search)."""
        return self.palette[0]

    @property
    def shape_only(self) -> bool:
        """One module type and rotor wrenches that do not depend on the structure (the
        paper's tasks): only the shapes are searched, the paper's search unchanged."""
        m = self.model
        return len(self.palette) == 1 and not m.uses_mass and not m.uses_inertia

    def rotor_wrenches(self, structure: Structure | float) -> np.ndarray:
        """What the rotors of ``structure`` must produce for the task. A mass in kg does for
        ``total`` and ``external`` tasks, and for ``dynamic`` ones whose wrenches do not
        depend on the inertia (ValueError otherwise)."""
        if isinstance(structure, Structure):
            return self.model.at(structure.mass, structure.inertia)
        return self.model.at(float(structure))

    @property
    def name(self) -> str:
        """The task's name."""
        return self.task.name

    def decide(self, structure: Structure) -> np.ndarray:
        """Bool (t,): does ``structure`` exert each of the task's rotor wrenches (with its own
        mass and inertia where the task depends on them) and, with ``fault``, still after every
        failure of that kind? Exact (the DAQP LP oracle, or the fault decision's); the decision
        every door verifies answers with (results, the evaluator of outside agents)."""
        from modquad_gym.oracle import feasible
        from modquad_gym.oracle.faults import tolerates

        W = self.rotor_wrenches(structure)
        if self.fault is None:
            return feasible(structure.configuration_matrix(), W, self.f_max, method="daqp")
        return tolerates(structure, W, self.f_max, fault=self.fault,
                         fault_margin=self.fault_margin)  # fmt: skip

    def without_meta(self) -> SearchProblem:
        """The same problem whose task carries no ``meta`` (a held-out task's certified optimum
        and planted cells): what an outside agent is handed."""
        if not getattr(self.task, "meta", None):
            return self
        task = copy.copy(self.task)
        object.__setattr__(task, "meta", {})
        out = copy.copy(self)
        object.__setattr__(out, "task", task)
        return out

    def checker(self) -> TaskChecker:
        """A fresh :class:`TaskChecker` of this problem."""
        return TaskChecker(self.model, self.f_max, self.palette, self.fault, self.fault_margin)

    def with_n_max(self, n_max: int) -> SearchProblem:
        """The same problem with another module budget."""
        return self.replace(n_max=n_max)

    def verify_reserve(self, time_limit: float) -> float:
        """Seconds kept back from ``time_limit`` for the final verification by the exact LP:
        a tenth, at most 2 s; with a fault a quarter, at most 10 s (an LP per wrench and
        failure)."""
        if self.fault is None:
            return min(0.1 * time_limit, 2.0)
        return min(0.25 * time_limit, 10.0)


class _Default(int):
    """The default budget, 7, told apart from a 7 the caller gave (a 7 given beside a problem
    of another budget is refused; the default is not)."""

    def __repr__(self) -> str:
        return "7"


DEFAULT_N_MAX = _Default(7)

TASK_PARAMETERS = tuple(
    p.replace(default=DEFAULT_N_MAX) if p.name == "n_max" else p
    for p in inspect.signature(SearchProblem.build).parameters.values()
)
"""The arguments every search's entry point takes first (those of :class:`SearchProblem`)."""
PRUNE = inspect.Parameter("prune", inspect.Parameter.KEYWORD_ONLY, default=False, annotation=bool)
"""The ``prune`` option of an entry that offers the post-pass (:mod:`~modquad_gym.search.prune`)."""

PROBLEM_FIELDS = ("n_max", "f_max", "module", "modules", "kind", "fault", "fault_margin")
"""The keywords that describe a problem: given beside a :class:`SearchProblem`, refused where
they say otherwise than it (:func:`~modquad_gym.search.fields.says`)."""


def as_problem(task, n_max=DEFAULT_N_MAX, f_max=None, module=None, *, modules=None, kind=None,
               fault=None, fault_margin=None) -> SearchProblem:  # fmt: skip
    """``task`` itself when it is a :class:`SearchProblem` (then a keyword that would change it
    is refused, a ValueError naming it; one equal to what the problem says is taken), else the
    problem of these arguments."""
    given = dict(n_max=n_max, f_max=f_max, module=module, modules=modules, kind=kind,
                 fault=fault, fault_margin=fault_margin)  # fmt: skip
    if isinstance(task, SearchProblem):
        extra = [k for k, v in given.items()
                 if v is not None and v is not DEFAULT_N_MAX and not says(task, k, v)]  # fmt: skip
        if extra:
            raise ValueError(
                f"{extra[0]}={given[extra[0]]!r} given beside a SearchProblem: the problem "
                f"already says it ({extra[0]}={getattr(task, extra[0], None)!r}); give one or "
                "the other (problem.replace(...) makes a changed copy)"
            )
        return task
    return SearchProblem(task, int(n_max) if n_max is DEFAULT_N_MAX else n_max, f_max, module,
                         modules=modules, kind=kind, fault=fault,
                         fault_margin=0.0 if fault_margin is None else fault_margin)  # fmt: skip


def search_entry(
    name: str,
    prune: Callable | None = None,
    options: dict | None = None,
    relations: tuple[Relation, ...] = (),
) -> Callable[[Callable], Callable]:
    """Decorator: the public entry point of the search ``solve(problem, **options)``.

    The entry takes a :class:`SearchProblem`, or the task's arguments (``task, n_max=7,
    f_max=None, module=None, *, modules=None, kind=None, fault=None``) from which it builds
    one (:func:`as_problem`), and then the search's own keyword options; its signature says so.
    An option the search does not take is refused with a TypeError naming it and the options
    it takes. ``entry.solve`` is the problem's function. Given ``prune(solve, problem,
    options)`` (:func:`~.prune.pruned_search`), the entry also takes ``prune=True`` and
    answers with that instead. Every option given is checked first, by the search's own check
    (``options``: ``{name: (help, check)}``) or the common one (:mod:`.options`);
    ``entry.option_specs`` holds them (the methods' options dataclasses read them). None is the
    default of an option that takes it (``seed=None``: seed 0), else refused by its check
    (:func:`~.options.checked_options`); then ``relations`` checks options against each other
    (:func:`~.options.broken_relation`: ``entry.relations``)."""
    own = options

    def wrap(solve: Callable) -> Callable:
        options = list(inspect.signature(solve).parameters.values())[1:]
        options += [PRUNE] if prune is not None else []
        names = {p.name for p in options}
        specs = option_specs(name, [p.name for p in options], own)
        defaults = {p.name: (p.annotation, p.default) for p in options}

        @functools.wraps(solve)
        def entry(task, n_max=DEFAULT_N_MAX, f_max=None, module=None, *, modules=None,
                  kind=None, fault=None, fault_margin=None, **kwargs):  # fmt: skip
            unknown = sorted(set(kwargs) - names)
            if unknown:
                raise TypeError(unknown_option(name, unknown[0], names))
            kwargs = checked_options(specs, kwargs, defaults)
            broken = broken_relation(relations, {k: d for k, (_, d) in defaults.items()} | kwargs)
            if broken is not None:
                raise ValueError(broken[2])
            problem = as_problem(task, n_max, f_max, module, modules=modules, kind=kind,
                                 fault=fault, fault_margin=fault_margin)  # fmt: skip
            if not kwargs.pop("prune", False):
                return solve(problem, **kwargs)
            return prune(solve, problem, kwargs)

        returns = inspect.signature(solve).return_annotation
        entry.__signature__ = inspect.Signature(
            [*TASK_PARAMETERS, *options], return_annotation=returns
        )
        entry.solve = solve
        entry.options = tuple(sorted(names))
        entry.prunes = prune is not None
        entry.option_specs = specs
        entry.relations = relations
        return entry

    return wrap


def unknown_option(method: str, option: str, takes) -> str:
    """The one refusal of an option a method does not take (Python and the CLI alike)."""
    listed = ", ".join(sorted(takes)) or "no options"
    return f"method {method!r} has no option {option!r}; it takes: {listed}"
