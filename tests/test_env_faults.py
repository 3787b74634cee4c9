"""The fault-tolerant assembly environment (issue 37): ``fault=`` makes success mean that the
structure survives any single failure, ``ModQuadAssemblyFaultTolerant-v0`` registers it."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

import modquad_gym as mq


def test_registered_id_passes_the_checker_and_never_raises():
    env = gym.make("ModQuadAssemblyFaultTolerant-v0")
    assert env.unwrapped.fault == "rotor" and env.unwrapped.n_max == 10
    check_env(env.unwrapped, skip_render_check=True)
    env.reset(seed=1)
    for action in (-1, 10**9, 2.5, None, "3", [1, 2], np.nan):
        env.step(action)  # invalid: penalised, never raised


@pytest.mark.parametrize("fault", ["rotor", "module"])
def test_success_is_tolerance_and_satisfied_counts_tolerated_wrenches(fault):
    env = gym.make("ModQuadAssembly-v0", tasks="screwdriver", fault=fault, n_max=8)
    u = env.unwrapped
    rng = np.random.default_rng(0)
    successes = 0
    for episode in range(4):
        _, info = env.reset(seed=episode)
        done = False
        while not done:
            a = rng.choice(np.flatnonzero(info["action_mask"]))
            _, _, terminated, truncated, info = env.step(a)
            done = terminated or truncated
            task, s = u.task, u.structure
            ok = mq.tolerates(s, task.rotor_wrenches(s), task.f_max, fault=fault, method="daqp")
            assert info["success"] == bool(ok.all())
            assert info["satisfied_fraction"] == pytest.approx(ok.mean())
        successes += info["success"]
    assert successes >= 1


def test_the_minimum_tolerant_structure_succeeds_and_the_intact_one_does_not():
    env = gym.make("ModQuadAssembly-v0", tasks="screwdriver", fault="rotor")
    u = env.unwrapped
    _, info = env.reset(seed=0)
    for cell in [(0, 1), (1, 0)]:  # the intact minimum: 3 modules
        _, _, terminated, _, info = env.step(u.action_of(cell))
    assert info["n_modules"] == 3 and not info["success"] and not terminated
    _, _, terminated, _, info = env.step(u.action_of((2, 0)))  # the rotor-tolerant minimum
    assert info["success"] and terminated


def test_bad_fault_is_one_clear_error():
    with pytest.raises(ValueError, match="fault must be one of"):
        gym.make("ModQuadAssembly-v0", fault="wing")
