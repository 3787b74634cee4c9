"""Tests of the Gymnasium environment ModQuadAssembly-v0 (issue 5)."""

from __future__ import annotations

import math
import pickle
import subprocess
import sys
import warnings

import gymnasium as gym
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import modquad_gym.envs  # noqa: F401  (registers the environments)
from modquad_gym.envs import ENV_IDS, ModQuadAssemblyEnv, RewardWeights, register_envs
from modquad_gym.envs.assembly.features import CANDIDATE_FEATURES, AssemblyFeatures, unit_directions
from modquad_gym.envs.assembly.reward import episode_return
from modquad_gym.geometry.structure import Structure, is_connected
from modquad_gym.oracle import feasible
from modquad_gym.tasks import PlantedTasks, TaskGenerator, TaskRequirement, make_generator

SMALL = PlantedTasks(n_modules=(2, 4), n_wrenches=(4, 16))


def small_env(**kwargs) -> ModQuadAssemblyEnv:
    kwargs.setdefault("tasks", SMALL)
    kwargs.setdefault("n_max", 4)
    return ModQuadAssemblyEnv(**kwargs)


def random_masked_episode(env: ModQuadAssemblyEnv, seed: int) -> list:
    """Play one episode with seeded random valid actions; return everything observed."""
    rng = np.random.default_rng(seed)
    obs, info = env.reset(seed=seed)
    trace = [(obs, info)]
    done = False
    while not done:
        valid = np.flatnonzero(env.action_masks())
        a = int(valid[rng.integers(len(valid))]) if len(valid) else 0
        obs, r, term, trunc, info = env.step(a)
        trace.append((obs, r, term, trunc, info))
        done = term or trunc
    return trace


def assert_same(a, b) -> None:
    if isinstance(a, dict):
        assert a.keys() == b.keys()
        for k in a:
            assert_same(a[k], b[k])
    elif isinstance(a, (list, tuple)):
        assert len(a) == len(b)
        for x, y in zip(a, b):
            assert_same(x, y)
    elif isinstance(a, np.ndarray):
        np.testing.assert_array_equal(a, b)
    else:
        assert a == b


# --- registration and checkers --------------------------------------------------------------
def test_registered_ids_make_and_double_registration_is_harmless():
    register_envs()  # a second call must not raise or re-register
    for env_id, kwargs in ENV_IDS.items():
        env = gym.make(env_id)
        assert isinstance(env.unwrapped, ModQuadAssemblyEnv)
        if "tasks" in kwargs:
            assert env.unwrapped.task_source == kwargs["tasks"]
        env.close()
    env = gym.make("modquad_gym:ModQuadAssembly-v0", n_max=5)
    assert env.action_space.n == 9 * 9


def test_module_prefixed_id_makes_the_env_in_a_fresh_process():
    """gymnasium 1.x ignores the ``gymnasium.envs`` entry point; ``"modquad_gym:..."`` imports
    the package (which registers the ids) before making the env."""
    code = (
        "import sys, gymnasium as gym\n"
        "assert 'modquad_gym' not in sys.modules\n"
        "env = gym.make('modquad_gym:ModQuadAssembly-v0', n_max=4)\n"
        "obs, info = env.reset(seed=0)\n"
        "print(type(env.unwrapped).__name__, env.action_space.n, info['n_modules'])\n"
    )
    out = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, timeout=300, check=False
    )
    assert out.returncode == 0, out.stderr
    assert out.stdout.split() == ["ModQuadAssemblyEnv", "49", "1"]


@pytest.mark.parametrize("render_mode", [None, "rgb_array", "ansi"])
def test_gymnasium_check_env_passes_without_warnings(render_mode):
    from gymnasium.utils.env_checker import check_env

    env = gym.make("ModQuadAssembly-v0", tasks=SMALL, n_max=4, render_mode=render_mode)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        check_env(env.unwrapped)
    assert [str(w.message) for w in caught] == []


def test_sb3_check_env_passes_without_warnings():
    from stable_baselines3.common.env_checker import check_env

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        check_env(small_env(), warn=True)
    assert [str(w.message) for w in caught] == []


# --- spaces, masks, episode rules -------------------------------------------------------------
def test_action_masks_before_reset_match_the_initial_state():
    env = small_env()
    before = env.action_masks()
    assert before.dtype == bool and before.sum() == 4
    obs, info = env.reset(seed=3)
    np.testing.assert_array_equal(before, env.action_masks())
    np.testing.assert_array_equal(before, obs["action_mask"].astype(bool))
    np.testing.assert_array_equal(before, info["action_mask"])
    expected = {env.action_of(c) for c in [(1, 0), (-1, 0), (0, 1), (0, -1)]}
    assert set(np.flatnonzero(before)) == expected


def test_action_cell_mapping_is_the_documented_formula():
    env = small_env(n_max=5)
    G = 9
    for a in range(G * G):
        x, y = env.cell_of(a)
        assert a == (y + 4) * G + (x + 4) == env.action_of((x, y))
    with pytest.raises(ValueError, match="outside the grid"):
        env.action_of((5, 0))


def test_anything_but_a_valid_action_is_an_invalid_action_and_never_raises():
    env = small_env(max_steps=64)
    env.reset(seed=0)
    n = int(env.action_space.n)
    occupied = env.action_of((0, 0))
    far = env.action_of((3, 3))
    not_actions = (-1, n, 2**70, 2.5, float("nan"), float("inf"), True, np.bool_(False), None)
    not_actions += ("3", [1, 2], [], np.array([1, 2]), 1 + 0j, {}, object())
    in_space = (occupied, far, np.int64(far), np.array(far), np.uint8(occupied))
    for a in not_actions + in_space:
        obs, r, term, trunc, info = env.step(a)
        assert info["invalid_action"] and not term
        assert r == pytest.approx(-env.weights.w_invalid)
        assert info["cells"] == [[0, 0]]
        assert obs["occupancy"].sum() == 1 and obs["action_mask"].sum() == 4


def test_whole_number_floats_and_one_element_arrays_are_that_action():
    right = small_env().action_of((1, 0))
    for a in (
        float(right),
        np.float32(right),
        np.array([float(right)]),
        [right],
        np.array([[right]]),
    ):
        env, ref = small_env(), small_env()
        env.reset(seed=2)
        ref.reset(seed=2)
        got, expected = env.step(a), ref.step(right)
        assert_same(got, expected)
        assert got[-1]["cells"] == [[0, 0], [1, 0]] and not got[-1]["invalid_action"]


def test_a_masked_element_holds_no_action_and_an_unmasked_array_is_its_value():
    """A ``numpy.ma`` array with a masked element is an invalid action (np.asarray would drop
    the mask and dock at the hidden value); a masked array with nothing masked is its value."""
    right = small_env().action_of((1, 0))  # valid at reset: the hidden value would dock
    masked = (np.ma.array([right], mask=[True]), np.ma.array(right, mask=True))
    masked += (np.ma.array([[right]], mask=[[True]]), np.ma.array([right], mask=[True])[0])
    for a in masked:
        env = small_env()
        env.reset(seed=2)
        obs, r, term, trunc, info = env.step(a)
        assert info["invalid_action"] and not term and info["cells"] == [[0, 0]]
        assert r == pytest.approx(-env.weights.w_invalid) and obs["occupancy"].sum() == 1
    env, ref = small_env(), small_env()
    env.reset(seed=2)
    ref.reset(seed=2)
    got = env.step(np.ma.array([right], mask=[False]))
    assert_same(got, ref.step(right))
    assert got[-1]["cells"] == [[0, 0], [1, 0]] and not got[-1]["invalid_action"]


def test_terminate_mode_ends_the_episode_on_an_invalid_action():
    env = small_env(invalid_action="terminate")
    env.reset(seed=0)
    _, r, term, trunc, info = env.step(env.action_of((0, 0)))
    assert term and not trunc and not info["success"]
    assert r == pytest.approx(-env.weights.w_invalid)


def test_only_invalid_actions_truncate_at_max_steps():
    env = small_env(max_steps=5)
    env.reset(seed=0)
    flags = [env.step(env.action_of((0, 0)))[2:4] for _ in range(5)]
    assert flags[:-1] == [(False, False)] * 4 and flags[-1] == (False, True)
    with pytest.raises(gym.error.ResetNeeded):
        env.step(0)


def test_episodes_end_at_n_max_or_on_success():
    env = small_env()
    for seed in range(8):
        *_, last = random_masked_episode(env, seed)
        _, _, term, trunc, info = last
        assert term and not trunc
        assert info["success"] or info["n_modules"] == env.n_max
        # the terminal mask is never empty: the cells where a module could still dock
        cells = {tuple(c) for c in info["cells"]}
        free = {(x + dx, y + dy) for x, y in cells for dx, dy in ((1, 0), (-1, 0), (0, 1), (0, -1))}
        marked = {env.cell_of(a) for a in np.flatnonzero(info["action_mask"])}
        assert marked and marked == {c for c in free - cells if max(map(abs, c)) <= env.radius}


def test_task_solved_by_one_module_ends_on_the_next_step_without_adding():
    A = Structure([(0, 0)]).configuration_matrix()
    hover = TaskRequirement((A @ np.full(4, 0.5))[None], name="hover")
    env = small_env(tasks=hover)
    obs, info = env.reset(seed=0)
    assert info["success"] and info["satisfied_fraction"] == 1.0
    # the mask is that of the start (never empty); any action, even an occupied cell, ends it
    np.testing.assert_array_equal(obs["action_mask"], env.grid.initial_mask)
    _, r, term, trunc, info = env.step(env.action_of((0, 0)))
    assert not info["invalid_action"]
    assert term and info["success"] and info["n_modules"] == 1
    assert r == pytest.approx(env.weights.w_success)


def test_reset_option_task_and_info_keys():
    env = small_env()
    task = SMALL(np.random.default_rng(5))
    obs, info = env.reset(seed=1, options={"task": task})
    assert env.task is task and info["task_name"] == task.name
    assert info["n_wrenches"] == len(task.wrenches)
    for key in ("n_modules", "satisfied_fraction", "success", "cells", "evaluated"):
        assert key in info
    assert info["evaluated"] == 1 and info["cells"] == [[0, 0]]
    with pytest.raises(ValueError, match="unknown reset options"):
        env.reset(options={"tsk": task})
    with pytest.raises(ValueError, match=r"\(t, 6\)"):
        env.reset(options={"task": np.zeros((3, 5))})


def lifting_tasks(rng: np.random.Generator) -> np.ndarray:
    """A plain module-level task source gen(rng) that returns a wrench array."""
    return rng.uniform(-0.2, 0.2, size=(3, 6)) + [0.0, 0.0, 2.0, 0.0, 0.0, 0.0]


def test_any_callable_is_a_task_source():
    task = TaskRequirement(np.array([[0.0, 0.0, 2.0, 0.0, 0.0, 0.0]]), name="lift")
    env = gym.make("ModQuadAssembly-v0", tasks=lambda rng: task, n_max=4)
    obs, info = env.reset(seed=0)
    assert env.unwrapped.task is task and info["task_name"] == "lift"
    env = small_env(tasks=lifting_tasks)
    _, info = env.reset(seed=3)
    first = env.task
    assert isinstance(first, TaskRequirement) and first.name == "lifting_tasks"
    assert info["n_wrenches"] == 3
    env.reset(seed=3)
    np.testing.assert_array_equal(env.task.wrenches, first.wrenches)  # seeded
    env.step(env.action_of((1, 0)))
    clone = pickle.loads(pickle.dumps(env))  # a module-level function pickles
    assert_same(env.step(env.action_of((2, 0))), clone.step(clone.action_of((2, 0))))
    gen = make_generator(lifting_tasks)
    assert isinstance(gen, TaskGenerator) and gen.name == "lifting_tasks"
    assert isinstance(pickle.loads(pickle.dumps(gen))(np.random.default_rng(0)), TaskRequirement)
    mixed = make_generator([lifting_tasks, "paper"])
    assert {mixed(np.random.default_rng(s)).name for s in range(20)} == {
        "lifting_tasks",
        "paper-abs",
    }


class _NamedBadSource:
    name = "named-bad"

    def __call__(self, rng):
        return {"wrenches": []}


@pytest.mark.parametrize(
    "source, match",
    [
        (lambda rng: None, "NoneType"),
        (lambda rng: "task", "str"),
        (lambda rng: np.zeros((3, 5)), r"\(t, 6\)"),
        (lambda rng: np.zeros((0, 6)), "at least one wrench"),
        (lambda rng: np.full((2, 6), np.nan), "finite"),
        (_NamedBadSource(), "named-bad"),
    ],
)
def test_a_task_source_returning_no_task_raises_a_clear_error_at_reset(source, match):
    env = small_env(tasks=source)  # the source is not called before reset
    with pytest.raises(ValueError, match=match) as info:
        env.reset(seed=0)
    assert "task generator" in str(info.value)


def test_task_source_classes_are_refused_with_a_hint():
    with pytest.raises(ValueError, match=r"instance \(e.g. PlantedTasks\(\)\)"):
        small_env(tasks=PlantedTasks)


@pytest.mark.parametrize(
    "kwargs, match",
    [
        ({"n_max": 1}, "n_max"),
        ({"invalid_action": "ignore"}, "invalid_action"),
        ({"render_mode": "window"}, "render_mode"),
        ({"n_max": 129}, "n_max"),
        ({"max_steps": 513}, "max_steps"),
        ({"actions": "cells"}, "actions"),
        ({"reward_weights": {"w_modul": 1.0}}, "unknown reward weights"),
        ({"reward_weights": {"w_module": -1.0}}, "w_module"),
        ({"tasks": "no-such-source"}, "no-such-source"),
        ({"n_directions": 5}, "n_directions"),
        ({"lookahead": "yes"}, "lookahead"),
    ],
)
def test_bad_arguments_raise_value_errors(kwargs, match):
    with pytest.raises(ValueError, match=match):
        small_env(**kwargs)


# --- exactness of the reward signal ------------------------------------------------------------
def test_satisfied_fraction_agrees_with_the_oracle_at_every_step():
    env = ModQuadAssemblyEnv(tasks=PlantedTasks(n_wrenches=(10, 30)), n_max=6)
    for seed in range(4):
        trace = random_masked_episode(env, seed)
        W = env.task.wrenches
        for item in trace:
            info = item[-1]
            A = Structure([tuple(c) for c in info["cells"]]).configuration_matrix()
            assert info["satisfied_fraction"] == pytest.approx(feasible(A, W).mean())


def test_observation_is_invariant_to_the_order_of_the_task_wrenches():
    env = small_env()
    task = PlantedTasks(n_wrenches=40)(np.random.default_rng(2))
    perm = np.random.default_rng(0).permutation(40)
    shuffled = TaskRequirement(task.wrenches[perm], name=task.name)
    a = env.reset(options={"task": task})[0]
    b = env.reset(options={"task": shuffled})[0]
    for key in a:
        np.testing.assert_allclose(a[key], b[key], rtol=0, atol=1e-6)


def test_support_directions_are_fixed_unit_vectors():
    D = unit_directions(48)
    np.testing.assert_allclose(np.linalg.norm(D, axis=1), 1.0)
    np.testing.assert_array_equal(D, unit_directions(48))
    np.testing.assert_array_equal(D[:6], np.eye(6))


# --- determinism, pickling, vectorisation ----------------------------------------------------
def test_deterministic_under_seed():
    a = random_masked_episode(small_env(), seed=11)
    b = random_masked_episode(small_env(), seed=11)
    assert_same(a, b)
    c = random_masked_episode(small_env(), seed=12)
    assert not np.array_equal(c[0][0]["task"], a[0][0]["task"])  # another seed, another task


def test_pickled_env_continues_identically():
    env = small_env()
    env.reset(seed=4)
    env.step(env.action_of((1, 0)))
    clone = pickle.loads(pickle.dumps(env))
    for a in (env.action_of((2, 0)), env.action_of((0, 0)), env.action_of((1, 1))):
        assert_same(env.step(a), clone.step(a))


def test_subproc_vec_env_runs():
    from stable_baselines3.common.vec_env import SubprocVecEnv

    vec = SubprocVecEnv([small_env, small_env])
    try:
        vec.seed(0)
        obs = vec.reset()
        assert obs["action_mask"].shape == (2, 49)
        masks = np.stack(vec.env_method("action_masks"))
        for _ in range(4):
            actions = np.array([np.flatnonzero(m)[0] for m in masks])
            obs, rewards, dones, infos = vec.step(actions)
            masks = np.stack(vec.env_method("action_masks"))
            assert masks.any(axis=1).all()  # auto-reset keeps a valid action available
        assert rewards.shape == (2,)
    finally:
        vec.close()


def test_gymnasium_make_vec():
    vec = gym.make_vec(
        "ModQuadAssembly-v0", num_envs=2, vectorization_mode="sync", tasks=SMALL, n_max=4
    )
    obs, info = vec.reset(seed=0)
    assert obs["structure"].shape == (2, vec.single_observation_space["structure"].shape[0])
    obs, r, term, trunc, info = vec.step(np.array([24 + 1, 24 - 1]))  # (1, 0) and (-1, 0)
    assert np.all(info["n_modules"] == 2)
    vec.close()


# --- rendering ---------------------------------------------------------------------------------
def test_renders():
    env = small_env(render_mode="rgb_array", render_size=(64, 80))
    env.reset(seed=0)
    env.step(env.action_of((1, 0)))
    frame = env.render()
    assert frame.dtype == np.uint8 and frame.shape == (64, 80, 3) and frame.std() > 0
    env = small_env(render_mode="ansi")
    env.reset(seed=0)
    env.step(env.action_of((1, 0)))
    text = env.render()
    grid = text.splitlines()[1:]
    assert len(grid) == 7 and grid[3].split() == [".", ".", "+", "@", "#", "+", "."]


# --- properties (hypothesis) ---------------------------------------------------------------------
PROPERTY_ENV = {mode: small_env(invalid_action=mode) for mode in ("penalise", "terminate")}


@settings(max_examples=30, deadline=None)
@given(
    seed=st.integers(0, 2**16),
    actions=st.lists(st.integers(0, 48), min_size=1, max_size=20),
    mode=st.sampled_from(["penalise", "terminate"]),
)
def test_mask_structure_and_return_properties(seed, actions, mode):
    env = PROPERTY_ENV[mode]
    obs, info = env.reset(seed=seed)
    frac_0, total, n_invalid = info["satisfied_fraction"], 0.0, 0
    for a in actions:
        mask = env.action_masks().copy()
        before = info["cells"]
        obs, r, term, trunc, info = env.step(a)
        total += r
        assert sum(info["reward_terms"].values()) == pytest.approx(r)
        added = len(info["cells"]) == len(before) + 1
        assert bool(mask[a]) == added  # mask[a] exactly when the step docks a module
        if added:
            assert info["cells"][:-1] == before and list(env.cell_of(a)) == info["cells"][-1]
        else:
            assert info["cells"] == before  # an invalid action changes nothing
            n_invalid += int(info["invalid_action"])
        assert is_connected([tuple(c) for c in info["cells"]])
        assert info["evaluated"] == len(info["cells"])
        if term or trunc:
            break
    expected = episode_return(
        env.weights,
        frac_0,
        info["satisfied_fraction"],
        info["n_modules"],
        info["success"] and term,
        n_invalid,
    )
    assert total == pytest.approx(expected, abs=1e-9)


NOT_ACTIONS = st.one_of(
    st.integers(max_value=-1),
    st.integers(min_value=49),
    st.floats().filter(lambda x: not (math.isfinite(x) and x.is_integer() and 0 <= x < 49)),
    st.integers(0, 48).map(lambda a: a + 0.5),
    st.integers(0, 48).map(lambda a: np.float32(a - 49)),
    st.booleans(),
    st.builds(np.bool_, st.booleans()),
    st.none(),
    st.text(max_size=3),
    st.lists(st.integers(0, 48), min_size=2, max_size=3),
    st.lists(st.integers(0, 48), max_size=0),
    st.integers(0, 48).map(lambda a: np.array([a, a])),
    st.complex_numbers(allow_nan=False),
    st.dictionaries(st.text(max_size=1), st.integers(), max_size=1),
)


@settings(max_examples=60, deadline=None)
@given(
    seed=st.integers(0, 2**16),
    n_docked=st.integers(0, 2),
    action=NOT_ACTIONS,
    mode=st.sampled_from(["penalise", "terminate"]),
)
def test_non_actions_change_nothing_and_never_raise(seed, n_docked, action, mode):
    env = PROPERTY_ENV[mode]
    obs, info = env.reset(seed=seed)
    rng = np.random.default_rng(seed)
    for _ in range(n_docked):  # some valid steps first
        valid = np.flatnonzero(env.action_masks())
        if info["success"] or not len(valid):
            break
        obs, _, term, _, info = env.step(int(rng.choice(valid)))
        if term:
            return
    if info["success"]:  # solved at reset: any action just ends the episode
        return
    before = (obs, info["cells"], info["satisfied_fraction"], env.action_masks().copy())
    obs, r, term, trunc, info = env.step(action)
    assert info["invalid_action"]
    assert r == pytest.approx(-env.weights.w_invalid)
    assert term == (mode == "terminate")
    assert info["cells"] == before[1] and info["satisfied_fraction"] == before[2]
    for key in ("occupancy", "task", "structure"):
        np.testing.assert_array_equal(obs[key], before[0][key])
    if not term:
        np.testing.assert_array_equal(env.action_masks(), before[3])


def test_fewer_modules_earn_more_for_successful_episodes():
    w = RewardWeights()
    returns = [episode_return(w, 0.0, 1.0, n, True, 0) for n in range(1, 8)]
    assert all(a > b for a, b in zip(returns, returns[1:]))
    worst_success = returns[-1]
    best_failure = episode_return(w, 0.0, 0.99, 7, False, 0)
    assert worst_success > best_failure


# --- an RL library end to end --------------------------------------------------------------------
def test_maskable_ppo_learns_a_few_steps():
    import torch
    from sb3_contrib import MaskablePPO

    torch.set_num_threads(1)
    model = MaskablePPO("MultiInputPolicy", small_env(), n_steps=32, batch_size=32, seed=0)
    model.learn(64)
    env = small_env()
    obs, _ = env.reset(seed=0)
    action, _ = model.predict(obs, action_masks=env.action_masks(), deterministic=True)
    assert env.action_masks()[int(action)]


# --- lookahead (candidate) features -------------------------------------------------------------
def test_check_envs_pass_with_lookahead():
    from gymnasium.utils.env_checker import check_env as gym_check
    from stable_baselines3.common.env_checker import check_env as sb3_check

    env = gym.make("ModQuadAssembly-v0", tasks=SMALL, n_max=4, lookahead=True)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        gym_check(env.unwrapped)
        sb3_check(small_env(lookahead=True), warn=True)
    assert [str(w.message) for w in caught] == []
    assert env.observation_space["candidates"].shape == (49 * CANDIDATE_FEATURES,)
    assert "candidates" not in small_env().observation_space.spaces


def test_candidate_rows_are_zero_exactly_on_invalid_actions():
    env = ModQuadAssemblyEnv(tasks="mixed", n_max=6, lookahead=True)
    for seed in range(6):
        for item in random_masked_episode(env, seed):
            obs = item[0]
            rows = obs["candidates"].reshape(-1, CANDIDATE_FEATURES)
            valid = obs["action_mask"].astype(bool)
            assert np.all(rows[~valid] == 0.0)
            assert np.all(np.abs(rows[valid]).sum(axis=1) > 0)
            assert env.observation_space["candidates"].contains(obs["candidates"])


def test_candidate_rows_match_each_child_and_never_reject_a_feasible_wrench():
    env = ModQuadAssemblyEnv(tasks=PlantedTasks(n_wrenches=(10, 30)), n_max=6, lookahead=True)
    obs, _ = env.reset(seed=5)
    obs, *_ = env.step(env.action_of((1, 0)))
    W = env.task.wrenches
    feats = AssemblyFeatures(env.module, env.n_max, env.task.f_max, env.n_directions)
    h_Tn, WD = feats.task(W)[1:]
    rows = obs["candidates"].reshape(-1, CANDIDATE_FEATURES)
    for a in np.flatnonzero(obs["action_mask"]):
        child = Structure([(0, 0), (1, 0), env.cell_of(a)])  # its own COM and torques
        A = child.configuration_matrix()
        h, slack = feats.support(A)
        expected = feats.candidates(h[None], np.array([slack]), h_Tn, WD)[0]
        np.testing.assert_allclose(rows[a], expected, rtol=0, atol=1e-6)
        assert rows[a][4] <= 1.0 - feasible(A, W).mean() + 1e-9  # a necessary test only


def test_lookahead_is_deterministic_and_costs_no_oracle_call():
    a = random_masked_episode(small_env(lookahead=True), seed=7)
    assert_same(a, random_masked_episode(small_env(lookahead=True), seed=7))
    plain = random_masked_episode(small_env(), seed=7)
    for with_la, without in zip(a, plain):
        assert with_la[-1]["evaluated"] == without[-1]["evaluated"]
        assert with_la[-1]["oracle_calls"] == without[-1]["oracle_calls"]
        for key in without[0]:
            np.testing.assert_array_equal(with_la[0][key], without[0][key])
