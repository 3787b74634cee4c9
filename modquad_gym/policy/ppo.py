"""Plain decoding of a trained policy: its greedy episode, plus sampled ones on request.

:class:`PPOSolver` runs the policy's most likely action until the episode ends (greedy's choice
where the policy is unsure, ``fallback``); with ``extra_fallbacks`` it also follows the
deterministic episodes of other fallbacks, as one tree that shares the dockings they agree on;
with ``samples=k`` it also runs k stochastic rollouts (seeded). It keeps the smallest verified
structure. A model trained with several module types decodes once from each start type, since a
structure is reachable only from a type it holds. ``evaluated`` counts the distinct structures
(up to translation) the rollouts evaluated, as the searches count configurations; a sampled
rollout stops as soon as it can no longer beat the best verified structure. The final structure
is always re-checked by the exact DAQP LP oracle; one that fails is reported as no structure,
never as a success.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np

from modquad_gym.core.compile_clock import compile_seconds, now
from modquad_gym.geometry.structure import Structure
from modquad_gym.policy.models import (
    EXTRA_FROM,
    LEARNED_CHECKS,
    MODEL_TOP_K,
    SCALE_FROM,
    check_learned,
    unused_seed,
)
from modquad_gym.policy.policy import (
    Policy,
    env_kwargs_of,
    extra_fallbacks_of,
    fallback_of,
    make_env,
    search_result,
)
from modquad_gym.search import SearchResult, verified
from modquad_gym.search.bounds import bound_levels
from modquad_gym.search.problem import SearchProblem
from modquad_gym.tasks import as_task

__all__ = ["PPOSolver", "env_kwargs_of", "make_env"]


class PPOSolver:
    """A trained policy's decoding behind the :class:`~modquad_gym.solvers.Solver` interface.

    Args:
        model: a :class:`~.policy.Policy`, a model .zip path (default the shipped model) or a
            loaded MaskablePPO.
        n_max: the module budget; at most the n_max the model was trained with.
        seed: seeds the sampled rollouts (refused other than 0 without them: nothing is drawn).
        samples: extra stochastic rollouts per task (0: deterministic decoding only; at most
            :data:`~.models.MAX_SAMPLES`); they stop once an answer meets the proved lower
            bound (:func:`~modquad_gym.search.bounds.bound_levels`: none can be smaller).
        config: the model's config when ``model`` is a loaded model.
        time_limit: seconds after which the rollouts stop, the first one too (None: none;
            :func:`~modquad_gym.solvers.make_solver` and the command line give 60 s unless
            told otherwise).
        top_k: as for :class:`~.policy.Policy` (the children decided exactly per step;
            default the model's own, :data:`~.models.MODEL_TOP_K`), unless ``model`` is a
            Policy.
        fallback: the deterministic rollout docks greedy's choice where the policy gives its
            own at most this probability (:meth:`~.policy.Policy.decide`; 0: never). None
            (default): :data:`~.models.FALLBACK` at budgets of :data:`~.models.SCALE_FROM`
            modules and more with a model that reads greedy's choice (the exact lookahead),
            else 0; a value above 0 for a model that does not read it is refused.
        extra_fallbacks: further deterministic rollouts, one per fallback value, branching
            from the first where their dockings differ (:func:`~.policy.extra_fallbacks_of`;
            empty: none). None (default), with a model that reads greedy's choice:
            :data:`~.models.EXTRA_FALLBACKS` where the first ends with more than
            :data:`~.models.EXTRA_FROM` modules, at budgets of :data:`~.models.SCALE_FROM`
            and more; :data:`~.models.SMALL_EXTRA_FALLBACKS` below.
        fault: design for that failure (None: none; :meth:`~.policy.Policy.use_fault`):
            every answer is verified to survive it.
        fault_margin: the worst margin each task wrench must keep after the failure.
        trust_model: load a model .zip that only unpickling reads (its policy class or
            keywords are none the package knows); a model .zip holds pickled Python objects
            that run code when loaded, so give True only for a file you trust.

    Each option is checked by the check :func:`~modquad_gym.solvers.make_solver` uses
    (:data:`~.models.LEARNED_CHECKS`), with the same words.
    """

    def __init__(
        self,
        model: Any = None,
        n_max: int | None = 7,
        seed: int = 0,
        samples: int = 0,
        config: dict | None = None,
        time_limit: float | None = None,
        top_k: int | str | None = MODEL_TOP_K,
        fallback: float | None = None,
        extra_fallbacks: Any = None,
        fault: str | None = None,
        fault_margin: float = 0.0,
        trust_model: bool = False,
    ) -> None:
        self.seed = LEARNED_CHECKS["seed"](seed, "seed")
        self.samples = LEARNED_CHECKS["samples"](samples, "samples")
        if (unused := unused_seed("ppo", self.seed, self.samples)) is not None:
            raise ValueError(f"seed={self.seed}: {unused}")
        self.time_limit = check_learned("time_limit", time_limit)
        if not isinstance(model, Policy):
            model = Policy(check_learned("model", model), n_max, config, top_k, trust_model)
        self.policy = model
        self.fault = (fault, fault_margin)
        self.policy.use_fault(*self.fault)
        self.n_max = self.policy.n_max
        self.name = "ppo" if self.samples == 0 else f"ppo-k{self.samples}"
        self.fallback = fallback_of(self.policy, fallback)
        extra = extra_fallbacks_of(self.policy, extra_fallbacks)
        self.fallbacks = (self.fallback, *(f for f in extra if f != self.fallback))
        default_at_scale = extra_fallbacks is None and self.n_max >= SCALE_FROM
        self.extra_from = EXTRA_FROM if default_at_scale else 0  # below: every size

    def solve(self, task: Any) -> SearchResult:
        """The smallest verified structure over the deterministic rollouts (one per fallback)
        and ``samples`` sampled ones (None when none verifies within ``n_max`` modules).
        ``evaluated`` counts the distinct structures (up to translation) the rollouts evaluated;
        a structure met again costs no oracle call (the environment memoises per task)."""
        t0, compiled = now(), compile_seconds()  # see search_result
        task = as_task(task)
        policy = self.policy
        policy.use_fault(*self.fault)  # a Policy shared with another solver may differ
        problem = policy.problem(task)
        starts = policy.starts
        best: Structure | None = None
        seen: set = set()
        oracle_calls = 0
        deadline = t0 + self.time_limit if self.time_limit is not None else float("inf")
        bound = bound_levels(problem)
        for start in starts:
            best, calls = self.deterministic(problem, start, best, seen, deadline, bound=bound)
            oracle_calls += calls
        for i in range(self.samples):
            rng = np.random.default_rng([self.seed, i])
            stop_at = best.n_modules if best is not None else policy.env.n_max + 2
            if stop_at <= bound or now() > deadline:  # at the bound: none smaller
                break
            info = policy.rollout(problem.task, rng, seen, stop_at, starts[i % len(starts)],
                                  deadline)  # fmt: skip
            oracle_calls += int(info["oracle_calls"])
            best = self.better(problem, info, best)
        certified = (
            best is not None and best.n_modules == bound or best is None and bound > self.n_max
        )
        proof = "lower bound reached" if certified else ""
        return search_result(self.name, problem, best, len(seen), oracle_calls, t0, certified,
                             proof, bound, compiled=compiled,
                             time_limit=self.time_limit)  # fmt: skip

    def deterministic(
        self,
        problem: SearchProblem,
        start: int | None,
        best: Structure | None,
        seen: set,
        deadline: float,
        visit: Callable[[np.ndarray, int], None] | None = None,
        bound: int = 1,
    ) -> tuple[Structure | None, int]:
        """The deterministic rollouts on ``problem``'s task from a first module of type
        ``start``, one per fallback of :attr:`fallbacks`, as one tree: a branch leaves where its
        fallback docks elsewhere, from the shared state, and stops once it can no longer beat
        ``best`` (the smallest verified structure so far); none leaves where the first episode
        ends with at most :attr:`extra_from` modules or once ``best`` reaches ``bound`` (a lower
        bound on any answer's modules: nothing beats it). ``visit(probs, action)``, when given, is
        called at each state the tree docks from, before it docks ``action`` there (the
        policy's probabilities at that state: the guided search queues the other dockings).
        Returns the new best and the oracle calls made."""
        policy, env = self.policy, self.policy.env
        calls = 0
        branches: list[tuple[Any, tuple[float, ...], int]] = [(None, self.fallbacks, -1)]
        while branches and now() <= deadline:
            stop_at = best.n_modules if best is not None else env.n_max + 2
            if stop_at <= 1:  # one module: nothing beats it
                break
            state, group, action = branches.pop()
            if state is not None and stop_at <= bound:  # best is at the bound: no branch beats it
                break
            if state is None:
                obs, info = policy.reset(problem.task, start)
                done, base = info["success"], 0  # one module suffices: nothing to decide
            elif state.n_modules < stop_at - 1:
                env.restore(state)
                obs, _, terminated, truncated, info = env.step(action)
                done, base = terminated or truncated, state.oracle_calls
            else:
                continue
            seen.add(env.structure.key)
            while not done and len(info["cells"]) < stop_at - 1 and now() < deadline:
                mask = env.action_masks()
                probs = None
                if visit is not None or len(group) > 1:
                    probs = policy.probabilities(obs, mask)
                if len(group) == 1:
                    action = policy.decide(obs, mask, group[0], probs)
                else:  # where the fallbacks dock differently, the later ones branch off
                    by_action: dict[int, list[float]] = {}
                    for f in group:
                        by_action.setdefault(policy.decide(obs, mask, f, probs), []).append(f)
                    (action, first), *others = by_action.items()
                    group = tuple(first)
                    branches += [(env.state, tuple(g), a) for a, g in reversed(others)]
                if visit is not None:
                    visit(probs, int(action))
                obs, _, terminated, truncated, info = env.step(int(action))
                seen.add(env.structure.key)
                done = terminated or truncated
            calls += int(info["oracle_calls"]) - base
            best = self.better(problem, info, best)
            if state is None and len(info["cells"]) <= self.extra_from:
                break  # the first episode ends small: the others would not pay for their time
        return best, calls

    def better(
        self, problem: SearchProblem, info: dict, best: Structure | None
    ) -> Structure | None:
        """The environment's structure if its episode (``info``) succeeded within ``n_max``
        modules, beats ``best`` and verifies (``problem``'s decision: with its fault, after
        every failure too), else ``best``."""
        n = len(info["cells"])
        if not info["success"] or n > self.n_max or (best is not None and n >= best.n_modules):
            return best
        s = self.policy.env.structure
        return s if verified(s, problem) else best

    def __repr__(self) -> str:
        return (
            f"PPOSolver(model={self.policy.model_path!r}, n_max={self.n_max}, "
            f"samples={self.samples}, fallbacks={self.fallbacks})"
        )
