"""Policy-guided search: best-first over dockings, ordered by a trained policy, decided exactly.

A node is a docking sequence from the single module at (0, 0) (one root per start type with
several module types); its priority is the sum of ``-log pi(a | s)`` along the sequence, so the
policy's favourite structures come first, after the policy's own greedy episode (a dive
that docks the most likely module until the episode ends: an incumbent, so the search never
does worse than the plain policy's first start; from :data:`~.models.SCALE_FROM` modules one
dive per start type, so never worse than its single pass). A node keeps its parent's
environment state (:meth:`~modquad_gym.envs.assembly.env.ModQuadAssemblyEnv.restore`): popping
it docks one module, whose structure the environment's exact oracle decides. The search stops with a
certificate as soon as it finds a feasible structure whose module count equals an exact lower
bound (the force bound and the level bounds of :mod:`modquad_gym.search.bounds`; the count
bound of the typed search with several types); otherwise it
returns the smallest feasible structure found within its budget of evaluated structures (from
:data:`~.models.SCALE_FROM` modules, a number per module of the dive's answer, so that its time
grows with the structure as beam's does, within :data:`~.models.QUEUE_MEMORY` of queued states).
"""

from __future__ import annotations

import dataclasses
import heapq
import importlib.util
import time
from typing import Any

import numpy as np

from modquad_gym.core.validation import check_int, check_real
from modquad_gym.geometry.structure import Structure, normalise, normalise_typed
from modquad_gym.policy.inference import exported
from modquad_gym.policy.models import (
    BUDGET_PER_MODULE,
    GUIDED_BUDGET,
    QUEUE_MEMORY,
    SCALE_FROM,
    TOP_K,
    default_model,
)
from modquad_gym.policy.policy import Policy, fallback_of, search_result
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
            per module of the dive's answer, or of n_max without a dive, at least
            :data:`~.models.GUIDED_BUDGET` and at most as many states as fit in
            :data:`~.models.QUEUE_MEMORY`).
        branching: children queued per expanded structure (the policy's most likely dockings).
        dive: start with the policy's greedy episode (default True; from
            :data:`~.models.SCALE_FROM` modules one per start type); False: best-first only.
        time_limit: seconds after which the search stops with what it has (None: none), in
            the dives too (which otherwise finish, whatever the budget).
        top_k: as for :class:`~.policy.Policy` (the children decided exactly per step;
            default :data:`~.models.TOP_K`), unless ``model`` is a Policy.
        fault: design for that failure (None: none; :meth:`~.policy.Policy.use_fault`):
            every answer is verified to survive it and the bound that certifies is its own.
        fault_margin: the worst margin each task wrench must keep after the failure.
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
        top_k: int | None = TOP_K,
        fallback: float | None = None,
        fault: str | None = None,
        fault_margin: float = 0.0,
    ) -> None:
        self.policy = model if isinstance(model, Policy) else Policy(model, n_max, config, top_k)
        self.fault = (fault, fault_margin)
        self.policy.use_fault(*self.fault)
        self.fallback = fallback_of(self.policy, fallback)
        self.n_max = self.policy.n_max
        self.dive = bool(dive)
        self.budget = None if budget is None else check_int(budget, "budget", low=1)
        self.branching = check_int(branching, "branching", low=1)
        self.time_limit = None if time_limit is None else check_real(time_limit, "time_limit", 0)
        self.name = "ppo-guided"

    def solve(self, task: Any) -> SearchResult:
        t0 = time.perf_counter()
        task = as_task(task)
        policy = self.policy
        policy.use_fault(*self.fault)  # a Policy shared with another solver may differ
        env = policy.env
        problem = policy.problem(task)
        bound = bound_levels(problem)
        best: Structure | None = None
        certified = bound > self.n_max  # every level ruled out: proven infeasible
        evaluated: set = set()
        queued: set = set()
        # a node: (priority, tie-break, parent state or None for a root, action or start type)
        heap: list[tuple[float, int, Any, Any]] = [
            (0.0, i, None, start) for i, start in enumerate(policy.starts)
        ]
        pushes, oracle_calls = len(heap), 0
        # the policy's episodes, incumbents: from the first start type; from SCALE_FROM modules
        # from each, as the single pass decodes (their roots then leave the queue)
        dives = [] if not self.dive else heap[:] if self.n_max >= SCALE_FROM else heap[:1]
        heap = heap[len(dives) :]
        dive, leading = (dives.pop(0) if dives else None), True
        deadline = t0 + self.time_limit if self.time_limit is not None else float("inf")
        budget, state_bytes = self.budget_for(self.n_max), 0
        while not certified and (dive or dives or heap and len(evaluated) < budget):
            if time.perf_counter() > deadline:
                break
            if dive is None and dives:  # the next start type's episode
                dive, leading = dives.pop(0), False
            cost, _, parent, move = dive if dive is not None else heapq.heappop(heap)
            diving, dive = dive is not None, None
            if parent is None:
                obs, info = policy.reset(task, move)
                oracle_calls += int(info["oracle_calls"])
            else:
                env.restore(parent)
                obs, _, _, _, info = env.step(move)
                oracle_calls += int(info["oracle_calls"]) - parent.oracle_calls
            s = env.structure
            n = s.n_modules
            evaluated.add(s.key)
            if not state_bytes:  # a state's size, known from the first structure on
                state_bytes = nbytes(env.state)
                budget = self.budget_for(self.n_max, state_bytes)
            if diving and leading:  # the budget if the first dive ends here
                budget = self.budget_for(n, state_bytes)
            if info["success"]:
                if (best is None or n < best.n_modules) and verified(s, problem):
                    best = s
                    certified = n <= bound
                continue  # a larger structure containing it cannot be smaller
            if n >= self.n_max or (best is not None and n + 1 >= best.n_modules):
                continue
            state, mask = env.state, env.action_masks()
            probs = policy.probabilities(obs, mask)
            order = np.argsort(-probs, kind="stable")[: self.branching]
            if diving and self.fallback:  # the dive is the single pass's episode
                lead = policy.decide(obs, mask, self.fallback, probs)
                order = [lead, *(a for a in order if a != lead)][: self.branching]
            for a in order:
                if probs[a] <= 0.0:
                    break
                key = child_key(s, env.grid.cell_of(a), env.grid.type_of(a), env)
                if key in queued:
                    continue
                queued.add(key)
                node = (cost - float(np.log(probs[a])), pushes, state, int(a))
                pushes += 1
                if diving and dive is None:  # the most likely child continues the dive
                    dive = node
                elif len(evaluated) < budget:  # else never popped: keep no state for it
                    heapq.heappush(heap, node)
        if not certified:
            proof = ""
        elif best is not None:
            proof = "lower bound reached"
        else:
            proof = f"exact bounds rule out every level up to {self.n_max}"
        return search_result(self.name, problem, best, len(evaluated), oracle_calls, t0,
                             certified, proof, bound)  # fmt: skip

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
    model = default_model(problem.n_max, list(problem.palette) if problem.typed else None)
    solver = GuidedSolver(model=model, n_max=problem.n_max, budget=GUIDED_BUDGET,
                          time_limit=time_limit)  # fmt: skip
    if problem.typed or problem.model.uses_mass:  # self-weight through a module set
        solver.policy.use_palette(list(problem.palette))
    return solver.solve(task)
