"""Import path kept for :mod:`modquad_gym.envs.assembly.reward` (moved there)."""

from .assembly.reward import (
    RewardFn,
    RewardWeights,
    WeightedReward,
    episode_return,
)

__all__ = ["RewardFn", "RewardWeights", "WeightedReward", "episode_return"]
