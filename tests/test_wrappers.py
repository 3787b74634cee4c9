"""NearestValidAction: every action becomes a valid docking, valid ones are kept, the nearest
cell (of the same type) is chosen, and SB3 algorithms without masks run through it."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import modquad_gym  # noqa: F401 - registers the environments
from modquad_gym.envs.wrappers import NearestValidAction


@pytest.mark.parametrize("env_id", ["ModQuadAssembly-v0", "ModQuadAssemblyMixed-v1"])
def test_every_action_docks_a_module(env_id):
    env = NearestValidAction(gym.make(env_id, n_max=5))
    rng = np.random.default_rng(0)
    for episode in range(5):
        env.reset(seed=episode)
        done = False
        while not done:
            had_valid = env.unwrapped.action_masks().any()
            action = [int(rng.integers(env.action_space.n)), -1, 2.5, None][rng.integers(4)]
            _, _, terminated, truncated, info = env.step(action)
            assert bool(info["invalid_action"]) is (not had_valid)
            assert info["requested_action"] is action
            done = terminated or truncated


def test_valid_actions_are_kept_and_invalid_ones_go_to_the_nearest_cell():
    env = NearestValidAction(gym.make("ModQuadAssembly-v0", n_max=4))
    env.reset(seed=0)
    base = env.unwrapped
    right = base.action_of((1, 0))
    assert env.valid_action(right) == right  # valid: unchanged
    assert env.valid_action(base.action_of((3, 1))) == right  # (1, 0) is nearest to (3, 1)
    assert env.valid_action(base.action_of((0, -3))) == base.action_of((0, -1))
    assert env.valid_action(base.action_of((0, 0))) == base.action_of((0, -1))  # tie: lowest
    assert env.valid_action("nonsense") == base.action_of((0, -1))  # as the centre cell


def test_mixed_env_keeps_the_requested_type():
    env = NearestValidAction(gym.make("ModQuadAssemblyMixed-v1", n_max=4))
    env.reset(seed=0)
    base = env.unwrapped
    for k in range(3):
        applied = env.valid_action(base.action_of((3, 3), k))
        assert base.type_of(applied) == k
        assert base.cell_of(applied) in [(1, 0), (0, 1)]


def test_sb3_algorithms_without_masks_run_through_it():
    pytest.importorskip("stable_baselines3")
    from examples.unmasked_sb3 import main

    table = main(["--algos", "a2c", "dqn", "--steps", "60", "--tasks", "2"])
    assert [row["agent"] for row in table] == [
        "random actions + wrapper", "A2C + wrapper", "DQN + wrapper",
    ]  # fmt: skip
    assert all(row["invalid actions per episode"] == 0 for row in table)
