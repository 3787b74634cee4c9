"""Reward of the assembly environment: satisfied wrenches up, module count down.

One step's reward is

    r_t = w_sat * (frac_t - frac_{t-1}) - w_module * added_t + w_success * success_t
          - w_invalid * invalid_t

with ``frac`` the fraction of task wrenches the structure can produce (decided by the exact
oracle), ``added`` 1 when the step docked a module, ``success`` 1 on the step that ends the
episode with every wrench satisfied, ``invalid`` 1 for an action whose cell cannot take a module.
The satisfaction term telescopes, so an episode's return is (see :func:`episode_return`)

    G = w_sat * (frac_T - frac_0) - w_module * (n_T - 1) + w_success * success
        - w_invalid * n_invalid.

For a successful episode frac_T = 1, so G falls by ``w_module`` per module: with ``w_module > 0``
fewer modules always earn more. Success beats every failed episode of the same task when
``w_success > w_module * (n_max - 1)`` (the defaults satisfy this up to n_max = 10).

The success threshold (:func:`success_threshold`; ``env.spec.reward_threshold`` of the
registered ids) is the least return of a successful episode without invalid actions,
``w_success - w_module * (n_max - 1)`` (frac_T = 1 >= frac_0 and at most n_max modules): 0.4
with the default weights at n_max = 7. It is defined only where success beats every failed
episode of the same task (the value is then > 0); with the default weights that is n_max <= 10,
so the ids at n_max 12 and 64 have none. Read it as a necessary mark, not a sufficient one: a
policy that succeeds on every task without invalid actions has a mean return of at least the
threshold, but a failed episode of an easy task can also return up to ``w_sat``.

A reward is any :class:`RewardFn`, ``reward(state, action, next_state, is_valid) -> float``,
given to the env as ``reward=``; :class:`WeightedReward` (this formula) is the default. To add a
term, subclass it and extend :meth:`WeightedReward.terms` (``info["reward_terms"]`` shows it).
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass
from typing import TYPE_CHECKING, Any, Protocol, runtime_checkable

if TYPE_CHECKING:
    from modquad_gym.envs.assembly.types import AssemblyState


@dataclass(frozen=True)
class RewardWeights:
    """Non-negative weights of the four reward terms (module docstring gives the formula).

    Args:
        w_sat: weight of the change in the fraction of satisfied wrenches.
        w_module: cost per docked module.
        w_success: bonus on the step that satisfies every wrench.
        w_invalid: penalty per invalid action (a cell that cannot take a module).
    """

    w_sat: float = 1.0
    w_module: float = 0.1
    w_success: float = 1.0
    w_invalid: float = 0.1

    def __post_init__(self) -> None:
        for name, value in asdict(self).items():
            if isinstance(value, bool) or not isinstance(value, (int, float)):
                raise ValueError(f"reward weight {name} must be a number, got {value!r}")
            if not (math.isfinite(value) and value >= 0):
                raise ValueError(f"reward weight {name} must be finite and >= 0, got {value!r}")

    @classmethod
    def coerce(cls, weights: RewardWeights | dict | None) -> RewardWeights:
        """Weights from None (defaults), a dict of some of the fields, or a RewardWeights."""
        if weights is None:
            return cls()
        if isinstance(weights, RewardWeights):
            return weights
        if isinstance(weights, dict):
            unknown = sorted(set(weights) - set(cls.__dataclass_fields__))
            if unknown:
                raise ValueError(
                    f"unknown reward weights {unknown}; known: {sorted(cls.__dataclass_fields__)}"
                )
            return cls(**weights)
        raise ValueError(f"reward_weights must be a RewardWeights, a dict or None, got {weights!r}")

    def terms(
        self, delta_frac: float, added: bool, success: bool, invalid: bool
    ) -> dict[str, float]:
        """The four signed reward terms of one step (their sum is the reward)."""
        return {
            "satisfaction": self.w_sat * float(delta_frac),
            "module": -self.w_module if added else 0.0,
            "success": self.w_success if success else 0.0,
            "invalid": -self.w_invalid if invalid else 0.0,
        }


def episode_return(
    weights: RewardWeights,
    frac_0: float,
    frac_T: float,
    n_modules: int,
    success: bool,
    n_invalid: int,
) -> float:
    """The documented return of an episode from its summary (equals the sum of step rewards)."""
    return (
        weights.w_sat * (frac_T - frac_0)
        - weights.w_module * (n_modules - 1)
        + weights.w_success * float(success)
        - weights.w_invalid * n_invalid
    )


def success_threshold(weights: RewardWeights, n_max: int) -> float | None:
    """The least return of a successful episode without invalid actions, ``w_success - w_module
    * (n_max - 1)`` (rounded to 12 decimals), where success beats every failed episode of the
    same task (that value > 0); else None (module docstring)."""
    value = round(weights.w_success - weights.w_module * (n_max - 1), 12)
    return value if value > 0 else None


@runtime_checkable
class RewardFn(Protocol):
    """A reward: the float earned by the step from ``state`` to ``next_state``. ``action`` is
    the parsed action (None when it was not an integer of the action space) and ``is_valid``
    is False for an invalid action. Optionally ``terms(...)`` (same arguments) returns the
    named parts for ``info["reward_terms"]``."""

    def __call__(
        self, state: AssemblyState, action: int | None, next_state: AssemblyState, is_valid: bool
    ) -> float: ...


class WeightedReward:
    """The default reward: the module docstring's four weighted terms.

    Args:
        weights: a :class:`RewardWeights`, a dict of some of its fields, or None (defaults).
    """

    def __init__(self, weights: RewardWeights | dict | None = None) -> None:
        self.weights = RewardWeights.coerce(weights)

    def terms(
        self, state: AssemblyState, action: Any, next_state: AssemblyState, is_valid: bool
    ) -> dict[str, float]:
        """The signed terms of one step (their sum is the reward)."""
        return self.weights.terms(
            next_state.frac - state.frac,
            len(next_state.cells) > len(state.cells),
            next_state.success and next_state.terminated,
            not is_valid,
        )

    def __call__(
        self, state: AssemblyState, action: Any, next_state: AssemblyState, is_valid: bool
    ) -> float:
        return float(sum(self.terms(state, action, next_state, is_valid).values()))

    def __repr__(self) -> str:
        return f"WeightedReward({self.weights!r})"


def make_reward(reward: Any, weights: RewardWeights | dict | None) -> RewardFn:
    """The env's reward from its ``reward`` and ``reward_weights`` arguments (at most one)."""
    if reward is None:
        return WeightedReward(weights)
    if weights is not None:
        raise ValueError("give reward= or reward_weights=, not both")
    if not callable(reward):
        raise ValueError(f"reward must be a RewardFn (a callable), got {reward!r}")
    return reward


def step_reward(
    reward: RewardFn, state: AssemblyState, action: Any, next_state: AssemblyState, is_valid: bool
) -> tuple[float, dict[str, float]]:
    """(reward, ``info["reward_terms"]``) of one step: the reward's own terms, or its value
    alone when it has none (the default reward's value is the sum of its terms)."""
    if type(reward) is WeightedReward:  # the default: computed once
        terms = reward.terms(state, action, next_state, is_valid)
        return float(sum(terms.values())), terms
    value = reward(state, action, next_state, is_valid)
    terms = getattr(reward, "terms", None)
    if terms is None:
        return value, {"reward": value}
    return value, terms(state, action, next_state, is_valid)


def reset_terms(reward: RewardFn, state: AssemblyState) -> dict[str, float]:
    """``info["reward_terms"]`` at reset: the terms of a step that changes nothing."""
    terms = getattr(reward, "terms", None)
    if terms is None:
        return {"reward": 0.0}
    return terms(state, None, state, True)
