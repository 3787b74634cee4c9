"""The assembly env's pluggable parts: reward, viewer, state, transitions, module set and
observation blocks."""

import dataclasses

import gymnasium as gym
import numpy as np
import pytest

import modquad_gym.envs  # noqa: F401  (registers the environments)
from modquad_gym.envs.assembly import (
    AssemblyState,
    AssemblyViewer,
    Episode,
    ModQuadAssemblyEnv,
    OneType,
    Palette,
    RewardFn,
    WeightedReward,
)
from modquad_gym.envs.assembly.features import observation_blocks
from modquad_gym.envs.assembly.grid import Grid
from modquad_gym.envs.assembly.transitions import initial_state, transition
from modquad_gym.tasks import TaskRequirement


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


# --- the state, the transitions and the module set as parts ----------------------------------
def test_states_are_frozen_with_read_only_arrays():
    env = ModQuadAssemblyEnv(tasks="paper", lookahead=True, modules="t45,flat")
    env.reset(seed=3)
    state = env.state
    with pytest.raises(dataclasses.FrozenInstanceError):
        state.cells = ((0, 0), (1, 0))
    for name in ("occupancy", "mask", "structure_vec", "types_onehot", "candidates"):
        with pytest.raises(ValueError, match="read-only"):
            getattr(state, name)[0] = 1
    obs, *_ = env.step(env.action_of((1, 0), 1))
    obs["action_mask"][:] = 0  # observations are the caller's copies
    assert env.state.mask.any() and env.state.but(steps=9).steps == 9 and env.state.steps == 1


def test_transitions_are_functions_of_an_episode_context_and_a_state():
    """No env needed: the pure transitions, given the parts, replay what the env does."""
    env = ModQuadAssemblyEnv(tasks="planted", modules="t45,flat", lookahead=True, n_max=5)
    obs, _ = env.reset(seed=2)
    task = env.task
    palette = Palette("t45,flat")
    evaluator = palette.evaluator(5, task.f_max, env.n_directions, "auto")
    ep = Episode(env.rules, Grid(5, 2), palette, evaluator, {}, {})
    arrays = evaluator.task_arrays(task)
    state = initial_state(ep, arrays, (0,))
    rows = obs["candidates"].reshape(state.mask.size, -1)  # the state keeps the valid rows
    np.testing.assert_array_equal(state.candidates, rows[np.flatnonzero(state.mask)])
    assert not rows[state.mask == 0].any()
    rng = np.random.default_rng(0)
    while not state.done:
        a = int(rng.choice(np.flatnonzero(state.mask)))
        again = transition(ep, state, a, True)
        state = transition(ep, state, a, True)
        assert state.cells == again.cells and state.frac == again.frac
        obs, _, term, _, info = env.step(a)
        for name in ("mask", "occupancy", "types_onehot", "structure_vec", "candidates"):
            np.testing.assert_array_equal(getattr(state, name), getattr(env.state, name))
        assert (state.terminated, state.success, state.cells) == (
            term,
            info["success"],
            tuple(map(tuple, info["cells"])),
        )


def test_one_env_class_takes_any_module_set():
    mixed = gym.make("ModQuadAssemblyMixed-v1").unwrapped
    assert type(mixed) is ModQuadAssemblyEnv and mixed.n_types == 3
    env = ModQuadAssemblyEnv(modules=Palette("t45,flat", initial_type=1))
    env.reset(seed=0)
    assert env.state.types == (1,) and env.palette[1].name == "flat"
    one = ModQuadAssemblyEnv(modules=OneType())
    assert one.palette is None and one.n_types == 1 and one.action_space.n == 13**2
    with pytest.raises(ValueError, match="initial_type needs a palette"):
        ModQuadAssemblyEnv(initial_type=1)
    with pytest.raises(ValueError, match="not both"):
        ModQuadAssemblyEnv(module=OneType().module, modules="t45")
    with pytest.raises(ValueError, match="carries its own"):
        ModQuadAssemblyEnv(modules=Palette("t45"), initial_type=0)


def test_a_one_type_palette_looks_ahead_with_the_child_mass():
    """A palette of one type decides external tasks: each child's row is that of the child's
    own mass (parent + one module)."""
    task = TaskRequirement([[0.0, 0.0, 5.0, 0.0, 0.0, 0.1]], kind="external", f_max=2.0)
    env = ModQuadAssemblyEnv(modules="t45", lookahead=True, tasks=task, n_max=4)
    obs, _ = env.reset(seed=0)
    rows = obs["candidates"].reshape(-1, 5)
    ev = env.evaluator
    for a in np.flatnonzero(obs["action_mask"]):
        key = env.module_set.key(((0, 0), env.cell_of(a)), (0, 0))
        expected = ev.candidate_rows([key], env.state.task, 0.6, {})[0]
        np.testing.assert_array_equal(rows[a], expected)
