"""The assembly env's pluggable parts: reward, viewer, state and observation blocks."""

import gymnasium as gym
import numpy as np
import pytest

import modquad_gym.envs  # noqa: F401  (registers the environments)
from modquad_gym.envs.assembly import (
    AssemblyState,
    AssemblyViewer,
    ModQuadAssemblyEnv,
    RewardFn,
    WeightedReward,
)
from modquad_gym.envs.assembly.features import observation_blocks


class ModuleCount:
    """A reward without terms: minus the number of modules after the step."""

    def __call__(self, state, action, next_state, is_valid):
        return -float(len(next_state.cells))


class SatisfiedWithBonus(WeightedReward):
    """The default terms plus one: how adding a reward term looks."""

    def terms(self, state, action, next_state, is_valid):
        out = super().terms(state, action, next_state, is_valid)
        out["bonus"] = 0.5 if is_valid else 0.0
        return out


def play(env, seed=0, steps=30):
    rng = np.random.default_rng(seed)
    obs, _ = env.reset(seed=seed)
    rows = []
    for _ in range(steps):
        valid = np.flatnonzero(obs["action_mask"])
        a = int(valid[rng.integers(len(valid))]) if len(valid) else 0
        obs, r, term, trunc, info = env.step(a)
        rows.append((r, info))
        if term or trunc:
            obs, _ = env.reset()
    return rows


def test_a_custom_reward_replaces_the_default_and_the_default_is_the_weighted_one():
    assert isinstance(ModuleCount(), RewardFn) and isinstance(WeightedReward(), RewardFn)
    env = gym.make("ModQuadAssembly-v0", tasks="paper", reward=ModuleCount())
    for r, info in play(env):
        assert r == -info["n_modules"] and info["reward_terms"] == {"reward": r}
    default = play(gym.make("ModQuadAssembly-v0", tasks="paper"))
    explicit = play(gym.make("ModQuadAssembly-v0", tasks="paper", reward=WeightedReward()))
    assert [r for r, _ in default] == [r for r, _ in explicit]


def test_a_new_reward_term_shows_in_the_info_and_the_reward():
    env = gym.make("ModQuadAssembly-v0", tasks="paper", reward=SatisfiedWithBonus())
    base = play(gym.make("ModQuadAssembly-v0", tasks="paper"))
    for (r, info), (r0, _) in zip(play(env), base):
        assert info["reward_terms"]["bonus"] == 0.5
        assert r == pytest.approx(r0 + 0.5)
        assert r == float(sum(info["reward_terms"].values()))


def test_reward_arguments_are_checked():
    with pytest.raises(ValueError, match="not both"):
        ModQuadAssemblyEnv(reward=ModuleCount(), reward_weights={"w_sat": 2.0})
    with pytest.raises(ValueError, match="reward must be a RewardFn"):
        ModQuadAssemblyEnv(reward=3)


def test_the_reward_sees_the_states_before_and_after_a_step():
    seen = []

    def spy(state, action, next_state, is_valid):
        seen.append((state, action, next_state, is_valid))
        return 0.0

    env = ModQuadAssemblyEnv(tasks="paper", reward=spy)
    env.reset(seed=1)
    before = env.state
    occupancy = before.occupancy.copy()
    a = env.action_of((1, 0))
    env.step(a)
    state, action, after, valid = seen[-1]
    assert state is before and after is env.state and action == a and valid
    assert isinstance(after, AssemblyState) and after.n_modules == 2 and state.n_modules == 1
    np.testing.assert_array_equal(state.occupancy, occupancy)  # the old state is unchanged
    env.step(a)  # occupied now: invalid
    assert seen[-1][3] is False and seen[-1][2].cells == after.cells


def test_a_given_viewer_renders_the_text_grid():
    viewer = AssemblyViewer(radius=2, n_max=3, size=(64, 64))
    env = ModQuadAssemblyEnv(tasks="screwdriver", n_max=3, render_mode="ansi", viewer=viewer)
    env.reset(seed=0)
    assert env.viewer is viewer
    text = env.render()
    assert "@" in text and text.count("+") == 4 and len(text.splitlines()) == 6
    env = ModQuadAssemblyEnv(tasks="screwdriver", n_max=3, render_mode="rgb_array", viewer=viewer)
    env.reset(seed=0)
    assert env.render().shape == (64, 64, 3)


def test_observation_blocks_derive_the_spaces():
    env = ModQuadAssemblyEnv(tasks="paper", lookahead=True)
    features = next(iter(env.evaluators.values())).features  # the one made for the spaces
    blocks = observation_blocks(env.side**2, 1, features, True)
    names = ["occupancy", "action_mask", "task", "structure", "candidates"]
    assert [b.name for b in blocks] == names
    for b in blocks:
        assert env.observation_space[b.name] == b.space()
    obs, _ = env.reset(seed=0)
    for b in blocks:
        assert obs[b.name].shape == (b.size,) and obs[b.name].dtype == b.dtype
