"""The environment's edges that users hit (issue 34): example task names in ``tasks=``, the
episode limit following ``n_max``, no hidden answer in ``info`` or task names, the mixed id's
palette tasks, a re-makeable ``NearestValidAction`` and the ids' ``reward_threshold``."""

from __future__ import annotations

import warnings

import gymnasium as gym
import numpy as np
from gymnasium.utils.env_checker import check_env

import modquad_gym  # noqa: F401 - registers the environments
from modquad_gym.envs.wrappers import NearestValidAction


# --- NearestValidAction ---------------------------------------------------------------------
def test_nearest_valid_action_is_remade_from_its_spec_and_passes_check_env():
    env = NearestValidAction(gym.make("ModQuadAssembly-v0", n_max=5, tasks="planted"))
    (wrapper,) = env.spec.additional_wrappers
    assert wrapper.entry_point.endswith("wrappers:NearestValidAction") and wrapper.kwargs == {}
    again = gym.make(env.spec)
    assert isinstance(again, NearestValidAction) and again.unwrapped.n_max == 5
    a, b = env.reset(seed=3), again.reset(seed=3)
    assert all(np.array_equal(a[0][k], b[0][k]) for k in a[0])
    # the remade env acts the same: an invalid request docks at the same nearest cell
    far = env.unwrapped.action_of((4, 4))
    assert env.step(far)[4]["applied_action"] == again.step(far)[4]["applied_action"]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # check_env's note that the env is wrapped
        check_env(env, skip_render_check=True)
        check_env(again, skip_render_check=True)
