"""The learned agent: a MaskablePPO policy that docks modules in ``ModQuadAssembly-v0``.

Decoding (:class:`PPOSolver`): the policy acts deterministically (the most likely valid action)
until the episode ends; with ``samples=k`` it also runs k stochastic rollouts (seeded) and keeps
the smallest verified structure. A model trained with several module types
(``ModQuadAssemblyMixed-v0``) decodes once from each start type, since a structure is reachable
only from a type it holds. ``evaluated`` counts the distinct structures (up to
translation) the rollouts evaluated, as the searches count configurations; a sampled rollout
stops as soon as it can no longer beat the best verified structure. The
final structure is always re-checked by the exact DAQP LP oracle; one that fails is reported as
no structure, never as a success.

Torch and SB3 are imported here only, so ``import agents`` stays light.
"""

from __future__ import annotations

import math
import time
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np

from modquad_gym.core.extras import import_optional
from modquad_gym.envs.assembly import ModQuadAssemblyEnv
from modquad_gym.geometry.structure import Structure
from modquad_gym.policy.models import DEFAULT_MODEL, load_model
from modquad_gym.search import SearchResult, verified
from modquad_gym.tasks import TaskRequirement

ENV_KWARG_KEYS = (
    "n_max", "n_directions", "reward_weights", "invalid_action", "oracle_method", "lookahead",
    "modules",
)  # fmt: skip
"""Environment keywords a model's config.json may fix (the task source is given per task)."""


def make_env(tasks: Any = "mixed", n_max: int = 7, **env_kwargs: Any) -> gym.Env:
    """One training/evaluation environment: the assembly env in a Monitor that records
    ``is_success`` per episode (SB3's callbacks read it; MaskablePPO finds ``action_masks``
    through the wrapper)."""
    Monitor = import_optional("stable_baselines3.common.monitor").Monitor

    env = ModQuadAssemblyEnv(tasks=tasks, n_max=n_max, **env_kwargs)
    return Monitor(env, info_keywords=("is_success",))


def env_kwargs_of(model, config: dict) -> dict:
    """The environment keywords the model was trained with (from its config, else inferred
    from its observation space)."""
    kwargs = {k: v for k, v in config.get("env_kwargs", {}).items() if k in ENV_KWARG_KEYS}
    if "n_max" not in kwargs:
        side = math.isqrt(model.observation_space["occupancy"].shape[0])  # G * G cells
        kwargs["n_max"] = (side + 1) // 2
    if "n_directions" not in kwargs:
        kwargs["n_directions"] = int(model.observation_space["task"].shape[0]) - 7
    if "lookahead" not in kwargs:
        kwargs["lookahead"] = "candidates" in model.observation_space.spaces
    return kwargs


class PPOSolver:
    """A trained MaskablePPO policy behind the :class:`~.solvers.Solver` interface.

    Args:
        model: a model .zip path (default :data:`DEFAULT_MODEL`) or a loaded MaskablePPO.
        n_max: the module budget; at most the n_max the model was trained with (its grid size).
        seed: seeds the sampled rollouts.
        samples: extra stochastic rollouts per task (0: deterministic decoding only).
        config: the model's config when ``model`` is a loaded model.
    """

    name = "ppo"

    def __init__(
        self,
        model: Any = None,
        n_max: int | None = 7,
        seed: int = 0,
        samples: int = 0,
        config: dict | None = None,
    ) -> None:
        if isinstance(samples, bool) or not isinstance(samples, (int, np.integer)) or samples < 0:
            raise ValueError(f"samples must be an integer >= 0, got {samples!r}")
        if model is None or isinstance(model, (str, Path)):
            self.model, config = load_model(model)
            self.model_path = str(model if model is not None else DEFAULT_MODEL)
        else:
            self.model, self.model_path = model, None
        kwargs = env_kwargs_of(self.model, config or {})
        trained = int(kwargs["n_max"])
        n_max = trained if n_max is None else n_max
        if isinstance(n_max, bool) or not isinstance(n_max, (int, np.integer)) or n_max < 1:
            raise ValueError(f"n_max must be a positive integer, got {n_max!r}")
        if n_max > trained:
            raise ValueError(
                f"n_max={n_max} exceeds the n_max={trained} the PPO model was trained with "
                "(its action grid cannot hold larger structures)"
            )
        self.n_max = int(n_max)
        self.seed = int(seed)
        self.samples = int(samples)
        self.name = "ppo" if self.samples == 0 else f"ppo-k{self.samples}"
        self.env = ModQuadAssemblyEnv(**kwargs)
        several = "modules" in kwargs  # decode once from each start type
        self.starts: list[int | None] = list(range(self.env.n_types)) if several else [None]

    def probabilities(self, obs: dict, mask: np.ndarray) -> np.ndarray:
        """The policy's action probabilities at ``obs``, zero outside ``mask`` (the masked
        softmax of the actor's logits, as sb3-contrib's masked distribution computes it)."""
        import torch

        policy = self.model.policy
        obs_t, _ = policy.obs_to_tensor(obs)
        with torch.no_grad():
            features = policy.extract_features(obs_t)
            if not policy.share_features_extractor:
                features = features[0]
            logits = policy.action_net(policy.mlp_extractor.forward_actor(features))
            logits = logits - logits.logsumexp(dim=-1, keepdim=True)  # torch's Categorical
            masked = torch.where(torch.as_tensor(mask)[None], logits, torch.tensor(-1e8))
            masked = masked - masked.logsumexp(dim=-1, keepdim=True)
            probs = torch.softmax(masked, dim=-1)[0].double().numpy()
        return np.where(mask, probs, 0.0)

    def reset(self, task: Any, start: int | None = None) -> tuple[dict, dict]:
        """The environment reset on ``task`` (a first module of type ``start``, several types)."""
        options = {"task": task} if start is None else {"task": task, "initial_type": start}
        return self.env.reset(options=options)

    def _rollout(
        self,
        task: Any,
        rng: np.random.Generator | None,
        seen: set,
        stop_at: int,
        start: int | None = None,
    ) -> tuple[dict, int]:
        """One episode on ``task`` from a first module of type ``start``; deterministic when
        ``rng`` is None. Stops early once the
        structure has ``stop_at - 1`` modules without success (it could no longer beat a
        verified structure of ``stop_at`` modules). Adds every structure it evaluates to
        ``seen`` (translation-normalised). Returns the final info and the oracle calls."""

        env = self.env
        obs, info = self.reset(task, start)
        seen.add(env.structure.key)
        done = info["success"]  # one module suffices: nothing to decide
        while not done and len(info["cells"]) < stop_at - 1:
            mask = env.action_masks()
            if rng is None:
                action, _ = self.model.predict(obs, action_masks=mask, deterministic=True)
            else:
                probs = self.probabilities(obs, mask)
                action = rng.choice(len(probs), p=probs / probs.sum())
            obs, _, terminated, truncated, info = env.step(int(action))
            seen.add(env.structure.key)
            done = terminated or truncated
        return info, int(info["oracle_calls"])

    def solve(self, task: Any) -> SearchResult:
        """The smallest verified structure over the deterministic rollout and ``samples``
        sampled ones (None when none verifies within ``n_max`` modules). ``evaluated`` counts
        the distinct structures (up to translation) the rollouts evaluated; a structure met
        again costs no oracle call (the environment memoises per task)."""
        t0 = time.perf_counter()
        if not isinstance(task, TaskRequirement):
            task = TaskRequirement(task, name="task")  # a (t, 6) wrench array
        best: Structure | None = None
        seen: set = set()
        oracle_calls = 0
        runs: list[tuple[np.random.Generator | None, int | None]] = [(None, k) for k in self.starts]
        runs += [
            (np.random.default_rng([self.seed, i]), self.starts[i % len(self.starts)])
            for i in range(self.samples)
        ]
        for rng, start in runs:
            stop_at = best.n_modules if best is not None else self.env.n_max + 2
            if stop_at <= 1:
                break
            info, calls = self._rollout(task, rng, seen, stop_at, start)
            oracle_calls += calls
            n = len(info["cells"])
            if not info["success"] or n > self.n_max or (best is not None and n >= best.n_modules):
                continue
            s = self.env.structure
            if verified(s, task):
                best = s
        return self._result(best, len(seen), oracle_calls, t0)

    def _result(
        self,
        best: Structure | None,
        evaluated: int,
        oracle_calls: int,
        t0: float,
        certified: bool = False,
        proof: str = "",
        lower_bound: int | None = None,
    ) -> SearchResult:
        """The search record of a solve that started at ``t0`` and kept ``best`` (with the
        proved ``lower_bound`` on the module count, when the solver knows one)."""
        return SearchResult(
            structure=best,
            n_modules=best.n_modules if best is not None else None,
            evaluated=evaluated,
            oracle_calls=oracle_calls,
            seconds=time.perf_counter() - t0,
            certified=certified,
            method=self.name,
            n_max=self.n_max,
            proof=proof,
            lower_bound=lower_bound,
        )

    def __repr__(self) -> str:
        return f"PPOSolver(model={self.model_path!r}, n_max={self.n_max}, samples={self.samples})"
