"""Gymnasium conventions of the assembly envs: a spec re-made with other arguments, frames that
show the env's own decision, ``"human"`` drawing in reset/step, ``initial_type`` in reset options
and what :class:`~modquad_gym.envs.wrappers.NearestValidAction` does where nothing is left."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.error import ResetNeeded

import modquad_gym  # noqa: F401 - registers the environments
from modquad_gym.envs.wrappers import NearestValidAction
from modquad_gym.oracle import feasible

IMPOSSIBLE = np.array([[0.0, 0.0, 1e3, 0.0, 0.0, 0.0]])
"""A lift no structure of <= 128 modules makes: episodes end at n_max modules, never sooner."""


def _impossible(rng: np.random.Generator) -> np.ndarray:
    return IMPOSSIBLE


# --- the spec carries no stale step limit ---------------------------------------------------
def test_remade_from_spec_with_another_n_max_runs_valid_actions_to_n_max_modules():
    small = gym.make("ModQuadAssembly-v0", n_max=3, tasks=_impossible)  # its limit: 12 steps
    env = gym.make(small.spec, n_max=20)  # 19 valid steps: past the small env's limit
    assert env.unwrapped.max_steps == 80
    env.reset(seed=0)
    steps, done = 0, False
    while not done:
        valid = np.flatnonzero(env.unwrapped.action_masks())
        _, _, terminated, truncated, info = env.step(int(valid[-1]))
        steps, done = steps + 1, terminated or truncated
    assert (steps, info["n_modules"], terminated, truncated) == (19, 20, True, False)

    vec = gym.make_vec(small.spec, num_envs=1, vectorization_mode="sync", n_max=20)
    vec.reset(seed=0)
    steps, done = 0, False
    while not done and steps < 80:
        mask = vec.call("action_masks")[0]
        _, _, terminated, truncated, info = vec.step(np.array([np.flatnonzero(mask)[-1]]))
        steps, done = steps + 1, terminated[0] or truncated[0]
    assert (steps, int(info["n_modules"][0]), terminated[0], truncated[0]) == (19, 20, True, False)
    vec.close()
    assert small.spec.max_episode_steps is None  # the limit is the env's max_steps


# --- frames show the decision the env rewards -----------------------------------------------
def _strip(frame: np.ndarray, t: int) -> np.ndarray:
    """bool (t,): the frame's bottom strip read back, True where a cell is green."""
    edges = np.linspace(0, frame.shape[1], t + 1).round().astype(int)
    row = frame[-1, (edges[:-1] + edges[1:]) // 2].astype(int)
    return row[:, 1] > row[:, 0]  # green (44, 160, 44), red (214, 39, 40)


@pytest.mark.parametrize(
    ("env_id", "kwargs"),
    [
        ("ModQuadAssemblyFaultTolerant-v0", {}),
        ("ModQuadAssembly-v0", {"fault": "module", "n_max": 6}),
        ("ModQuadAssembly-v0", {"fault": "rotor", "fault_margin": 0.2, "n_max": 6}),
    ],
)
def test_fault_env_frame_strip_agrees_with_satisfied_fraction(env_id, kwargs):
    env = gym.make(env_id, render_mode="rgb_array", render_size=(64, 512), **kwargs)
    u, states, intact_differs = env.unwrapped, 0, 0
    for seed in range(4):
        _, info = env.reset(seed=seed)
        rng, done = np.random.default_rng(seed), False
        while not done:
            t = info["n_wrenches"]
            shown = _strip(env.render(), t)
            assert np.count_nonzero(shown) / t == pytest.approx(info["satisfied_fraction"])
            W = u.evaluator.at_mass(u.state.task, u.structure.mass)[0]
            intact = feasible(u.structure.configuration_matrix(), W, u.evaluator.oracle.f_max)
            intact_differs += bool((np.asarray(intact) != shown).any())
            states += 1
            action = int(rng.choice(np.flatnonzero(u.action_masks())))
            _, _, terminated, truncated, info = env.step(action)
            done = terminated or truncated
    assert intact_differs > 0, "no state where the fault decision differs: the test shows nothing"
    env.close()


# --- "human" draws itself -------------------------------------------------------------------
def test_human_mode_draws_in_reset_and_step_without_render(monkeypatch):
    pytest.importorskip("pygame")
    monkeypatch.setenv("SDL_VIDEODRIVER", "dummy")
    env = gym.make("ModQuadAssembly-v0", tasks="screwdriver", n_max=4, render_mode="human")
    viewer, shown = env.unwrapped.viewer, []
    show = viewer.show
    monkeypatch.setattr(viewer, "show", lambda frame: (shown.append(frame), show(frame))[1])
    env.reset(seed=0)
    assert len(shown) == 1 and viewer.window is not None
    action = int(np.flatnonzero(env.unwrapped.action_masks())[0])
    env.step(action)
    assert len(shown) == 2
    pictures = gym.make("ModQuadAssembly-v0", tasks="screwdriver", n_max=4, render_mode="rgb_array")
    pictures.reset(seed=0)
    pictures.step(action)
    np.testing.assert_array_equal(shown[-1], pictures.render())  # the frame of the new state
    env.close()
    assert viewer.window is None


# --- reset options --------------------------------------------------------------------------
def test_reset_option_initial_type_random_means_what_the_constructor_means():
    drawn = gym.make("ModQuadAssemblyMixed-v1", initial_type="random")
    asked = gym.make("ModQuadAssemblyMixed-v1")  # initial type 0, unless an episode asks
    firsts = set()
    for seed in range(8):
        obs_d, info_d = drawn.reset(seed=seed)
        obs_a, info_a = asked.reset(seed=seed, options={"initial_type": "random"})
        assert info_a["modules"] == info_d["modules"] and info_a["task_name"] == info_d["task_name"]
        assert all(np.array_equal(obs_a[k], obs_d[k]) for k in obs_d)
        firsts.add(info_a["modules"][0])
    assert len(firsts) > 1  # drawn, not the env's type 0
    _, info = asked.reset(seed=0)
    assert info["modules"][0] == asked.unwrapped.palette[0].name  # the next episode: the env's
    with pytest.raises(ValueError, match=r"options\['initial_type'\].*got 'first'"):
        asked.reset(seed=0, options={"initial_type": "first"})


# --- NearestValidAction where nothing is left -----------------------------------------------
def test_nearest_valid_action_applies_a_valid_action_even_when_any_action_ends_the_episode():
    assert "ResetNeeded" in NearestValidAction.__doc__  # says what happens after the end
    env = NearestValidAction(gym.make("ModQuadAssembly-v0"))
    _, info = env.reset(seed=0, options={"task": np.array([[0, 0, 0.1, 0, 0, 0.0]])})
    assert info["success"]  # one module satisfies it: any action ends the episode
    mask = env.unwrapped.action_masks()
    _, _, terminated, _, info = env.step(-1)
    assert mask[info["applied_action"]] and info["requested_action"] == -1 and terminated
    with pytest.raises(ResetNeeded):
        env.step(0)
