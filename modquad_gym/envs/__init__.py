"""Gymnasium environments of modquad_gym, registered on import.

``import modquad_gym`` (or ``gym.make("modquad_gym:ModQuadAssembly-v0")``, which imports the
package first) registers:

* ``ModQuadAssembly-v0``: :class:`~modquad_gym.envs.assembly.env.ModQuadAssemblyEnv`, every keyword
  of its constructor accepted by ``gym.make``.
* ``ModQuadAssemblyPaper-v0``: the same with ``tasks="paper"`` (the paper's random tasks).
* ``ModQuadAssemblyPlanted-v0``: the same with ``tasks="planted"`` (tasks planted from a
  random structure, so a solution within n_max is known to exist).
* ``ModQuadAssemblyMixed-v0``: the same with ``modules="t45,t45m,flat"``: three module types,
  (cell, type) actions (:class:`~modquad_gym.envs.assembly.modules.Palette`).
* ``ModQuadAssemblyLarge-v0``: the same with ``n_max=12`` and ``tasks="planted-large"`` (tasks
  planted in 6-12 modules): the large benchmark tier (:mod:`modquad_gym.bench.tiers`).
"""

from __future__ import annotations

import gymnasium as gym

from modquad_gym.envs.assembly import (
    MAX_STEPS_LIMIT,
    AssemblyFeatures,
    AssemblyState,
    ModQuadAssemblyEnv,
    RewardFn,
    RewardWeights,
    WeightedReward,
    episode_return,
    unit_directions,
)

ENTRY_POINT = "modquad_gym.envs.assembly:ModQuadAssemblyEnv"

ENV_IDS: dict[str, dict] = {
    "ModQuadAssembly-v0": {},
    "ModQuadAssemblyPaper-v0": {"tasks": "paper"},
    "ModQuadAssemblyPlanted-v0": {"tasks": "planted"},
    "ModQuadAssemblyMixed-v0": {"modules": "t45,t45m,flat"},
    "ModQuadAssemblyLarge-v0": {"tasks": "planted-large", "n_max": 12},
}


def register_envs() -> None:
    """Register every id of :data:`ENV_IDS` with Gymnasium; a second call does nothing."""
    for env_id, kwargs in ENV_IDS.items():
        if env_id not in gym.registry:
            gym.register(
                id=env_id,
                entry_point=ENTRY_POINT,
                kwargs=dict(kwargs),
                max_episode_steps=MAX_STEPS_LIMIT,
            )


register_envs()

__all__ = [
    "ENV_IDS",
    "AssemblyFeatures",
    "AssemblyState",
    "ModQuadAssemblyEnv",
    "RewardFn",
    "RewardWeights",
    "WeightedReward",
    "episode_return",
    "register_envs",
    "unit_directions",
]
