"""Demonstrations from the certified search, and behaviour cloning of a MaskablePPO policy.

Why: in ``ModQuadAssembly-v0`` a planted task usually has exactly *one* optimal structure (the
hidden one), so the policy must infer a shape from the task's features. PPO alone finds that
slowly (the only signal is the episode's final module count); supervised targets from the
exhaustive search give it directly. The recipe of ``train.py`` is therefore: behaviour cloning
on expert episodes, then MaskablePPO fine-tuning on the reward of the environment.

The expert: for a training task, :func:`~modquad_gym.search.optimal_structures` gives every
minimum-module structure O (certified). In a state with cells P (initial module at (0, 0)), an
action is *good* when P plus its cell still fits inside some translate of some O; an expert
episode follows good actions chosen at random, so it ends with an optimal structure. With
several module types (:class:`~modquad_gym.envs.assembly.modules.Palette`) a cell of O
carries its type, an action docks (cell, type), and the episode starts with a module of a type
drawn from O's (a structure is reachable only from a type it holds). The
cloning loss is ``-log sum_{a good} pi(a | s)`` (any good action is right) plus a value loss
towards the expert's return-to-go, so PPO starts with a critic that matches its actor.

Training tasks come from the training streams only (``default_rng(seed)``, seeds below
:data:`agents.suites.VALIDATION_SEED0`), never from the validation or held-out suites.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from modquad_gym.envs.assembly import ModQuadAssemblyEnv
from modquad_gym.geometry.structure import Cell, Key, normalise_typed
from modquad_gym.search import exhaustive_search, optimal_structures


def typed_cells(key: Key, palette: Sequence[Any] | None) -> list[tuple[Cell, int]]:
    """(cell, palette index) pairs of a structure key: a one-type key's cells with type 0, or a
    typed key's (:func:`~modquad_gym.geometry.structure.normalise_typed`) with their types'
    indices."""
    if palette is None:
        return [(cell, 0) for cell in key]
    return [(cell, palette.index(module)) for cell, module in key]


def placements(
    optima: Sequence[Key], palette: Sequence[Any] | None = None, start: int = 0
) -> list[frozenset[tuple[Cell, int]]]:
    """Every translate of every optimal structure that puts a module of type ``start`` on the
    initial cell (0, 0), as frozensets of (cell, type index)."""
    out = set()
    for key in optima:
        pairs = typed_cells(key, palette)
        for (ox, oy), k in pairs:
            if k == start:
                out.add(frozenset(((x - ox, y - oy), t) for (x, y), t in pairs))
    return sorted(out, key=sorted)


def good_actions(
    env: ModQuadAssemblyEnv, targets: Sequence[frozenset[tuple[Cell, int]]]
) -> np.ndarray:
    """bool: valid actions whose (cell, type) keeps the structure inside some target."""
    types = env.state.types or (0,) * env.state.n_modules
    built = set(zip(env.state.cells, types, strict=True))
    good = np.zeros(env.action_space.n, dtype=bool)
    for target in targets:
        if built <= target:
            for cell, k in target - built:
                good[env.grid.action_of(cell, k)] = True
    return good & env.action_masks()


@dataclass
class Demonstrations:
    """Expert states: observations (dict of stacked arrays), valid and good action masks,
    the expert's return-to-go, and how many tasks and episodes they came from."""

    obs: dict[str, np.ndarray]
    valid: np.ndarray
    good: np.ndarray
    returns: np.ndarray
    n_tasks: int

    def __len__(self) -> int:
        return len(self.valid)

    @classmethod
    def stacked(cls, obs_rows: dict[str, list], valid: list, good: list, returns: list,
                n_tasks: int) -> Demonstrations:  # fmt: skip
        """Demonstrations from the rows an episode loop collected (one per labelled state)."""
        return cls(
            obs={k: np.stack(v) for k, v in obs_rows.items()},
            valid=np.array(valid),
            good=np.array(good),
            returns=np.array(returns, dtype=np.float32),
            n_tasks=n_tasks,
        )


EXPERTS = ("all", "one")
"""Expert targets: ``all`` optimal structures (:func:`optimal_structures`), or ``one``, the
first the certified search finds (:func:`exhaustive_search`: much cheaper where a task has
thousands of optima, as on the large tier)."""


def expert_targets(
    task: Any,
    n_max: int,
    expert: str = "all",
    palette: Sequence[Any] | None = None,
    fault: str | None = None,
) -> tuple[int | None, list[Key]]:
    """(n*, optimal structure keys) that the ``expert`` steers towards (see :data:`EXPERTS`);
    typed keys with a ``palette`` (several module types); with a ``fault``, the optima among the
    structures that survive it. A callable ``expert(task, n_max, palette)`` gives them itself
    (expert iteration: the best structure found, not certified; no fault)."""
    if callable(expert):
        return expert(task, n_max, palette)
    kwargs = {"modules": list(palette)} if palette is not None else {}
    kwargs |= {"fault": fault} if fault is not None else {}
    if expert == "all":
        return optimal_structures(task, n_max=n_max, **kwargs)
    if expert == "one":
        r = exhaustive_search(task, n_max=n_max, **kwargs)
        if r.structure is None:
            return r.n_modules, []
        s = r.structure
        return r.n_modules, [normalise_typed(s.cells, s.modules) if palette else s.key]
    raise ValueError(f"expert must be one of {EXPERTS}, got {expert!r}")


def expert_start(
    task: Any, keys: Sequence[Key], palette: Sequence[Any] | None, rng: np.random.Generator
) -> tuple[dict, int]:
    """(reset options, start type) of an episode towards the optima ``keys``: with several
    module types, a type some optimum holds, drawn with ``rng`` (a structure is reachable only
    from a type it holds)."""
    if palette is None:
        return {"task": task}, 0
    held = sorted({k for key in keys for _, k in typed_cells(key, palette)})
    start = int(rng.choice(held))
    return {"task": task, "initial_type": start}, start


def expert_episode(
    env: ModQuadAssemblyEnv,
    task: Any,
    n_max: int,
    expert: str,
    rng: np.random.Generator,
) -> tuple[int, list, dict] | None:
    """Reset ``env`` for an episode towards ``task``'s optima: (n*, targets as
    :func:`placements` gives them, first observation), or None for a task with no decision to
    learn (no structure of up to ``n_max`` modules, or one module already satisfies it)."""
    palette = getattr(env, "palette", None)
    n_star, keys = expert_targets(task, n_max, expert, palette, getattr(env, "fault", None))
    if n_star is None or n_star == 1:
        return None
    options, start = expert_start(task, keys, palette, rng)
    targets = placements(keys, palette, start)
    obs, _ = env.reset(options=options)
    return n_star, targets, obs


def collect(
    env: ModQuadAssemblyEnv,
    tasks: Sequence[Any],
    n_max: int,
    seed: int = 0,
    progress: bool = False,
    expert: str = "all",
) -> Demonstrations:
    """One expert episode per task (tasks with no structure of up to ``n_max`` modules, or that
    one module already satisfies, are skipped: no decision to learn there); ``expert`` as in
    :data:`EXPERTS`."""
    rng = np.random.default_rng(seed)
    obs_rows: dict[str, list[np.ndarray]] = {}
    valid, good, returns = [], [], []
    used = 0
    iterator = tasks
    if progress:
        from tqdm.auto import tqdm

        iterator = tqdm(tasks, desc="expert episodes", unit="task")
    for task in iterator:
        episode = expert_episode(env, task, n_max, expert, rng)
        if episode is None:
            continue
        n_star, targets, obs = episode
        rewards: list[float] = []
        done = False
        while not done:
            g = good_actions(env, targets)
            if not g.any():  # cannot happen on an expert path; guards a wrong target set
                raise RuntimeError(f"expert lost its way on task {task.name!r}")
            for k, v in obs.items():
                obs_rows.setdefault(k, []).append(v)
            valid.append(env.action_masks())
            good.append(g)
            obs, reward, terminated, truncated, info = env.step(int(rng.choice(np.flatnonzero(g))))
            rewards.append(reward)
            done = terminated or truncated
        if not info["success"] or info["n_modules"] > n_star:  # fewer: a part of it suffices
            raise RuntimeError(f"expert episode on {task.name!r} did not reach its target")
        returns.extend(np.cumsum(rewards[::-1])[::-1])
        used += 1
    return Demonstrations.stacked(obs_rows, valid, good, returns, used)


def _collect_chunk(args: tuple) -> Demonstrations:
    tasks, env_kwargs, n_max, seed, expert = args
    return collect(ModQuadAssemblyEnv(**env_kwargs), tasks, n_max, seed=seed, expert=expert)


def collect_parallel(
    tasks: Sequence[Any],
    env_kwargs: dict,
    n_max: int,
    seed: int = 0,
    workers: int = 1,
    progress: bool = False,
    expert: str = "all",
) -> Demonstrations:
    """:func:`collect` over ``workers`` Ray tasks (:mod:`modquad_gym.core.distributed`: an embedded
    Ray, or the cluster of ``RAY_ADDRESS``; 1: in this process). Chunks of 50 tasks, each seeded
    by ``[seed, chunk index]``, so the result does not depend on ``workers``."""
    from modquad_gym.core.distributed import map_tasks

    size = 50
    jobs = [
        (list(tasks[i : i + size]), env_kwargs, n_max, [seed, i // size], expert)
        for i in range(0, len(tasks), size)
    ]
    parts = map_tasks(
        _collect_chunk, jobs, workers=workers, progress=progress, desc="expert demonstrations"
    )
    return merge(parts)


def merge(parts: Sequence[Demonstrations]) -> Demonstrations:
    """One set of demonstrations from several (in order)."""
    parts = [p for p in parts if len(p)]
    if not parts:
        raise ValueError("no demonstrations: every task was skipped (none needs a decision)")
    return Demonstrations(
        obs={k: np.concatenate([p.obs[k] for p in parts]) for k in parts[0].obs},
        valid=np.concatenate([p.valid for p in parts]),
        good=np.concatenate([p.good for p in parts]),
        returns=np.concatenate([p.returns for p in parts]),
        n_tasks=sum(p.n_tasks for p in parts),
    )


def clone(
    model: Any,
    demos: Demonstrations,
    epochs: int = 30,
    batch_size: int = 256,
    learning_rate: float = 1e-3,
    value_coef: float = 0.5,
    seed: int = 0,
    progress: bool = False,
    log: Any = None,
) -> list[dict[str, float]]:
    """Behaviour cloning of ``model.policy`` (a MaskablePPO actor-critic) on ``demos``.

    Minimises ``-log sum_{a good} pi(a | s) + value_coef * (V(s) - return-to-go)^2`` with Adam.
    Returns per-epoch statistics (loss, share of states whose most likely action is good);
    ``log(epoch, stats)`` is called after each epoch (e.g. a TensorBoard writer)."""
    import torch

    policy = model.policy
    policy.set_training_mode(True)
    opt = torch.optim.Adam(policy.parameters(), lr=learning_rate)
    gen = torch.Generator().manual_seed(seed)
    obs = {k: torch.as_tensor(v) for k, v in demos.obs.items()}
    valid = torch.as_tensor(demos.valid)
    good = torch.as_tensor(demos.good)
    returns = torch.as_tensor(demos.returns)
    n = len(demos)
    history = []
    epochs_iter = range(epochs)
    if progress:
        from tqdm.auto import tqdm

        epochs_iter = tqdm(epochs_iter, desc="behaviour cloning", unit="epoch")
    for epoch in epochs_iter:
        perm = torch.randperm(n, generator=gen)
        total = hits = 0.0
        for start in range(0, n, batch_size):
            idx = perm[start : start + batch_size]
            batch = {k: v[idx] for k, v in obs.items()}
            logits, values = _logits_and_values(policy, batch)
            logits = logits.masked_fill(~valid[idx], -1e9)
            log_z = torch.logsumexp(logits, dim=1)
            log_good = torch.logsumexp(logits.masked_fill(~good[idx], -1e9), dim=1)
            policy_loss = (log_z - log_good).mean()
            value_loss = ((values - returns[idx]) ** 2).mean()
            loss = policy_loss + value_coef * value_loss
            opt.zero_grad()
            loss.backward()
            torch.nn.utils.clip_grad_norm_(policy.parameters(), 1.0)
            opt.step()
            total += float(loss.detach()) * len(idx)
            hits += float(good[idx].gather(1, logits.argmax(1, keepdim=True)).sum())
        stats = {"loss": total / n, "greedy_good": hits / n}
        history.append(stats)
        if log is not None:
            log(epoch, stats)
    policy.set_training_mode(False)
    return history


def _logits_and_values(policy: Any, obs: dict) -> tuple[Any, Any]:
    """Action logits (before masking) and values of an SB3 actor-critic policy."""
    features = policy.extract_features(obs)
    if policy.share_features_extractor:
        latent_pi, latent_vf = policy.mlp_extractor(features)
    else:
        pi_features, vf_features = features
        latent_pi = policy.mlp_extractor.forward_actor(pi_features)
        latent_vf = policy.mlp_extractor.forward_critic(vf_features)
    return policy.action_net(latent_pi), policy.value_net(latent_vf).squeeze(-1)
