"""MaskablePPO with a KL term towards the cloned policy: fine-tuning that may move the actor
only as far as its advantages pay for.

The loss of each minibatch gains ``kl_coef * KL(pi || pi_cloned)``, the exact KL divergence
between the current and the frozen cloned policy's masked action distributions on the
minibatch's states (``hyperparameters`` key ``kl_coef``; 0: plain MaskablePPO). sb3-contrib's
``train`` adds ``ent_coef * -mean(entropy)`` with the entropy that ``evaluate_actions`` returns;
:class:`AnchoredPPO` (built by :func:`anchored_ppo_class`) overrides ``train`` to hand it
``entropy - kl_coef / ent_coef * KL`` instead, so the loss gains exactly the KL term and the
rest of the update is sb3-contrib's own (hence ``ent_coef`` > 0 is required).
"""

from __future__ import annotations

import copy
from typing import Any

from modquad_gym.core.extras import import_optional


def kl_divergence(policy: Any, anchor: Any, obs: Any, action_masks: Any) -> Any:
    """Per state KL(policy || anchor) of the masked action distributions (a torch tensor)."""
    import torch

    p = policy.get_distribution(obs, action_masks=action_masks).distribution
    with torch.no_grad():
        q = anchor.get_distribution(obs, action_masks=action_masks).distribution
    valid = torch.as_tensor(action_masks, dtype=torch.bool).reshape(p.logits.shape)
    terms = p.probs * (p.logits - q.logits)  # masked entries: probability 0
    return torch.where(valid, terms, torch.zeros_like(terms)).sum(-1)


def anchored_ppo_class():
    """:class:`AnchoredPPO`, built on first use so importing this module needs no SB3."""
    MaskablePPO = import_optional("sb3_contrib").MaskablePPO

    class AnchoredPPO(MaskablePPO):
        """MaskablePPO whose loss gains ``kl_coef`` times the KL divergence towards the policy
        frozen by :meth:`set_anchor` (the cloned one); without an anchor, plain MaskablePPO."""

        def __init__(self, *args: Any, kl_coef: float = 0.0, **kwargs: Any) -> None:
            super().__init__(*args, **kwargs)
            self.kl_coef = float(kl_coef)
            self.anchor = None

        def _excluded_save_params(self) -> list[str]:
            return [*super()._excluded_save_params(), "anchor"]

        def set_anchor(self) -> None:
            """Freeze a copy of the current policy as the one the KL term pulls towards."""
            self.anchor = copy.deepcopy(self.policy)
            self.anchor.set_training_mode(False)
            for p in self.anchor.parameters():
                p.requires_grad_(False)

        def train(self) -> None:
            if not self.kl_coef or self.anchor is None:
                return super().train()
            evaluate, kls = self.policy.evaluate_actions, []
            scale = self.kl_coef / self.ent_coef

            def anchored(obs: Any, actions: Any, action_masks: Any = None) -> tuple:
                values, log_prob, entropy = evaluate(obs, actions, action_masks=action_masks)
                kl = kl_divergence(self.policy, self.anchor, obs, action_masks)
                kls.append(float(kl.mean().detach()))
                return values, log_prob, entropy - scale * kl

            self.policy.evaluate_actions = anchored
            try:
                super().train()
            finally:
                del self.policy.evaluate_actions  # the class's method again
            self.logger.record("train/kl_to_cloned", sum(kls) / max(len(kls), 1))
            return None

    return AnchoredPPO
