"""Policy-guided search: best-first over dockings, ordered by a trained policy, decided exactly.

A node is a docking sequence from the single module at (0, 0) (one root per start type with
several module types); its priority is the sum of ``-log pi(a | s)`` along the sequence, so the
policy's favourite structures come first, after the dives: ``ppo``'s own episodes
(:meth:`~.ppo.PPOSolver.deterministic`, with its extra fallbacks' branches, from each start
type; below :data:`~.models.SCALE_FROM` modules the policy's own pass from the first, and
``ppo``'s passes from each last, where the search ends uncertified), so the search never does
worse than ``ppo``. A node keeps its parent's
environment state (:meth:`~modquad_gym.envs.assembly.env.ModQuadAssemblyEnv.restore`): popping
it docks one module, whose structure the environment's exact oracle decides. The search stops with a
certificate as soon as it finds a feasible structure whose module count equals an exact lower
bound (the force bound and the level bounds of :mod:`modquad_gym.search.bounds`; the count
bound of the typed search with several types); otherwise it
returns the smallest feasible structure found within its budget of evaluated structures (from
:data:`~.models.SCALE_FROM` modules, a number per module of the dives' answer, so that its time
grows with the structure as beam's does, within :data:`~.models.QUEUE_MEMORY` of queued states).
"""

from __future__ import annotations

import dataclasses
import heapq
import importlib.util
from functools import partial
from typing import Any

import numpy as np

from modquad_gym.core.compile_clock import compile_seconds, now
from modquad_gym.geometry.structure import Structure, normalise, normalise_typed
from modquad_gym.policy.inference import exported
from modquad_gym.policy.models import (
    BUDGET_PER_MODULE,
    GUIDED_BUDGET,
    LEARNED_CHECKS,
    MODEL_TOP_K,
    QUEUE_MEMORY,
    SCALE_FROM,
    check_learned,
    default_model,
)
from modquad_gym.policy.policy import Policy, acting_palette, fallback_of, search_result
from modquad_gym.policy.ppo import PPOSolver
from modquad_gym.search import SearchResult, verified
from modquad_gym.search.bounds import bound_levels
from modquad_gym.tasks import as_task


class GuidedSolver:
    """Best-first search over dockings ordered by a trained policy (see the module doc).

    Args:
        model: a :class:`~.policy.Policy`, a model .zip path (default the shipped model) or a
            loaded MaskablePPO.
        n_max: as for :class:`~.policy.Policy`.
        config: as for :class:`~.policy.Policy`.
        budget: most structures to evaluate per task (None: :data:`~.models.GUIDED_BUDGET`
            below :data:`~.models.SCALE_FROM` modules, else :data:`~.models.BUDGET_PER_MODULE`
            per module the first start type's dives reach, or of n_max without a dive, at least
            :data:`~.models.GUIDED_BUDGET` and at most as many states as fit in
            :data:`~.models.QUEUE_MEMORY`); below :data:`~.models.SCALE_FROM` modules ``ppo``'s
            closing passes come on top.
        branching: children queued per expanded structure (the policy's most likely dockings).
        dive: start with ``ppo``'s episodes (default True; the module doc);
            False: best-first only.
        time_limit: seconds after which the search stops with what it has (None: none; 60 s by
            :func:`~modquad_gym.solvers.make_solver` and the command line), in the dives too
            (which otherwise finish, whatever the budget).
        top_k: as for :class:`~.policy.Policy` (the children decided exactly per step;
            default the model's own, :data:`~.models.MODEL_TOP_K`), unless ``model`` is a
            Policy.
        fallback: as for :class:`~.ppo.PPOSolver`: the dives' (``ppo``'s) fallback.
        fault: design for that failure (None: none; :meth:`~.policy.Policy.use_fault`):
            every answer is verified to survive it and the bound that certifies is its own.
        fault_margin: the worst margin each task wrench must keep after the failure.
        trust_model: as for :class:`~.ppo.PPOSolver` (only for a model file you trust).

    Each option is checked by the check :func:`~modquad_gym.solvers.make_solver` uses
    (:data:`~.models.LEARNED_CHECKS`), with the same words.
    """

    def __init__(
        self,
        model: Any = None,
        n_max: int | None = 7,
        budget: int | None = None,
        branching: int = 4,
        config: dict | None = None,
        dive: bool = True,
        time_limit: float | None = None,
        top_k: int | str | None = MODEL_TOP_K,
        fallback: float | None = None,
        fault: str | None = None,
        fault_margin: float = 0.0,
        trust_model: bool = False,
    ) -> None:
        self.dive = LEARNED_CHECKS["dive"](dive, "dive")
        self.budget = check_learned("budget", budget)
        self.branching = LEARNED_CHECKS["branching"](branching, "branching")
        self.time_limit = check_learned("time_limit", time_limit)
        if not isinstance(model, Policy):
            model = Policy(check_learned("model", model), n_max, config, top_k, trust_model)
        self.policy = model
        self.fault = (fault, fault_margin)
        self.policy.use_fault(*self.fault)
        self.fallback = fallback_of(self.policy, fallback)
        self.n_max = self.policy.n_max
        self.name = "ppo-guided"
        small = self.n_max < SCALE_FROM  # ppo's passes there: the dive's, then the closing ones
        self.single = PPOSolver(self.policy, fallback=self.fallback, fault=fault,
                                fault_margin=fault_margin,
                                extra_fallbacks=() if small else None)  # fmt: skip
        self.closing = (PPOSolver(self.policy, fallback=self.fallback, fault=fault,
                                  fault_margin=fault_margin) if small else None)  # fmt: skip

    def solve(self, task: Any) -> SearchResult:
        t0, compiled = now(), compile_seconds()  # see search_result
        task = as_task(task)
        self.policy.use_fault(*self.fault)  # a Policy shared with another solver may differ
        problem = self.policy.problem(task)
        bound = bound_levels(problem)
        deadline = t0 + self.time_limit if self.time_limit is not None else float("inf")
        run = Run(self, problem, bound, deadline)
        if bound <= self.n_max:  # else every level is ruled out: proven infeasible
            run.dive()
            run.search()
            run.close()
        best = run.best
        certified = best is not None and best.n_modules <= bound or bound > self.n_max
        if not certified:
            proof = ""
        elif best is not None:
            proof = "lower bound reached"
        else:
            proof = f"exact bounds rule out every level up to {self.n_max}"
        return search_result(self.name, problem, best, len(run.evaluated), run.oracle_calls, t0,
                             certified, proof, bound, compiled=compiled,
                             time_limit=self.time_limit)  # fmt: skip

    def budget_for(self, n: int, state_bytes: int = 0) -> int:
        """Structures to evaluate when the dive's answer (or without a dive, n_max) has ``n``
        modules and an environment state takes ``state_bytes`` (0: not known): ``budget``, else
        the default of the class docstring."""
        if self.budget is not None:
            return self.budget
        if self.n_max < SCALE_FROM:
            return GUIDED_BUDGET
        states = QUEUE_MEMORY // state_bytes if state_bytes else BUDGET_PER_MODULE * n
        return max(GUIDED_BUDGET, min(BUDGET_PER_MODULE * n, states))

    def __repr__(self) -> str:
        return (
            f"GuidedSolver(model={self.policy.model_path!r}, n_max={self.n_max}, "
            f"budget={self.budget}, branching={self.branching}, dive={self.dive})"
        )


class Run:
    """One guided search on a problem: ``ppo``'s episodes as incumbents (:meth:`dive`),
    then best-first over the queue their states left (:meth:`search`).

    A node of the queue is (priority, tie-break, parent state or None for a root, action or
    start type, its structure's key or None for a root): each structure is queued once."""

    def __init__(self, solver: GuidedSolver, problem: Any, bound: int, deadline: float):
        self.solver, self.policy, self.problem = solver, solver.policy, problem
        self.bound, self.deadline = bound, deadline
        self.best: Structure | None = None
        self.evaluated: set = set()
        self.queued: set = set()
        self.costs: dict = {}  # key -> priority of the structures the dives docked
        self.heap = [(0.0, i, None, start, None) for i, start in enumerate(self.policy.starts)]
        self.pushes, self.oracle_calls = len(self.heap), 0
        self.budget = solver.budget_for(solver.n_max)
        self.state_bytes = 0

    def dive(self) -> None:
        """``ppo``'s deterministic episodes (:meth:`~.ppo.PPOSolver.deterministic`,
        with its fallbacks' branches: the plain ``ppo`` answer), from the first start type;
        from :data:`~.models.SCALE_FROM` modules from each, as ``ppo`` decodes (their
        roots leave the queue). Each state they dock from queues its other likely dockings;
        the budget follows the size the first start's episodes reach."""
        solver = self.solver
        if not solver.dive:
            return
        roots = self.heap if solver.n_max >= SCALE_FROM else self.heap[:1]
        self.heap = self.heap[len(roots) :]
        for i, (*_, start, _) in enumerate(roots):
            leading = [0]
            visit = partial(self.visit, leading if i == 0 else None)
            self.best, calls = solver.single.deterministic(
                self.problem, start, self.best, self.evaluated, self.deadline, visit, self.bound
            )
            self.oracle_calls += calls
            if i == 0:
                self.budget = solver.budget_for(leading[0] or solver.n_max, self.state_bytes)
            if self.certified:
                return

    @property
    def certified(self) -> bool:
        return self.best is not None and self.best.n_modules <= self.bound

    def visit(self, leading: list | None, probs: np.ndarray, action: int) -> None:
        """At a state a dive docks ``action`` from: queue its other likely dockings (the
        first start's dives record their largest size in ``leading``)."""
        env = self.policy.env
        if not self.state_bytes:  # a state's size, known from the first structure on
            self.state_bytes = nbytes(env.state)
        n = env.structure.n_modules
        if leading is not None:
            leading[0] = max(leading[0], n + 1)
            budget = self.solver.budget_for(leading[0], self.state_bytes)
        else:
            budget = self.budget
        self.expand(probs, self.costs.get(env.structure.key, 0.0), budget, action)

    def expand(self, probs: np.ndarray, cost: float, budget: int, lead: int = -1) -> None:
        """Queue the most likely dockings of the environment's state (``probs``: the policy's
        probabilities there; ``cost``: its priority) while fewer than ``budget`` structures
        are evaluated; ``lead`` (a dive's next docking) is not queued: the dive docks it."""
        env, s = self.policy.env, self.policy.env.structure
        order = np.argsort(-probs, kind="stable")[: self.solver.branching]
        if lead >= 0:
            key = child_key(s, env.grid.cell_of(lead), env.grid.type_of(lead), env)
            self.queued.add(key)
            self.costs.setdefault(key, cost + _surprise(probs[lead]))
            order = [a for a in order if a != lead][: self.solver.branching - 1]
        state = env.state
        for a in order:
            if probs[a] <= 0.0:
                break
            key = child_key(s, env.grid.cell_of(a), env.grid.type_of(a), env)
            if key in self.queued:
                continue
            self.queued.add(key)
            if len(self.evaluated) < budget:  # else never popped: keep no state for it
                node = (cost + _surprise(probs[a]), self.pushes, state, int(a), key)
                heapq.heappush(self.heap, node)
                self.pushes += 1

    def close(self) -> None:
        """Below :data:`~.models.SCALE_FROM` modules, where the search ends uncertified:
        ``ppo``'s passes from each start type, as ``ppo`` decodes (from the first, its extra
        ones branch off the dive's), so that the answer is never above ``ppo``'s. They run
        after the search, not in the dive, where their structures would take the small
        budget's place."""
        closing = self.solver.closing
        if closing is None or self.certified or not self.solver.dive:
            return
        for start in self.policy.starts:
            self.best, calls = closing.deterministic(
                self.problem, start, self.best, self.evaluated, self.deadline, bound=self.bound
            )
            self.oracle_calls += calls

    def search(self) -> None:
        """Best-first over the queue until a structure reaches the bound, the budget of
        evaluated structures is spent, or the time is up."""
        policy, env, solver = self.policy, self.policy.env, self.solver
        while not self.certified and self.heap and len(self.evaluated) < self.budget:
            if now() > self.deadline:
                break
            cost, _, parent, move, key = heapq.heappop(self.heap)
            if key in self.evaluated:  # a dive docked it and queued its dockings
                continue
            if parent is None:
                obs, info = policy.reset(self.problem.task, move)
                self.oracle_calls += int(info["oracle_calls"])
            else:
                env.restore(parent)
                obs, _, _, _, info = env.step(move)
                self.oracle_calls += int(info["oracle_calls"]) - parent.oracle_calls
            s = env.structure
            n = s.n_modules
            self.evaluated.add(s.key)
            if not self.state_bytes:
                self.state_bytes = nbytes(env.state)
                self.budget = solver.budget_for(solver.n_max, self.state_bytes)
            if info["success"]:
                if (self.best is None or n < self.best.n_modules) and verified(s, self.problem):
                    self.best = s
                continue  # a larger structure containing it cannot be smaller
            if n >= solver.n_max or (self.best is not None and n + 1 >= self.best.n_modules):
                continue
            self.expand(policy.probabilities(obs, env.action_masks()), cost, self.budget)


def _surprise(p: float) -> float:
    """-log p: a docking's share of a node's priority (inf for an impossible one)."""
    return -float(np.log(p)) if p > 0.0 else float("inf")


def nbytes(state: Any) -> int:
    """Bytes of the arrays an environment state holds (its task's included)."""
    total = 0
    for field in dataclasses.fields(state):
        value = getattr(state, field.name)
        if isinstance(value, np.ndarray):
            total += value.nbytes
        elif dataclasses.is_dataclass(value):
            total += nbytes(value)
    return total


def child_key(s: Structure, cell: tuple, type_index: int, env: Any) -> Any:
    """The translation-normalised key of ``s`` with a module of ``type_index`` at ``cell`` (the
    type from ``env``'s palette when it has several)."""
    palette = getattr(env, "palette", None)
    if palette is None:
        return normalise([*s.cells, cell])
    return normalise_typed([*s.cells, cell], [*s.modules, palette[type_index]])


def producers_with_policy() -> tuple:
    """The anytime search's incumbent producers on workers (:mod:`modquad_gym.search.portfolio`):
    the field's heuristics, then the shipped policy's guided search when it can act: its
    models' NumPy actors are fresh (:mod:`.inference`) or its extra (torch, sb3-contrib) is
    installed."""
    from modquad_gym.search.portfolio import HEURISTICS

    models = (default_model(), default_model(SCALE_FROM))
    extra = all(importlib.util.find_spec(m) is not None for m in ("torch", "sb3_contrib"))
    if extra or all(exported(m) is not None for m in models):
        return (*HEURISTICS, guided_producer)
    return HEURISTICS


def guided_producer(problem, time_limit: float, seed: int | None = 0) -> SearchResult | None:
    """The shipped policy's guided search on a search problem, for at most ``time_limit``
    seconds, with :data:`~.models.GUIDED_BUDGET` structures at any size (an incumbent for the
    anytime search, whose own time goes to its exact levels and local moves); None where the
    default model is not trained for the problem: a fault (the learned methods take it
    themselves, with the fault tier's model), a dynamic task, or one module type other than the
    T-module."""
    from modquad_gym.search.problem import DEFAULT_MODULE

    task = problem.task
    if problem.fault is not None or task is None or task.per_structure:
        return None
    if not problem.typed and problem.palette[0].digest != DEFAULT_MODULE.digest:
        return None
    palette = acting_palette(problem)  # self-weight through a module set, one type too
    model = default_model(problem.n_max, palette)
    solver = GuidedSolver(model=model, n_max=problem.n_max, budget=GUIDED_BUDGET,
                          time_limit=time_limit)  # fmt: skip
    if palette is not None:
        solver.policy.use_palette(palette)
    return solver.solve(task)
