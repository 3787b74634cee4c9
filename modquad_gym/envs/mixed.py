"""Import path kept for :mod:`modquad_gym.envs.assembly.mixed` (moved there)."""

from .assembly.mixed import (
    MixedAssemblyEnv,
)

__all__ = ["MixedAssemblyEnv"]
