"""Policy inference: the shipped models (:mod:`.models`), decoding a trained policy into a
structure (:mod:`.ppo`) and the policy-guided best-first search (:mod:`.guided`).

Training lives outside the package, in the repository's top-level ``agents/``; what is here is
what an installed wheel needs to answer ``modquad solve --method ppo``. The shipped models act
through their actors in NumPy (:mod:`.inference`); torch and SB3 load only for a model without
a fresh one.
"""

from modquad_gym.policy.models import (
    DEFAULT_MODEL,
    MODELS_DIR,
    SCALE_FROM,
    SCALE_MODEL,
    default_model,
    shipped_model,
)

__all__ = [
    "DEFAULT_MODEL",
    "MODELS_DIR",
    "SCALE_FROM",
    "SCALE_MODEL",
    "default_model",
    "shipped_model",
]
