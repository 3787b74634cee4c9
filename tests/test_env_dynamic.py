"""The env with dynamic tasks (a motion): each docking decided on the structure's own rotor
wrenches (its mass and inertia), agreeing with the exact oracle and the certified searches."""

import warnings
from collections import deque

import gymnasium as gym
import numpy as np
import pytest

import modquad_gym as mq
from modquad_gym import dynamics as dy
from modquad_gym.envs import ENV_IDS
from modquad_gym.search import verified

N_MAX = 5
FAST = dy.circle(radius=1.0, speed=2.0, f_max=2.0, rate=10)  # level: mass only; optimum 4
TURNING = dy.circle(radius=1.0, speed=2.0, f_max=2.0, rate=10, heading="tangent")  # inertia: 3
PAYLOAD = dy.figure_eight(speed=1.0, payload=0.4, f_max=2.0, rate=10)


def make(task=TURNING, **kwargs):
    kwargs.setdefault("n_max", N_MAX)
    return gym.make("ModQuadAssembly-v0", tasks=task, **kwargs).unwrapped


def own_fraction(structure, task, fault=None):
    """The oracle's satisfied fraction on the structure's own rotor wrenches (tolerated ones
    under a ``fault``)."""
    W = task.rotor_wrenches(structure)
    if fault is not None:
        return float(mq.tolerates(structure, W, task.f_max, fault=fault).mean())
    return float(mq.feasible(structure.configuration_matrix(), W, task.f_max).mean())


def play_random(env, task, rng, episodes=4, masked=True):
    """Random episodes; success and the satisfied fraction checked against the oracle at every
    step; returns the module counts of the successes."""
    wins = []
    for seed in range(episodes):
        _, info = env.reset(seed=seed)
        done = False
        while not done:
            if masked:
                a = int(rng.choice(np.flatnonzero(env.action_masks())))
            else:
                a = [int(rng.integers(-3, env.action_space.n + 3)), 2.5, None, "3", -1][seed % 5]
            obs, _, term, trunc, info = env.step(a)
            done = term or trunc
            s = env.structure
            fraction = own_fraction(s, task, env.fault)
            if env.fault is None:
                assert info["success"] == verified(s, task), s.cells
            assert info["success"] == (fraction == 1.0), s.cells
            assert info["satisfied_fraction"] == pytest.approx(fraction, abs=1e-12)
            assert env.observation_space.contains(obs)
        if info["success"]:
            wins.append(info["n_modules"])
    return wins


@pytest.mark.parametrize("render_mode", [None, "rgb_array"])
def test_check_env_passes_with_a_dynamic_task(render_mode):
    from gymnasium.utils.env_checker import check_env

    env = make(render_mode=render_mode, n_max=4)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        check_env(env)
    assert [str(w.message) for w in caught] == []


@pytest.mark.parametrize("env_id", list(ENV_IDS))
def test_every_env_id_takes_a_dynamic_task(env_id):
    """Masked random episodes: success is the oracle's on the structure's own wrenches."""
    task = PAYLOAD if "Mixed" in env_id else TURNING
    env = gym.make(env_id, tasks=task).unwrapped
    play_random(env, task, np.random.default_rng(0), episodes=2)


@pytest.mark.parametrize("kwargs", [{}, {"lookahead": True}, {"modules": "t45,t45m,flat"}])
def test_random_actions_never_raise_and_agree_with_the_oracle(kwargs):
    rng = np.random.default_rng(1)
    for masked in (True, False):
        play_random(make(**kwargs), TURNING, rng, episodes=5, masked=masked)


def connected_order(cells):
    """The cells in a breadth-first order from the first: every prefix is connected."""
    cells = [tuple(c) for c in cells]
    seen, order, queue = {cells[0]}, [], deque([cells[0]])
    while queue:
        x, y = queue.popleft()
        order.append((x, y))
        for n in ((x + 1, y), (x - 1, y), (x, y + 1), (x, y - 1)):
            if n in cells and n not in seen:
                seen.add(n)
                queue.append(n)
    return order


@pytest.mark.parametrize("task", [FAST, TURNING], ids=["level", "turning"])
def test_the_certified_minimum_is_reachable_and_nothing_smaller_succeeds(task):
    r = mq.exhaustive_search(task, n_max=N_MAX)
    assert r.certified and r.n_modules is not None
    env = make(task)
    order = connected_order(r.structure.cells)
    x0, y0 = order[0]
    _, info = env.reset(seed=0)
    for x, y in order[1:]:
        assert not info["success"]
        _, _, term, _, info = env.step(env.action_of((x - x0, y - y0)))
    assert term and info["success"] and info["n_modules"] == r.n_modules
    assert sorted(env.structure.cells) == sorted((x - x0, y - y0) for x, y in order)
    wins = play_random(env, task, np.random.default_rng(2), episodes=12)
    assert all(n >= r.n_modules for n in wins)
    for a in np.flatnonzero(env.reset(seed=0)[1]["action_mask"]):  # every two-module structure
        env.reset(seed=0)
        assert env.step(int(a))[4]["success"] == (r.n_modules <= 2)


def test_observation_holds_the_current_structures_wrenches():
    env = make(lookahead=True)
    obs, info = env.reset(seed=0)
    feats = env.evaluator.features
    for a in (env.action_of((1, 0)), env.action_of((1, 1))):
        s = env.structure
        W = TURNING.rotor_wrenches(s)
        vec, h_Tn, WD = feats.task(W)
        assert np.array_equal(obs["task"], vec) and info["n_wrenches"] == len(W)
        rows = obs["candidates"].reshape(env.action_space.n, -1)
        for b in np.flatnonzero(env.action_masks()):  # each child against its own wrenches
            child = mq.Structure([*s.cells, env.cell_of(int(b))])
            _, h_C, WD_C = feats.task(TURNING.rotor_wrenches(child))
            h, slack = feats.support(child.configuration_matrix())
            want = feats.candidates(h[None], np.array([slack]), h_C, WD_C)[0]
            np.testing.assert_allclose(rows[b], want, atol=1e-5)
        obs, _, _, _, info = env.step(a)


def test_restore_round_trip():
    env = make()
    env.reset(seed=0)
    obs1, _, _, _, info1 = env.step(env.action_of((1, 0)))
    saved = env.state
    obs2, _, _, _, info2 = env.step(env.action_of((0, 1)))
    back = env.restore(saved)
    assert all(np.array_equal(back[k], obs1[k]) for k in obs1)
    again, _, _, _, info3 = env.step(env.action_of((0, 1)))
    assert all(np.array_equal(again[k], obs2[k]) for k in obs2)
    assert info3["success"] == info2["success"] and info3["cells"] == info2["cells"]


def test_task_sources(tmp_path):
    """A DynamicTask, a list, a JSON file, a callable and the reset option."""
    path = FAST.save(tmp_path / "fast.json")
    for source in ([FAST, TURNING], str(path), lambda rng: TURNING):
        env = make(source)
        names = {env.reset(seed=s)[1]["task_name"] for s in range(6)}
        assert names <= {"circle"} and isinstance(env.task, mq.DynamicTask)
    env = make("paper")
    info = env.reset(seed=0, options={"task": FAST})[1]
    assert env.task is FAST and info["n_wrenches"] == FAST.n_wrenches
    env.reset(seed=0)
    assert not isinstance(env.task, mq.DynamicTask)  # the next episode is the source's again
