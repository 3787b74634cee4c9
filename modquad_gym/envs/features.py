"""Import path kept for :mod:`modquad_gym.envs.assembly.features` (moved there)."""

from .assembly.features import (
    CANDIDATE_FEATURES,
    DEFAULT_N_DIRECTIONS,
    AssemblyFeatures,
    ObservationBlock,
    observation_blocks,
    unit_directions,
)

__all__ = [
    "CANDIDATE_FEATURES",
    "DEFAULT_N_DIRECTIONS",
    "AssemblyFeatures",
    "ObservationBlock",
    "observation_blocks",
    "unit_directions",
]
