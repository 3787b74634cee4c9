"""The environment a saved model acts in: its ``config.json`` checked against its own spaces.

A model's observation space fixes its grid (n_max), its task directions, its lookahead rows
and its number of module types; its ``config.json`` (``env_kwargs``) may say the same, name the
module types and fix the environment's other keywords. Each key is checked here: a value of the
wrong type, one that contradicts the saved space, or a key that is no environment keyword is a
ValueError naming ``<folder>/config.json`` and the key, so a model never acts in an environment
it was not trained for, and never fails later with a message that names neither.
"""

from __future__ import annotations

import inspect
import math
from typing import Any

from modquad_gym.core.validation import check_int
from modquad_gym.envs.assembly import ModQuadAssemblyEnv
from modquad_gym.envs.assembly.features import MAX_N_DIRECTIONS, lookahead_width
from modquad_gym.envs.assembly.inputs import (
    check_invalid_action,
    check_lookahead,
    check_oracle_method,
    check_top_k,
)
from modquad_gym.envs.assembly.modules import Palette
from modquad_gym.envs.assembly.reward import make_reward

ENV_KWARG_KEYS = (
    "n_max", "n_directions", "reward_weights", "invalid_action", "oracle_method", "lookahead",
    "modules", "lookahead_top_k",
)  # fmt: skip
"""Environment keywords a model's config.json may fix (the task source is given per task)."""
ENV_KEYWORDS = frozenset(inspect.signature(ModQuadAssemblyEnv.__init__).parameters) - {"self"}
"""Every keyword of the environment: a config.json key outside them is refused; those outside
:data:`ENV_KWARG_KEYS` (the task source, the failure, ...) are set per problem instead."""


def saved_shape(space) -> dict:
    """What an observation space fixes: n_max (its grid), n_directions, lookahead and the
    number of module types."""
    side = math.isqrt(int(space["occupancy"].shape[0]))  # G * G cells, G = 2 n_max - 1
    return {
        "n_max": (side + 1) // 2,
        "n_directions": int(space["task"].shape[0]) - 7,
        "lookahead": lookahead_of(space),
        "n_types": int(space["action_mask"].shape[0]) // (side * side),
    }


def lookahead_of(space) -> bool | str:
    """The env's ``lookahead`` that made the observation ``space`` (by its rows' width)."""
    if "candidates" not in space.spaces:
        return False
    width = int(space["candidates"].shape[0]) // int(space["action_mask"].shape[0])
    return "exact" if width == lookahead_width("exact") else True


def env_kwargs_of(model, config: dict, where: str = "config", size_free: bool = False) -> dict:
    """The environment keywords ``model`` (a MaskablePPO, its policy network or its observation
    space) was trained with: its config's ``env_kwargs`` (:data:`ENV_KWARG_KEYS`), each checked
    against the saved space, the rest read from that space. ``where`` names the config in
    errors (``<folder>/config.json``); a model that is not ``size_free`` (one grid) with several
    module types needs them named there."""
    space = getattr(model, "observation_space", model)
    shape = saved_shape(space)
    given = config.get("env_kwargs", {})
    for key in given:
        if key not in ENV_KEYWORDS:
            raise ValueError(f"{where}: env_kwargs.{key} is no keyword of the environment (a "
                             f"model's config may fix {', '.join(ENV_KWARG_KEYS)})")  # fmt: skip
    if given.get("actions", "grid") != "grid":
        raise ValueError(f"{where}: env_kwargs.actions={given['actions']!r}: the learned "
                         "methods act on the grid encoding ('grid')")  # fmt: skip
    kwargs = {k: checked(k, v, shape, where) for k, v in given.items() if k in ENV_KWARG_KEYS}
    for key in ("n_max", "n_directions", "lookahead"):
        kwargs.setdefault(key, shape[key])
    if shape["n_types"] > 1 and "modules" not in kwargs and not size_free:
        raise ValueError(
            f"{where}: the model's saved spaces hold {shape['n_types']} module types but no "
            "env_kwargs.modules names them (its config.json beside it must)"
        )
    try:  # the env's own rule: a shortlist of the exact lookahead only
        check_top_k(kwargs.get("lookahead_top_k"), kwargs["lookahead"])
    except ValueError as exc:
        raise ValueError(f"{where}: env_kwargs.{exc}") from None
    return kwargs


def checked(key: str, value: Any, shape: dict, where: str) -> Any:
    """The config value ``value`` of ``key``, checked (its type, its range, the saved space)."""
    name = f"env_kwargs.{key}"
    try:
        if key == "n_max":
            value = check_int(value, name, low=1)
        elif key == "n_directions":
            value = check_int(value, name, 12, MAX_N_DIRECTIONS)
        elif key == "lookahead":
            value = check_lookahead(value)
        elif key == "lookahead_top_k":
            value = check_top_k(value, "exact")  # against the lookahead: env_kwargs_of
        elif key == "oracle_method":
            check_oracle_method(value)
        elif key == "invalid_action":
            check_invalid_action(value)
        elif key == "reward_weights":
            make_reward(None, value)
        elif key == "modules" and value is not None:
            n_types = Palette(value, 0).n_types
            if n_types != shape["n_types"]:
                raise ValueError(f"{name} names {n_types} module types; the model's saved "
                                 f"spaces hold {shape['n_types']}")  # fmt: skip
    except (TypeError, ValueError) as exc:
        text = " ".join(str(exc).split())
        if not text.startswith(name):  # the env's own words name the key without env_kwargs.
            text = f"{name}{text.removeprefix(key)}" if text.startswith(key) else f"{name}: {text}"
        raise ValueError(f"{where}: {text}") from None
    saved = shape.get(key)
    if saved is not None and key != "modules" and value != saved:
        raise ValueError(
            f"{where}: env_kwargs.{key} is {value!r}, but the model's saved observation space "
            f"is of {key} {saved!r}"
        )
    return value
