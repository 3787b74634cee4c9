"""A trained policy ready to act: its model, the environment it acts in, its action
probabilities and its greedy episode.

:class:`Policy` is what the learned solvers *use*: plain decoding (:mod:`.ppo`) runs its
episodes, the policy-guided search (:mod:`.guided`) orders its branches by its probabilities.
A saved model with a fresh NumPy export beside it (:mod:`.inference`) acts without torch;
torch and SB3 load only for a model without one (or a loaded MaskablePPO).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np

from modquad_gym.core.compile_clock import compile_seconds, now
from modquad_gym.core.extras import import_optional
from modquad_gym.core.validation import check_int
from modquad_gym.envs.assembly import ModQuadAssemblyEnv
from modquad_gym.envs.assembly.lookahead import flagged
from modquad_gym.geometry.structure import Structure
from modquad_gym.oracle.faults import check_fault_margin
from modquad_gym.policy.inference import Actor, inference_model, type_features
from modquad_gym.policy.model_config import ENV_KWARG_KEYS, env_kwargs_of, lookahead_of
from modquad_gym.policy.models import (
    EXTRA_FALLBACKS,
    FALLBACK,
    LEARNED_CHECKS,
    MODEL_TOP_K,
    SCALE_FROM,
    SMALL_EXTRA_FALLBACKS,
    check_learned,
    default_model,
    model_file,
    model_top_k,
    one_torch_thread,
    read_model,
)
from modquad_gym.search import SearchResult
from modquad_gym.search.beyond import bound_beyond
from modquad_gym.search.problem import SearchProblem
from modquad_gym.tasks import TaskRequirement

__all__ = ["ENV_KWARG_KEYS", "Policy", "acting_palette", "env_kwargs_of", "lookahead_of",
           "make_env"]  # fmt: skip


def acting_palette(problem: SearchProblem) -> list | None:
    """The module types a policy acts with on ``problem``: its palette where it has one or
    where its task's wrenches carry the structure's own weight (kind ``external``: only a
    module set decides self-weight, one type too), else None (one type; a dynamic task's
    wrenches follow each structure's own mass)."""
    task = problem.task
    weight = problem.model.uses_mass and not getattr(task, "per_structure", False)
    return list(problem.palette) if problem.typed or weight else None


def make_env(tasks: Any = "mixed", n_max: int = 7, **env_kwargs: Any) -> gym.Env:
    """One training/evaluation environment: the assembly env in a Monitor that records
    ``is_success`` per episode (SB3's callbacks read it; MaskablePPO finds ``action_masks``
    through the wrapper)."""
    Monitor = import_optional("stable_baselines3.common.monitor").Monitor

    env = ModQuadAssemblyEnv(tasks=tasks, n_max=n_max, **env_kwargs)
    return Monitor(env, info_keywords=("is_success",))


class Policy:
    """A trained policy network with the environment it acts in.

    Args:
        model: a model .zip path (default the shipped model for ``n_max``,
            :func:`~modquad_gym.policy.models.default_model`), a loaded MaskablePPO or its
            policy network.
        n_max: the module budget; at most the n_max the model was trained with (its grid size);
            None: the trained one.
        config: the model's config when ``model`` is a loaded model.
        top_k: with a model that reads the exact lookahead, the children decided exactly per
            step (the env's ``lookahead_top_k``); None (default): all, as in training;
            :data:`~.models.MODEL_TOP_K` (the learned solvers' default): the model's own
            (:func:`~.models.model_top_k`: its config's ``top_k``, else :data:`~.models.TOP_K`).
        trust_model: read a model .zip that only unpickling reads (True only for a file the
            user trusts: unpickling runs code from it; :func:`~.models.read_model`).

    Attributes:
        actor (the NumPy actor of a saved model's fresh export, :mod:`.inference`; None: the
        torch network acts), net (the actor-critic: an sb3-contrib masked policy, loaded on
        first use when the actor acts), model_path (None for a loaded
        model), n_max, env, typed (trained with a palette:
        (cell, type) actions), starts (the start types a decoding tries: each type of the
        palette, else [None]), palette (the module types it acts with).
    """

    def __init__(
        self,
        model: Any = None,
        n_max: int | None = 7,
        config: dict | None = None,
        top_k: int | None = None,
        trust_model: bool = False,
    ) -> None:
        self.saved, self.actor, self._net = None, None, None
        self.trust = check_learned("trust_model", trust_model)
        top_k = check_learned("top_k", top_k)
        n_max = None if n_max is None else check_int(n_max, "n_max", low=1)
        where = "config"
        if model is None or isinstance(model, (str, Path)):
            path = model_file(default_model(n_max) if model is None else model)
            self.saved = inference_model(path, self.trust)
            self.model_path, config = str(self.saved.path), self.saved.config
            space, where = self.saved.observation_space, str(path.with_name("config.json"))
        else:
            self._net, self.model_path = getattr(model, "policy", model), None
            space = self._net.observation_space
        kwargs = env_kwargs_of(space, config or {}, where, self.size_free)
        trained = int(kwargs["n_max"])
        n_max = trained if n_max is None else n_max
        if n_max > trained and not self.size_free:
            raise ValueError(
                f"n_max={n_max} exceeds the n_max={trained} the PPO model was trained with "
                "(its action grid cannot hold larger structures)"
            )
        self.n_max = int(n_max)
        if self.size_free:  # the environment of the budget asked for (at least 2 modules)
            kwargs["n_max"] = max(self.n_max, 2)
        kwargs.pop("lookahead_top_k", None)
        if top_k == MODEL_TOP_K:
            top_k = model_top_k(config or {}, where)
        if kwargs.get("lookahead") == "exact" and top_k is not None:
            kwargs["lookahead_top_k"] = top_k
        self.build(kwargs)

    @property
    def size_free(self) -> bool:
        """Whether the network acts at any n_max and palette (a saved size-free model)."""
        return self.saved is not None and self.saved.size_free

    def build(self, env_kwargs: dict) -> None:
        """(Re)build the environment of ``env_kwargs`` and, for a saved model, the network for
        its spaces (a size-free one with the descriptors of its module types)."""
        self.env_kwargs = env_kwargs
        self.env = ModQuadAssemblyEnv(**env_kwargs)
        self.typed = self.env.palette is not None  # (cell, type) actions: decode from each type
        self.starts: list[int | None] = list(range(self.env.n_types)) if self.typed else [None]
        self.palette = list(self.env.palette or [self.env.module])
        if self.saved is None:
            return
        if self.size_free:
            *spaces, types = self.spaces
            net = self.saved.build(*spaces, types=types)
        else:
            net = self.saved.build()
        self.actor, self._net = (net, None) if isinstance(net, Actor) else (None, net)

    @property
    def observation_space(self) -> Any:
        """The observation space of the environment it acts in."""
        return self.env.observation_space

    @property
    def spaces(self) -> tuple:
        """(observation space, action space) of the environment, and the palette's types."""
        env = self.env
        return env.observation_space, env.action_space, type_features(self.palette)

    @property
    def net(self) -> Any:
        """The torch actor-critic (read from the model file on first use when the NumPy actor
        acts: training code that asks for it gets it)."""
        if self._net is None:
            *spaces, types = self.spaces
            self._net = read_model(self.model_path, self.trust).build(*spaces, types=types)
        return self._net

    def use_palette(self, modules: list | None) -> None:
        """Act with the module types ``modules`` (None: one type, the T-module): a size-free
        network is rebuilt for them; any other must have been trained with exactly them
        (ValueError otherwise)."""
        if not self.size_free:
            return self.check_palette(modules)
        kwargs = {k: v for k, v in self.env_kwargs.items() if k not in ("modules", "initial_type")}
        self.build({**kwargs, **({"modules": list(modules)} if modules else {})})

    def check_palette(self, modules: list | None) -> None:
        """ValueError unless ``modules`` (None: one type) is the palette the model was trained
        with."""
        same = [m.digest for m in modules or []] == [m.digest for m in self.palette]
        if modules and not same or not modules and len(self.palette) > 1:
            given = ",".join(m.name for m in modules) if modules else "one type"
            raise ValueError(
                f"--model {self.model_path or 'given'}: trained with the module types "
                f"{','.join(m.name for m in self.palette)}, not {given} (its action grid is "
                "of those types): give --model of one trained with them, or of a size-free "
                "model, which acts with any module types (as every shipped model does)"
            )

    def use_fault(self, fault: str | None, fault_margin: float = 0.0) -> None:
        """Design for ``fault`` (None: every rotor works): an episode then succeeds only when
        every task wrench survives any failure of that kind with ``fault_margin`` to spare, and
        the shares the policy reads count only the wrenches that survive. The observation's
        shape is unchanged, so any model acts (zero-shot where it was trained without it)."""
        fault_margin = check_fault_margin(fault_margin, fault)  # none without a fault
        kwargs = {k: v for k, v in self.env_kwargs.items() if k not in ("fault", "fault_margin")}
        if fault is not None:
            kwargs.update(fault=fault, fault_margin=fault_margin)
        if kwargs != self.env_kwargs:
            self.build(kwargs)

    def problem(self, task: TaskRequirement) -> SearchProblem:
        """``task`` as the :class:`~modquad_gym.search.problem.SearchProblem` the policy designs
        for: its module types, budget and fault (the decision every answer is verified by).
        ValueError for a task that carries the structure's weight when it acts without a
        module set (:func:`acting_palette`), naming what does."""
        palette = {"modules": self.palette} if self.typed else {"module": self.env.module}
        problem = SearchProblem.build(task, self.n_max, **palette, fault=self.env.fault,
                                      fault_margin=self.env.fault_margin)  # fmt: skip
        if not self.typed and acting_palette(problem) is not None:
            said = (f"task {problem.task.name!r} is of kind {problem.kind!r}: its wrenches carry "
                    "the structure's weight, which only a module set decides")  # fmt: skip
            if self.size_free:
                raise ValueError(f"{said}: act with policy.use_palette([module]), as "
                                 "make_solver does")  # fmt: skip
            raise ValueError(f"{said}, and the model {self.model_path or 'given'} (one grid, "
                             "one type) acts without one; give a size-free model, as every "
                             "shipped one is")  # fmt: skip
        return problem

    def probabilities(self, obs: dict, mask: np.ndarray) -> np.ndarray:
        """The policy's action probabilities at ``obs``, zero outside ``mask`` (sb3-contrib's
        masked distribution)."""
        if self.actor is not None:
            return self.actor.probabilities(obs, mask)
        import torch

        obs_t, _ = self.net.obs_to_tensor(obs)
        with torch.no_grad(), one_torch_thread():
            dist = self.net.get_distribution(obs_t, action_masks=np.asarray(mask)[None])
            probs = dist.distribution.probs[0].double().numpy()
        return np.where(mask, probs, 0.0)

    def greedy(self, obs: dict, mask: np.ndarray) -> int:
        """The most likely valid action at ``obs``."""
        if self.actor is not None:
            return self.actor.greedy(obs, mask)
        net = self.net
        with one_torch_thread():
            action, _ = net.predict(obs, action_masks=mask, deterministic=True)
        return int(action)

    @property
    def reads_greedy(self) -> bool:
        """Whether its observation flags greedy's choice (a model of the exact lookahead)."""
        return self.env_kwargs.get("lookahead") == "exact"

    def decide(self, obs: dict, mask: np.ndarray, fallback: float = 0.0, probs=None) -> int:
        """The deterministic decoding's action at ``obs``: the most likely valid one, or
        greedy's choice (its flag in the exact lookahead rows) where the most likely has a
        probability of at most ``fallback`` (0: never; 1: always). ``probs``: the policy's
        :meth:`probabilities` at ``obs`` when already known."""
        if not fallback:
            return self.greedy(obs, mask) if probs is None else int(np.argmax(probs))
        probs = self.probabilities(obs, mask) if probs is None else probs
        action = int(np.argmax(probs))
        if probs[action] <= fallback:
            greedys = flagged(obs["candidates"], mask)
            action = action if greedys is None else greedys
        return action

    def reset(self, task: Any, start: int | None = None) -> tuple[dict, dict]:
        """The environment reset on ``task`` (a first module of type ``start``, several types)."""
        options = {"task": task} if start is None else {"task": task, "initial_type": start}
        return self.env.reset(options=options)

    def rollout(
        self,
        task: Any,
        rng: np.random.Generator | None = None,
        seen: set | None = None,
        stop_at: int | None = None,
        start: int | None = None,
        deadline: float = float("inf"),
        fallback: float = 0.0,
    ) -> dict:
        """One episode on ``task`` from a first module of type ``start``: at each step
        :meth:`decide`'s action (with ``fallback``) when ``rng`` is None, else sampled. Stops
        early once the structure has ``stop_at - 1`` modules without success (it could no
        longer beat a verified structure of ``stop_at`` modules) or at ``deadline`` (a time on
        the search clock, :func:`~modquad_gym.core.compile_clock.now`). Adds every structure
        it evaluates to ``seen`` (translation-normalised). Returns the final info;
        ``env.structure`` is its structure."""
        env = self.env
        seen = set() if seen is None else seen
        stop_at = env.n_max + 2 if stop_at is None else stop_at
        obs, info = self.reset(task, start)
        seen.add(env.structure.key)
        done = info["success"]  # one module suffices: nothing to decide
        while not done and len(info["cells"]) < stop_at - 1 and now() < deadline:
            mask = env.action_masks()
            if rng is None:
                action = self.decide(obs, mask, fallback)
            else:
                probs = self.probabilities(obs, mask)
                action = rng.choice(len(probs), p=probs / probs.sum())
            obs, _, terminated, truncated, info = env.step(int(action))
            seen.add(env.structure.key)
            done = terminated or truncated
        return info

    def __repr__(self) -> str:
        return f"Policy(model={self.model_path!r}, n_max={self.n_max})"


def fallback_of(policy: Policy, fallback: float | None, name: str = "fallback") -> float:
    """The ``fallback`` ``policy`` decodes with (see :class:`~.ppo.PPOSolver`): a ValueError for
    one out of [0, 1] (the option's check), or above 0 with a model whose observation has no
    greedy choice."""
    if fallback is None:
        return FALLBACK if policy.reads_greedy and policy.n_max >= SCALE_FROM else 0.0
    value = LEARNED_CHECKS["fallback"](fallback, name)
    if value > 0 and not policy.reads_greedy:
        raise ValueError(
            f"{name}={fallback}: the model {policy.model_path or 'given'} does not see "
            "greedy's choice (it was trained without the exact lookahead); give 0"
        )
    return value


def extra_fallbacks_of(policy: Policy, extra: Any) -> tuple[float, ...]:
    """The further fallbacks ``policy``'s deterministic decoding follows (see
    :class:`~.ppo.PPOSolver`): None gives :data:`~.models.EXTRA_FALLBACKS` at budgets of
    :data:`~.models.SCALE_FROM` modules and more and :data:`~.models.SMALL_EXTRA_FALLBACKS`
    below, with a model that sees greedy's choice, else none; a number or a sequence of numbers
    in [0, 1] (the option's check, :data:`~.models.LEARNED_CHECKS`), each above 0 only with a
    model that sees greedy's choice."""
    if extra is None:
        if not policy.reads_greedy:
            return ()
        return EXTRA_FALLBACKS if policy.n_max >= SCALE_FROM else SMALL_EXTRA_FALLBACKS
    values = check_learned("extra_fallbacks", extra)
    return tuple(dict.fromkeys(fallback_of(policy, v, "extra_fallbacks") for v in values))


def search_result(
    name: str,
    problem: SearchProblem,
    best: Structure | None,
    evaluated: int,
    oracle_calls: int,
    t0: float,
    certified: bool | None = False,
    proof: str = "",
    lower_bound: int | None = None,
    compiled: float | None = None,
    time_limit: float | None = None,
) -> SearchResult:
    """The search record of a learned solver ``name`` that started at ``t0`` (on the search
    clock, :func:`~modquad_gym.core.compile_clock.now`) on ``problem``
    (:meth:`Policy.problem`: its budget, palette, task kind and fault) and kept ``best`` (with the
    proved ``lower_bound`` on the module count, when the solver knows one; ``certified`` None:
    derived from it; without a structure, raised by the exact bounds past n_max: it is the
    strongest bound proved, :mod:`~modquad_gym.search.beyond`, within what is left of the
    solver's ``time_limit``). ``compiled``: the compile clock's reading at ``t0``
    (:func:`~modquad_gym.core.compile_clock.compile_seconds`): the kernels compiled since are
    left out of the seconds."""
    compiling = 0.0 if compiled is None else compile_seconds() - compiled
    if best is None and lower_bound is not None:
        left = None if time_limit is None else t0 + time_limit - now()
        lower_bound = bound_beyond(problem, lower_bound, left)
    return SearchResult(
        structure=best,
        n_modules=best.n_modules if best is not None else None,
        evaluated=evaluated,
        oracle_calls=oracle_calls,
        seconds=now() - t0,
        certified=certified,
        method=name,
        n_max=problem.n_max,
        proof=proof,
        lower_bound=lower_bound,
        kind=problem.kind,
        palette=tuple(m.name for m in problem.palette) if problem.typed else (),
        fault=problem.fault,
        fault_margin=problem.fault_margin,
        compile_seconds=compiling,
    )
