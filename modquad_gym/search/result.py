"""What every search shares: the result record, the run in progress, the final independent check.

Lower bounds and certificates: a search's ``lower_bound`` is a module count below which it has
*proved* that no structure satisfies the task. The proofs it may use are exact (never a
heuristic): the force and count bounds (:mod:`.bounds`: the task's forces, and for ``external``
tasks the structure's weight, need at least that many modules whatever their shape), the level
bounds (every structure of n modules has a smaller support than the task in a fixed direction)
and the exhaustive refutation of whole levels (every structure of the level decided infeasible
by the certified oracle). ``certified`` follows from it: the answer is proved.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from modquad_gym.core.compile_clock import compile_seconds, now, to_perf_counter
from modquad_gym.geometry.cells import MAX_MODULES
from modquad_gym.geometry.structure import Structure
from modquad_gym.oracle import Zonotope, feasible
from modquad_gym.oracle.faults import DecisionInterruptedError, tolerates
from modquad_gym.search.beyond import bound_beyond
from modquad_gym.search.checker import LP_ROTORS
from modquad_gym.search.status import Improvement, Status  # noqa: F401 (named here too)
from modquad_gym.tasks import as_task
from modquad_gym.tasks.wrenches import kind_entry

if TYPE_CHECKING:
    from collections.abc import Callable

    from modquad_gym.search.problem import SearchProblem


@dataclass
class SearchResult:
    """What a search found.

    Attributes:
        structure: the structure found (verified feasible), or None.
        n_modules: its module count, or None.
        evaluated: configurations evaluated (feasibility against the whole task decided).
        oracle_calls: wrench-structure membership tests made.
        seconds: wall time, less the kernels' compilation (``compile_seconds``).
        certified: the answer is proved: ``n_modules == lower_bound`` (a minimum), or no
            structure was found and ``lower_bound > n_max`` (none of up to ``n_max``
            modules exists). Derived from ``lower_bound`` when built with None; a True that
            the bound does not support is refused (ValueError).
        method: the search's name.
        n_max: the module budget searched.
        skipped_levels: module counts ruled out as a whole by exact bounds (force, level).
        proof: how infeasibility was proven without searching, when it was ("" otherwise).
        palette: names of the module types searched when the search was given ``modules``
            (then ``to_dict`` lists each module's type); empty for a one-type search.
        kind: the task kind searched (``total``, ``external`` or ``dynamic``).
        skipped: (shape, type assignment) pairs ruled out by exact bounds without being
            evaluated (force and count bounds, level bounds), in the levels visited.
        lower_bound: proved: no structure of fewer modules satisfies the task (at least 1;
            above n_max when none of up to n_max modules does, the strongest bound proved:
            :mod:`.beyond`; how each search proves it: module docstring). None at
            construction means what ``certified`` says: ``n_modules`` (or ``n_max + 1``) when
            certified, else the trivial bound 1.
        fault: the failure the structure survives (``"rotor"``, ``"module"``, ``"rotor2"``,
            ``"rotor+module"``), or None when every rotor was assumed to work.
        fault_margin: the worst margin it keeps after that failure, at least (0: none asked).
        history: how the bound and the incumbent improved over time (:class:`Improvement`,
            in order; the anytime search fills it, the others leave it empty).
        ray_start_seconds: how long the search waited for Ray's start (the anytime search's
            producers on workers, the exhaustive search's split levels), not counted in
            ``seconds`` or the time limit (0: none).
        scope: which structures an exact search searched when not all of them (``"containing
            start"``, :func:`~.exhaustive.exhaustive_search`'s ``start``): its structure is the
            proved minimum among them, or none of them satisfies the task; ``lower_bound``
            (and so ``certified`` and :attr:`status`) stays what is proved for the task.
        reach: the largest n_max its method takes (:attr:`message` suggests no more).
        compile_seconds: how long numba compiled kernels during the search (once, on a cold
            cache; :mod:`~modquad_gym.core.compile_clock`), not counted in ``seconds`` or the
            time limit (0: none).
    """

    structure: Structure | None
    n_modules: int | None
    evaluated: int
    oracle_calls: int
    seconds: float
    certified: bool | None
    method: str
    n_max: int
    skipped_levels: list[int] = field(default_factory=list)
    proof: str = ""
    palette: tuple[str, ...] = ()
    kind: str = "total"
    skipped: int = 0
    lower_bound: int | None = None
    fault: str | None = None
    fault_margin: float = 0.0
    history: tuple[Improvement, ...] = ()
    ray_start_seconds: float = 0.0
    scope: str = ""
    reach: int = MAX_MODULES
    compile_seconds: float = 0.0

    def __post_init__(self) -> None:
        if self.lower_bound is None:
            certain = self.n_modules if self.n_modules is not None else self.n_max + 1
            self.lower_bound = certain if self.certified else 1
        self.lower_bound = int(self.lower_bound)
        if self.n_modules is not None and self.lower_bound > self.n_modules:
            raise ValueError(
                f"lower_bound {self.lower_bound} exceeds the {self.n_modules} modules found"
            )
        proved = (
            self.lower_bound == self.n_modules
            if self.n_modules is not None
            else self.lower_bound > self.n_max
        )
        if self.certified and not proved:
            raise ValueError(
                f"certified needs lower_bound == n_modules, got {self.lower_bound} "
                f"and {self.n_modules}"
            )
        self.certified = proved

    @property
    def feasible(self) -> bool:
        return self.structure is not None

    @property
    def status(self) -> Status:
        """:class:`Status`: optimal, feasible, infeasible (proved) or no answer."""
        if self.structure is not None:
            return Status.OPTIMAL if self.certified else Status.FEASIBLE
        return Status.INFEASIBLE if self.certified else Status.NO_ANSWER

    @property
    def message(self) -> str:
        """One line that says what :attr:`status` means for this result (and the seconds of
        Ray's start and of compiling kernels left out of its time)."""
        return self.describe()

    def describe(self, next_step: str = "raise n_max to at least {n}") -> str:
        """:attr:`message`, with ``next_step`` (``{n}``: the proved bound) the advice of an
        infeasible answer (the command line names its option there)."""
        line = self._meaning(next_step)
        if self.ray_start_seconds:
            took = f"{self.ray_start_seconds:.1f} s"
            line += f"; Ray's start took {took}, not counted in the time limit or the seconds"
        if self.compile_seconds:
            line += (f"; compiling kernels once (cached for later runs) took "
                     f"{self.compile_seconds:.1f} s, not counted in the time limit or the "
                     "seconds")  # fmt: skip
        return line

    def proved_note(self, next_step: str = "raise n_max to at least {n}") -> str:
        """What an infeasible answer proved, in words: the bound, and ``next_step`` when the
        bound is within the method's reach."""
        n = self.lower_bound
        if self.proof.endswith("no number of modules can exert the task's forces"):
            return "proved: no number of modules can exert the task's forces"
        if n > self.reach:
            return f"proved: it needs at least {n}; {self.method} takes at most {self.reach}"
        return f"proved: it needs at least {n}; {next_step.format(n=n)}"

    def _meaning(self, next_step: str) -> str:
        status, fault = self.status, f" surviving any {self.fault} failure" if self.fault else ""
        if self.fault_margin:
            fault += f" with a margin of {self.fault_margin:g}"
        if status is Status.OPTIMAL:
            return f"{self.n_modules} modules{fault} (certified minimum)"
        among = f", the minimum among structures {self.scope}" if self.scope else ""
        if status is Status.FEASIBLE:
            return (
                f"{self.n_modules} modules{fault}{among}; proved: at least {self.lower_bound} (a "
                "smaller structure may exist)"
            )
        if status is Status.INFEASIBLE:
            return (f"no structure of up to {self.n_max} modules{fault} satisfies the task "
                    f"({self.proved_note(next_step)})")  # fmt: skip
        if self.scope:
            return (
                f"no structure {self.scope} of up to {self.n_max} modules{fault} satisfies the "
                f"task (proved among them; for the task, proved: at least {self.lower_bound})"
            )
        return (
            f"{self.method} found no structure of up to {self.n_max} modules{fault} (not a proof: "
            f"one may still exist; proved: at least {self.lower_bound})"
        )

    def certificate(self, problem: SearchProblem) -> dict:
        """The certificate of this certified answer to ``problem``: a proof that
        :mod:`modquad_gym.proofcheck` (``modquad check``) verifies (:mod:`.certificates`)."""
        from modquad_gym.search.certificates import make

        return make(self, problem)

    def to_dict(self) -> dict:
        out = {
            "cells": [list(c) for c in self.structure.cells] if self.structure else None,
            "n_modules": self.n_modules,
            "lower_bound": self.lower_bound,
            "evaluated": self.evaluated,
            "oracle_calls": self.oracle_calls,
            "feasible": self.feasible,
            "certified": self.certified,
            "status": self.status.value,
            "message": self.message,
            "seconds": self.seconds,
            "method": self.method,
            "n_max": self.n_max,
        }
        if self.palette:
            out["modules"] = (
                [m.name for m in self.structure.modules] if self.structure is not None else None
            )
        out.update(kind_entry(self.kind))  # the default kind left out, as in task files
        if self.fault is not None:
            out["fault"] = self.fault
        if self.fault_margin:
            out["fault_margin"] = self.fault_margin
        if self.proof:
            out["proof"] = self.proof
        if self.history:
            out["history"] = [event.to_dict() for event in self.history]
        if self.ray_start_seconds:
            out["ray_start_seconds"] = round(self.ray_start_seconds, 3)
        if self.scope:
            out["scope"] = self.scope
        if self.compile_seconds:
            out["compile_seconds"] = round(self.compile_seconds, 3)
        return out


class SearchRun:
    """One search in progress: its :class:`~.problem.SearchProblem`, the shared checker, the
    clock and the structures ruled out by bounds. ``finish`` re-verifies the answer with the
    exact LP and builds the result; with a fault, a structure the checker already decided
    tolerant (:attr:`~.checker.TaskChecker.confirmed`) is re-verified until
    ``verify_deadline`` at most (a search's time limit), then stands on that decision. A
    search that reports its progress calls :meth:`improve`; ``listener`` (when set) sees each
    event as it happens. ``t0`` and every deadline are times on the search clock
    (:func:`~modquad_gym.core.compile_clock.now`: kernel compilation is not the search's time)."""

    def __init__(self, method: str, problem: SearchProblem) -> None:
        self.t0, self.compiled = now(), compile_seconds()  # see finish
        self.method = method
        self.problem = problem
        self.skipped = 0
        self.checker = problem.checker()
        self.history: list[Improvement] = []
        self.listener: Callable[[Improvement], None] | None = None
        self.verify_deadline: float | None = None  # see finish
        self.time_limit: float | None = None  # a search's, from t0: finish's bound keeps it
        self.ray_start_seconds = 0.0  # left out of the clock (t0 moved past it)
        self.reach = MAX_MODULES  # the method's largest n_max: check_budget sets it

    def improve(
        self, source: str, lower_bound: int | None = None, n_modules: int | None = None
    ) -> None:
        """``source`` proved ``lower_bound`` or found a structure of ``n_modules``: an event in
        the history when the bound rose or the incumbent shrank (the first call always), so the
        history is monotone."""
        last = self.history[-1] if self.history else Improvement(0.0, 1, None, "")
        bound = max(last.lower_bound, lower_bound or 1)
        n = last.n_modules
        if n_modules is not None and (n is None or n_modules < n):
            n = n_modules
        if self.history and (bound, n) == (last.lower_bound, last.n_modules):
            return
        event = Improvement(now() - self.t0, bound, n, source)
        self.history.append(event)
        if self.listener is not None:
            self.listener(event)

    def decide(self, s: Structure) -> tuple[Zonotope, np.ndarray, np.ndarray]:
        """(zonotope of ``s``, its own rotor wrenches W, the exact decision of each: feasible,
        or tolerated when the problem has a fault), counted as one evaluated configuration and
        ``len(W)`` oracle calls (plus the LPs on failed matrices)."""
        W = self.problem.rotor_wrenches(s)
        self.checker.evaluated += 1
        A = s.configuration_matrix()
        z = Zonotope(A, self.problem.f_max)
        ok = self.checker.decide(z, W)
        if self.problem.fault is None:
            return z, W, ok
        tolerance = self.checker.tolerance(A, z)
        ok = tolerance.decide(W, self.checker.method(z))
        self.checker.oracle_calls += tolerance.tests
        if ok.all():
            self.checker.confirmed.add(self.checker.key(s))
        return z, W, ok

    def check_budget(self, limit: int, first_level: int) -> None:
        """Refuse before any work an n_max beyond ``limit``, this method's reach in bounded
        time (unless no level up to n_max is left to search)."""
        n_max, self.reach = self.problem.n_max, limit
        if n_max > limit and first_level <= n_max:
            raise ValueError(
                f"n_max={n_max} is beyond what the {self.method} search can finish: "
                f"at most {limit} modules (see `modquad solve --help`)"
            )

    def finish(
        self,
        structure: Structure | None,
        lower_bound: int,
        skipped: list[int] | tuple[int, ...] = (),
        proof: str = "",
        scope: str = "",
    ) -> SearchResult:
        """The result: ``structure`` (verified here by the exact LP) and ``lower_bound``, the
        proved bound on the module count (:class:`SearchResult`; ``scope`` as there; without a
        structure, raised by the exact bounds past n_max within the :attr:`time_limit` left:
        :mod:`.beyond`)."""
        p = self.problem
        left = None if self.time_limit is None else self.t0 + self.time_limit - now()
        if structure is None and (raised := bound_beyond(p, lower_bound, left)) > lower_bound:
            lower_bound = raised
            if self.history:  # the progress shown ends at the bound reported
                self.improve("bounds", lower_bound=raised)
        if structure is not None:
            W = p.rotor_wrenches(structure)
            if p.fault is None:
                ok = feasible(structure.configuration_matrix(), W, p.f_max, method="daqp")
            else:  # the LP per failure up to LP_ROTORS rotors, else the explicit certificates
                A = structure.configuration_matrix()
                method = "daqp" if A.shape[1] <= LP_ROTORS else "auto"
                confirmed = self.checker.key(structure) in self.checker.confirmed
                cut = None
                if confirmed and self.verify_deadline is not None:
                    cut = to_perf_counter(self.verify_deadline)
                try:
                    ok = tolerates(structure, W, p.f_max, fault=p.fault, method=method,
                                   fault_margin=p.fault_margin, deadline=cut)  # fmt: skip
                except DecisionInterruptedError:  # the checker's exact decision of it stands
                    ok = feasible(A, W, p.f_max, method="daqp")
            if not ok.all():  # never a silent success
                raise ValueError(
                    f"{self.method} search found {structure!r} but the exact LP rejects it: the "
                    "oracle's methods disagree on it (within the agreement band of the threshold, "
                    "where decisions depend on round-off: modquad_gym.oracle.tolerance)"
                )
        compiling = compile_seconds() - self.compiled  # once, on a cold cache: not the search's
        return SearchResult(
            structure=structure,
            n_modules=structure.n_modules if structure is not None else None,
            evaluated=self.checker.evaluated,
            oracle_calls=self.checker.oracle_calls,
            seconds=now() - self.t0,
            certified=None,
            method=self.method,
            n_max=p.n_max,
            skipped_levels=list(skipped),
            proof=proof,
            palette=tuple(m.name for m in p.palette) if p.typed else (),
            kind=p.kind,
            skipped=self.skipped,
            lower_bound=lower_bound,
            fault=p.fault,
            fault_margin=p.fault_margin,
            history=tuple(self.history),
            ray_start_seconds=self.ray_start_seconds,
            scope=scope,
            reach=self.reach,
            compile_seconds=compiling,
        )


def verified(structure: Structure | None, task: Any) -> bool:
    """Does ``structure`` exert every wrench of ``task`` (a TaskRequirement, its own weight
    added for external tasks; a DynamicTask, its own mass and inertia; or what
    :func:`~modquad_gym.tasks.as_task` takes, a (t, 6) wrench array)? Decided by the exact DAQP
    LP oracle. For a :class:`~.problem.SearchProblem`, its own decision
    (:meth:`~.problem.SearchProblem.decide`: with ``fault``, after every failure too). A
    ``structure`` that is neither a Structure nor None is a ValueError, so is a bad ``task``."""
    if structure is None:
        return False
    if not isinstance(structure, Structure):
        raise ValueError(f"structure must be a Structure or None, got {type(structure).__name__}")
    if hasattr(task, "decide"):
        return bool(task.decide(structure).all())
    task = as_task(task, "task")
    W = task.rotor_wrenches(structure)
    return bool(feasible(structure.configuration_matrix(), W, task.f_max, method="daqp").all())
