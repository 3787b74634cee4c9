"""The environment's Gymnasium spec made true for its arguments (a mixin of the env class).

``gym.make`` copies an id's registration into ``env.spec``; the registration cannot know the
keywords of one ``gym.make`` call. :class:`ArgumentSpec` fills in the env's own success
threshold. The step limit stays out of the spec: the ids register no ``max_episode_steps``
(the env truncates itself at its own ``max_steps``, which follows ``n_max``), and a spec that
carried it would make ``gym.make(env.spec, n_max=N)`` add a ``TimeLimit`` at the old limit.
"""

from __future__ import annotations

import dataclasses
from typing import TYPE_CHECKING

from modquad_gym.envs.assembly.reward import WeightedReward, success_threshold

if TYPE_CHECKING:
    from gymnasium.envs.registration import EnvSpec

DEFAULT_N_MAX = 7
"""The default ``n_max`` (the paper's)."""
ENTRY_POINT = "modquad_gym.envs.assembly:ModQuadAssemblyEnv"
"""The Gymnasium entry point of the assembly environment (every registered id's)."""


class ArgumentSpec:
    """``spec`` and ``reward_threshold`` for an env with ``n_max`` and ``reward``."""

    @property
    def reward_threshold(self) -> float | None:
        """The success threshold of this env's reward at its n_max (the default reward's only;
        None for another reward): :func:`~.reward.success_threshold`."""
        if type(self.reward) is not WeightedReward:
            return None
        return success_threshold(self.reward.weights, self.n_max)

    @property
    def spec(self) -> EnvSpec | None:
        """Gymnasium's spec (set by ``gym.make``), true for this env's arguments: for an id of
        :data:`ENTRY_POINT` (every registered one) its ``reward_threshold`` is the env's own
        (``gym.make(id, n_max=N)`` changes it). ``max_episode_steps`` is left as made (None
        unless ``gym.make(..., max_episode_steps=M)`` added a ``TimeLimit``); the env's own
        limit is ``max_steps``."""
        return self.__dict__.get("_spec")

    @spec.setter
    def spec(self, spec: EnvSpec | None) -> None:
        if spec is not None and spec.entry_point == ENTRY_POINT:
            spec = dataclasses.replace(spec, reward_threshold=self.reward_threshold)
        self.__dict__["_spec"] = spec
