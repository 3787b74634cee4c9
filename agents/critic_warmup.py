"""A warm-up for PPO from a cloned policy: only the critic learns at first.

With ``--critic-warmup N`` (:mod:`.training`) the actor's parameters are frozen for the first N
PPO steps, so the critic fits the cloned policy's returns before any policy update moves it.
"""

from __future__ import annotations

from typing import Any

from modquad_gym.core.extras import import_optional


def critic_parameters(policy: Any) -> set[str]:
    """Names of the parameters of ``policy`` (an SB3 actor-critic) that only the critic uses:
    its value head and the critic's own layers (``critic`` in the candidates network, the
    ``value_net`` branch of SB3's MLP extractor). Every other parameter moves the actor."""
    return {
        name
        for name, _ in policy.named_parameters()
        if name.startswith(("value_net.", "mlp_extractor.value_net.", "vf_features_extractor."))
        or name.startswith("features_extractor.critic.")
    }


def critic_warmup_class():
    """:class:`CriticWarmup`, built on first use so importing this module needs no SB3."""
    BaseCallback = import_optional("stable_baselines3.common.callbacks").BaseCallback

    class CriticWarmup(BaseCallback):
        """Freezes every parameter of the actor for the first ``steps`` PPO steps, so the
        critic fits the cloned policy's returns before any policy update (the first updates
        then follow fitted advantages instead of a critic's errors)."""

        def __init__(self, steps: int) -> None:
            super().__init__()
            self.steps = steps
            self.frozen: list = []

        def _on_training_start(self) -> None:
            critic = critic_parameters(self.model.policy)
            if self.num_timesteps < self.steps:
                self.frozen = [p for name, p in self.model.policy.named_parameters()
                               if name not in critic and p.requires_grad]  # fmt: skip
                for p in self.frozen:
                    p.requires_grad_(False)

        def _on_step(self) -> bool:
            if self.frozen and self.num_timesteps >= self.steps:
                self.thaw()
            return True

        def _on_training_end(self) -> None:
            self.thaw()

        def thaw(self) -> None:
            for p in self.frozen:
                p.requires_grad_(True)
            self.frozen = []

    return CriticWarmup
