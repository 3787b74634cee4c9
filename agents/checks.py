"""Checks of a training run's inputs before any work: the recipe's numbers, its environment, the
PPO hyperparameters, and a saved model that is resumed or published.

Each check raises ValueError naming the ``train.py`` option (``--seed``, ``--hyperparameters``,
``--resume``, ...) and the value, so ``train.py`` stops in one line (exit 2) before it builds
environments, collects demonstrations or replaces a shipped model.
"""

from __future__ import annotations

import numbers
from dataclasses import fields
from pathlib import Path
from typing import Any

from modquad_gym.core.interrupts import one_line
from modquad_gym.core.resources import usable_cpus
from modquad_gym.core.validation import check_int, check_real

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
}
"""(type, low, high, low included) per MaskablePPO hyperparameter; ``net_arch`` is a list."""


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
    """Every value of ``hp`` (``--hyperparameters``) of the right type and range."""
    for key, value in hp.items():
        where = f"--hyperparameters: {key}"
        if key == "net_arch":
            ok = isinstance(value, list) and 1 <= len(value) <= 16
            if not ok or not all(_is_int(v) and 1 <= v <= 4096 for v in value):
                raise ValueError(
                    f"{where} must be a list of 1 to 16 layer widths in 1..4096, got {value!r}"
                )
            continue
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
    ``--n-max`` and the extra keywords (``--env-kwargs``), each named when it is wrong."""
    from modquad_gym.envs.assembly import ModQuadAssemblyEnv
    from modquad_gym.envs.assembly.env import N_MAX_LIMIT
    from modquad_gym.tasks import make_generator

    try:
        make_generator(config.source)
    except ValueError as exc:
        raise ValueError(f"--task-source {config.source!r}: {exc}") from None
    check_int(config.max_modules, "--n-max", low=2, high=N_MAX_LIMIT)
    try:
        ModQuadAssemblyEnv(**config.env_kwargs_full).close()
    except (TypeError, ValueError) as exc:
        raise ValueError(f"--env-kwargs {config.env_kwargs}: {one_line(exc)}") from None


def check_model(path: Path, env_kwargs: dict, what: str, tier_kwargs: dict | None = None) -> None:
    """The file ``path`` is a saved MaskablePPO model whose observation and action spaces are
    those of the environment ``env_kwargs`` describes (a model of another tier or n_max is
    refused) and, given ``tier_kwargs``, whose actions are those of the tier's environment (its
    n_max and module types), else a ValueError naming ``what`` (``--resume``,
    ``--publish-run``)."""
    from modquad_gym.envs.assembly import ModQuadAssemblyEnv
    from modquad_gym.policy.models import load_model

    path = Path(path)
    if path.is_dir():
        raise ValueError(f"{what} {path}: a folder; give the model .zip file in it")
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


def check_publishable(run: Path, tier_kwargs: dict) -> None:
    """A run folder whose model may become a tier's shipped model: its config is readable, its
    model loads and plays its own environment and the tier's actions (``--publish-run``)."""
    import json

    try:
        config = json.loads((Path(run) / "config.json").read_text())
        env_kwargs = dict(config.get("env_kwargs", {}))
    except (OSError, ValueError, AttributeError, TypeError) as exc:
        raise ValueError(f"--publish-run {run}: its config.json is not a run's ({exc})") from None
    check_model(Path(run) / "model.zip", env_kwargs, "--publish-run", tier_kwargs)
