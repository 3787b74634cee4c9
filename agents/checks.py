"""Checks of a training run's inputs before any work: the recipe's numbers, its environment, the
PPO hyperparameters, and a saved model that is resumed or published.

Each check raises ValueError naming the ``train.py`` option (``--seed``, ``--hyperparameters``,
``--resume``, ...) and the value, so ``train.py`` stops in one line (exit 2) before it builds
environments, collects demonstrations or replaces a shipped model.
"""

from __future__ import annotations

import numbers
from collections.abc import Iterable
from dataclasses import fields
from pathlib import Path
from typing import Any

import numpy as np

from modquad_gym.core.interrupts import one_line
from modquad_gym.core.resources import check_memory, usable_cpus
from modquad_gym.core.validation import NOT_REGULAR, check_int, check_real

MAX_N_ENVS = 256
"""Most training environments (each holds its own task and caches)."""

MAX_STEPS = 10**10
"""Most PPO steps, demonstrations or evaluation episodes one run may ask for."""


HYPERPARAMETER_RANGES: dict[str, tuple[type, float, float, bool]] = {
    "learning_rate": (float, 0.0, 1.0, False),
    "n_steps": (int, 2, 10**7, True),
    "batch_size": (int, 2, 10**7, True),
    "n_epochs": (int, 1, 10**4, True),
    "gamma": (float, 0.0, 1.0, True),
    "gae_lambda": (float, 0.0, 1.0, True),
    "clip_range": (float, 0.0, 10.0, False),
    "ent_coef": (float, 0.0, 10.0, True),
    "vf_coef": (float, 0.0, 10.0, True),
    "max_grad_norm": (float, 0.0, 1e6, False),
    "target_kl": (float, 0.0, 10.0, False),
    "kl_coef": (float, 0.0, 1e3, True),
    "hidden": (int, 1, 4096, True),
}
"""(type, low, high, low included) per MaskablePPO hyperparameter; ``net_arch`` is a list
(:func:`check_hyperparameters`), ``hidden`` the ``candidates`` network's width."""

OFF_WHEN_NONE = ("target_kl",)
"""Hyperparameters whose None (JSON null, the recipe's default) means off."""


def option(name: str) -> str:
    return "--" + name.replace("_", "-")


def check_numbers(config: Any) -> None:
    """The integer fields of ``config`` (a TrainConfig) within their ``limits``."""
    for f in fields(config):
        value = getattr(config, f.name)
        if "limits" in f.metadata and value is not None:
            low, high = f.metadata["limits"]
            check_int(value, option(f.name), low=low, high=high)
    if config.vec_env == "subproc" and config.n_envs > 2 * usable_cpus():
        raise ValueError(
            f"--n-envs {config.n_envs} with --vec-env subproc starts {config.n_envs} processes; "
            f"this machine has {usable_cpus()} usable CPU(s) (at most {2 * usable_cpus()})"
        )


def check_hyperparameters(hp: dict) -> None:
    """Every value of ``hp`` (``--hyperparameters``) of the right type and range (None where it
    means off)."""
    for key, value in hp.items():
        where = f"--hyperparameters: {key}"
        if value is None and key in OFF_WHEN_NONE:
            continue
        if key == "net_arch":
            ok = isinstance(value, list) and 1 <= len(value) <= 16
            if not ok or not all(_is_int(v) and 1 <= v <= 4096 for v in value):
                raise ValueError(
                    f"{where} must be a list of 1 to 16 layer widths in 1..4096, got {value!r}"
                )
            continue
        if key not in HYPERPARAMETER_RANGES:
            raise ValueError(f"--hyperparameters: unknown key {key!r}")
        kind, low, high, closed = HYPERPARAMETER_RANGES[key]
        if kind is int:
            check_int(value, where, low=int(low), high=int(high))
            continue
        v = check_real(value, where, high=high)
        if v < low or (v == low and not closed):
            sign = ">=" if closed else ">"
            raise ValueError(f"{where} must be {sign} {low:g}, got {v:g}")


def _is_int(value: object) -> bool:
    return isinstance(value, numbers.Integral) and not isinstance(value, bool)


def check_environment(config: Any) -> None:
    """The training environment of ``config`` can be built: the task source (``--task-source``),
    ``--n-max`` and the extra keywords (``--env-kwargs``), each named when it is wrong; and
    PPO's rollout buffer of its observations fits in memory (``n_steps`` of
    ``--hyperparameters`` with ``--n-envs``, :func:`rollout_bytes`)."""
    from modquad_gym.envs.assembly import ModQuadAssemblyEnv
    from modquad_gym.envs.assembly.env import N_MAX_LIMIT
    from modquad_gym.tasks import make_generator

    try:
        make_generator(config.source)
    except ValueError as exc:
        raise ValueError(f"--task-source {config.source!r}: {exc}") from None
    check_int(config.max_modules, "--n-max", low=2, high=N_MAX_LIMIT)
    check_expert_reach(config)
    try:
        env = ModQuadAssemblyEnv(**config.env_kwargs_full)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"--env-kwargs {config.env_kwargs}: {one_line(exc)}") from None
    try:
        if config.resume is None:  # a resumed model keeps its own n_steps
            n_steps = config.ppo_hyperparameters()["n_steps"]
            check_memory(rollout_bytes(env, n_steps, config.n_envs),
                         f"--hyperparameters n_steps {n_steps} with --n-envs {config.n_envs} "
                         "(PPO's rollout buffer)")  # fmt: skip
    finally:
        env.close()


def check_expert_reach(config: Any) -> None:
    """``--n-max`` within what the expert's exhaustive search finishes on the tier's palette and
    the run's tasks (it certifies the validation optima and labels the demonstrations:
    :func:`~modquad_gym.search.typed.exhaustive_reach`), else a ValueError in the option's
    words, before any folder is claimed (the search itself would refuse it only then)."""
    from modquad_gym.geometry.module import palette
    from modquad_gym.scoring.tiers import get_tier
    from modquad_gym.search.typed import exhaustive_reach

    tier = get_tier(config.tier)
    n_types = len(palette(tier.modules)) if tier.modules else 1
    sources = dict.fromkeys((config.source, config.validation_source))
    weighed = n_types == 1 and any(structure_dependent(s) for s in sources)
    reach = exhaustive_reach(n_types, shape_only=n_types == 1 and not weighed)
    if config.max_modules <= reach:
        return
    why = ""
    if n_types > 1:
        why = f" with the {config.tier} tier's {n_types} module types"
    elif weighed:
        why = " on tasks whose wrenches depend on the structure (self-weight, dynamic)"
    raise ValueError(
        f"--n-max {config.max_modules}: beyond what the expert's exhaustive search can finish"
        f"{why}: at most {reach} modules (it certifies the validation optima and "
        "labels the demonstrations)"
    )


def structure_dependent(source: str) -> bool:
    """Whether a task of ``source`` (a generator name or a task file) has wrenches that depend
    on the structure (self-weight, a dynamic task): every task of a file, eight draws of a
    generator."""
    from modquad_gym.tasks import make_generator

    gen = make_generator(source)
    tasks = getattr(gen, "tasks", None) or [gen(np.random.default_rng(i)) for i in range(8)]
    return any(t.decision_model.uses_mass or t.decision_model.uses_inertia for t in tasks)


def rollout_bytes(env: Any, n_steps: int, n_envs: int) -> int:
    """Bytes of MaskablePPO's rollout buffer for ``env``'s spaces (SB3's ``DictRolloutBuffer``
    with its action masks): ``n_steps`` x ``n_envs`` rows of every observation array, the
    action, its mask (float32) and six float32 scalars (reward, return, value, log-probability,
    advantage, episode start), plus one copy of its largest array, which ``get`` flattens into
    a new one before it drops the old."""
    arrays = [int(np.prod(s.shape)) * s.dtype.itemsize
              for s in env.observation_space.spaces.values()]  # fmt: skip
    arrays += [int(env.action_space.n) * 4, env.action_space.dtype.itemsize, *[4] * 6]
    return n_steps * n_envs * (sum(arrays) + max(arrays))


def check_training_seed(seed: int, n_envs: int, option: str = "--seed") -> None:
    """The training environments' seeds, ``seed + i`` for env ``i < n_envs`` (SB3's
    ``VecEnv.seed``: each env's first task is drawn from ``default_rng(seed + i)``), stay out of
    the validation and held-out seeds (:mod:`modquad_gym.tasks.reserved`), else a ValueError
    naming ``option``. The recipe's other task draws use seed sequences ``[seed, k]``, never a
    reserved integer."""
    from modquad_gym.tasks.reserved import RESERVED_SEEDS, VALIDATION_SEEDS, reserved_met, span

    seeds = range(seed, seed + n_envs)
    met = reserved_met(seeds)
    if not met:
        return
    ranges = " and ".join(f"{what} ({span(RESERVED_SEEDS[what])})" for what in met)
    raise ValueError(
        f"{option} {seed}: the training environments would reset with seed"
        f"{'s' if n_envs > 1 else ''} {span(seeds)} (seed + env index, --n-envs {n_envs}), "
        f"among those reserved for the benchmark's {ranges} tasks; never train on them "
        f"(docs/leaderboard.md): choose a seed below {VALIDATION_SEEDS.start - n_envs + 1:,} "
        f"or from {RESERVED_SEEDS['held-out'].stop:,}"
    )


TIER_KEYS = ("module", "modules", "initial_type", "fault")
"""Environment keywords a tier sets (its module types and the failure its answers survive):
not ``--env-kwargs`` keys, or a run would train another tier under this one's name."""


def check_tier_keys(env_kwargs: dict, tier: str) -> None:
    """``--env-kwargs`` sets nothing that ``--task-source``, ``--n-max`` or ``--tier`` says."""
    if {"tasks", "task", "n_max"} & set(env_kwargs):
        raise ValueError("--env-kwargs: give tasks and n_max with --task-source and --n-max")
    for key in TIER_KEYS:
        if key in env_kwargs:
            raise ValueError(
                f"--env-kwargs {key}={env_kwargs[key]!r}: the module types and the failure are "
                f"the tier's (here --tier {tier}); choose another with --tier"
            )


def check_model(path: Path, env_kwargs: dict, what: str, tier_kwargs: dict | None = None) -> Any:
    """The file ``path`` is a saved MaskablePPO model whose observation and action spaces are
    those of the environment ``env_kwargs`` describes (a model of another tier or n_max is
    refused) and, given ``tier_kwargs``, whose actions are those of the tier's environment (its
    n_max and module types), else a ValueError naming ``what`` (``--resume``,
    ``--publish-run``). Returns its policy network."""
    from modquad_gym.envs.assembly import ModQuadAssemblyEnv
    from modquad_gym.policy.models import load_model

    path = Path(path)
    if path.is_dir():
        raise ValueError(f"{what} {path}: a folder; give the model .zip file in it")
    if path.exists() and not path.is_file():
        raise ValueError(f"{what} {path}: {NOT_REGULAR}")
    if not path.is_file():
        raise ValueError(f"{what} {path}: no such model file")
    try:
        model, _ = load_model(path)
    except ValueError as exc:
        reason = str(exc).split(": ", 1)[-1]
        raise ValueError(f"{what} {path}: {reason}") from None
    checks = [(env_kwargs, ("observation_space", "action_space"), "this run's")]
    if tier_kwargs is not None:
        checks.append((tier_kwargs, ("action_space",), "its tier's"))
    for kwargs, names, whose in checks:
        env = ModQuadAssemblyEnv(**kwargs)
        try:
            for name in names:
                if getattr(model, name) != getattr(env, name):
                    raise ValueError(
                        f"{what} {path}: trained on another environment (its {name} differs "
                        f"from {whose}: another tier, n_max or module types)"
                    )
        finally:
            env.close()
    return model


def check_network(path: Path, config: Any) -> None:
    """The model at ``path`` (``--init-from``, already :func:`check_model`-ed) has the network a
    new run of ``config`` builds (:meth:`~agents.config.TrainConfig.policy`): the same
    architecture, width and weights' shapes, so PPO can start from its weights; else a
    ValueError naming ``--init-from`` and what differs."""
    from modquad_gym.envs.assembly import ModQuadAssemblyEnv
    from modquad_gym.policy.models import read_model

    saved, where = read_model(path), f"--init-from {path}"
    policy, kwargs = config.policy()
    theirs = "candidates" if saved.size_free else "mlp"
    if theirs != config.architecture:
        raise ValueError(f"{where}: its network is --architecture {theirs}, this run's "
                         f"--architecture {config.architecture}")  # fmt: skip
    width = "hidden" if saved.size_free else "net_arch"
    default = {"hidden": 64, "net_arch": None}[width]  # what each class takes when not given
    if saved.policy_kwargs.get(width, default) != kwargs[width]:
        raise ValueError(f"{where}: its network's {width} is {saved.policy_kwargs.get(width)}, "
                         f"this run's {kwargs[width]} (--hyperparameters {width})")  # fmt: skip
    if policy == "MultiInputPolicy":
        from sb3_contrib.common.maskable.policies import MaskableMultiInputActorCriticPolicy

        policy = MaskableMultiInputActorCriticPolicy
    env = ModQuadAssemblyEnv(**config.env_kwargs_full)
    try:
        ours = policy(env.observation_space, env.action_space, lambda _: 0.0, **kwargs)
    finally:
        env.close()
    shapes = {k: tuple(v.shape) for k, v in ours.state_dict().items()}
    for key in sorted(set(shapes) | set(saved.weights)):
        mine, its = shapes.get(key), saved.weights.get(key)
        its = None if its is None else tuple(its.shape)
        if mine != its:
            raise ValueError(f"{where}: its network's {key} has shape {its}, this run's {mine}")


NOTHING = object()
"""Stands for "no value": every value of a field dropped this way is unused."""

CLONING = {"bc_epochs": 0, "demo_tasks": NOTHING, "expert": NOTHING, "dagger_rounds": 0,
           "dagger_tasks": NOTHING, "workers": NOTHING}  # fmt: skip
"""The fields of behaviour cloning (and DAgger), each with the value that asks for nothing
(NOTHING: none does)."""
AFTER_CLONING = {"critic_warmup": 0, "focus_tasks": 0, "focus_percent": NOTHING}
"""The fields that act on a cloned policy (the critic's warm-up, the tasks it misses)."""


def unused_fields(config: Any) -> dict[str, tuple[Any, str]]:
    """The fields of ``config`` (a TrainConfig, or train.py's parsed options) that its run
    would not use: {field: (the one value that agrees with the run, or NOTHING; the option
    that drops it, with why)}; ``hyperparameters`` keys: :func:`unused_hyperparameters`."""
    rules = [
        (config.resume is not None, "--resume (it continues the saved model as it is: no "
         "cloning, no critic warm-up, no focus tasks)", {**CLONING, **AFTER_CLONING}),
        (config.init_from is not None, "--init-from (PPO starts from that model's policy: no "
         "demonstrations, no cloning)", CLONING),
        (config.bc_epochs == 0, "--bc-epochs 0 (PPO alone from scratch: no demonstrations, "
         "no cloned policy)", {**CLONING, **AFTER_CLONING}),
        (config.focus_tasks == 0, "--focus-tasks 0 (no tasks to focus on)",
         {"focus_percent": NOTHING}),
        (config.dagger_rounds == 0, "--dagger-rounds 0 (no DAgger round)",
         {"dagger_tasks": NOTHING}),
        (config.advantage != "group", f"--advantage {config.advantage} (only --advantage "
         "group samples groups)", {"group_size": NOTHING}),
    ]  # fmt: skip
    unused: dict[str, tuple[Any, str]] = {}
    for applies, why, dropped in rules:
        for name, agrees in dropped.items() if applies else ():
            unused.setdefault(name, (agrees, why))
    return unused


def unused_hyperparameters(config: Any) -> dict[str, tuple[Any, str]]:
    """The ``--hyperparameters`` keys a run of ``config`` would not use, as
    :func:`unused_fields` gives them: every key with ``--resume`` (the saved model keeps its
    own), the other architecture's size, ``kl_coef`` without a cloned policy to pull
    towards."""
    if config.resume is not None:
        why = "--resume (the saved model keeps its own hyperparameters)"
        return {key: (NOTHING, why) for key in config.hyperparameters}
    other = "net_arch" if config.architecture == "candidates" else "hidden"
    unused = {other: (NOTHING, f"--architecture {config.architecture} (net_arch sizes the "
                               "mlp network, hidden the candidates one)")}  # fmt: skip
    if config.init_from is None and config.bc_epochs == 0:
        unused["kl_coef"] = (0, "--bc-epochs 0 (no cloned policy to pull towards)")
    return unused


def check_used(config: Any, given: Iterable[str]) -> None:
    """A ValueError naming the first field of ``given`` (the options the user set) that the run
    of ``config`` would drop, and the option that drops it; a field set to the one value that
    agrees with the run (``--dagger-rounds 0`` with ``--bc-epochs 0``) passes. Both doors call
    it: :class:`~agents.config.TrainConfig` with the fields set away from their defaults,
    ``train.py`` also with the options typed."""
    unused = unused_fields(config)
    for name in given:
        agrees, why = unused.get(name, (None, ""))
        value = getattr(config, name)
        if why and (agrees is NOTHING or value != agrees):
            raise ValueError(f"{option(name)} {value}: not used with {why}")
    unused = unused_hyperparameters(config)
    for key, value in config.hyperparameters.items():
        agrees, why = unused.get(key, (None, ""))
        if why and (agrees is NOTHING or value != agrees):
            raise ValueError(f"--hyperparameters: {key} is not used with {why}")
