"""Expert demonstrations and behaviour cloning (agents.imitation), and the certified
optimal_structures they rest on."""

from __future__ import annotations

import numpy as np
import pytest

from agents.imitation import collect, collect_parallel, good_actions, merge, placements
from modquad_gym.envs.assembly import ModQuadAssemblyEnv
from modquad_gym.envs.assembly.reward import RewardWeights
from modquad_gym.geometry.structure import Structure, normalise, structure_levels
from modquad_gym.oracle import feasible
from modquad_gym.search import exhaustive_search, optimal_structures
from modquad_gym.tasks import PaperTasks, PlantedTasks, ScrewdriverTask, TaskRequirement


def _tasks() -> list[TaskRequirement]:
    planted = PlantedTasks(n_modules=(2, 4), n_wrenches=(8, 30))
    paper = PaperTasks(n_wrenches=10)
    return [planted(np.random.default_rng(s)) for s in range(4)] + [
        paper(np.random.default_rng(7)),
        ScrewdriverTask()(np.random.default_rng(0)),
    ]


@pytest.mark.parametrize("task", _tasks(), ids=lambda t: t.name[:20])
def test_optimal_structures_is_the_whole_minimal_level(task):
    n_star, keys = optimal_structures(task, n_max=5)
    assert n_star == exhaustive_search(task, n_max=5).n_modules
    brute = {}
    for n, level in enumerate(structure_levels(5), start=1):
        ok = [
            k for k in level if feasible(Structure(k).configuration_matrix(), task.wrenches).all()
        ]
        if ok:
            brute = {"n": n, "keys": set(ok)}
            break
    assert n_star == brute["n"] and set(keys) == brute["keys"]


def test_optimal_structures_reports_none_beyond_n_max():
    task = TaskRequirement([[0, 0, 40.0, 0, 0, 0]])  # lift of 40: more than 7 modules
    assert optimal_structures(task, n_max=7) == (None, [])


def test_placements_hold_the_origin_and_every_translate():
    targets = placements([((0, 0), (1, 0), (1, 1))])
    assert len(targets) == 3 and all(((0, 0), 0) in t for t in targets)
    assert {normalise(c for c, _ in t) for t in targets} == {((0, 0), (1, 0), (1, 1))}


def test_typed_placements_put_a_module_of_the_start_type_on_the_origin():
    from modquad_gym.geometry.module import palette

    a, b = palette("t45,flat")
    key = (((0, 0), a), ((1, 0), b), ((1, 1), b))
    assert placements([key], [a, b], start=0) == [
        frozenset({((0, 0), 0), ((1, 0), 1), ((1, 1), 1)})
    ]
    from_b = placements([key], [a, b], start=1)
    assert len(from_b) == 2 and all(((0, 0), 1) in t for t in from_b)


def test_mixed_expert_episodes_dock_the_certified_typed_optimum():
    """With several module types the expert docks (cell, type) pairs of the certified search's
    typed optimum, from a start type that optimum holds, and ends with its module count."""
    from agents.imitation import expert_targets, typed_cells
    from modquad_gym.tasks import make_generator

    gen = make_generator("planted-mixed-external")
    tasks = [gen(np.random.default_rng(s)) for s in range(3)]
    env = ModQuadAssemblyEnv(tasks=tasks, n_max=6, modules="t45,t45m,flat", initial_type="random")
    demos = collect(env, tasks, n_max=6, seed=0, expert="one")
    assert demos.n_tasks == len(tasks) and demos.good.any(axis=1).all()
    assert not (demos.good & ~demos.valid).any()
    starts = np.flatnonzero(demos.obs["occupancy"].sum(axis=1) == 1)
    for i, task in zip(starts, tasks):
        n_star, keys = expert_targets(task, 6, "one", env.palette)
        held = {k for _, k in typed_cells(keys[0], env.palette)}
        first_type = int(np.flatnonzero(demos.obs["types"][i])[0]) // env.grid.n_cells
        assert first_type in held
        _, info = env.reset(options={"task": task, "initial_type": first_type})
        w = RewardWeights()  # the return of a successful episode of n* modules
        expected = w.w_sat * (1 - info["satisfied_fraction"]) - w.w_module * (n_star - 1)
        assert demos.returns[i] == pytest.approx(expected + w.w_success, abs=1e-5)


def test_good_actions_of_a_unique_horizontal_pair():
    task = PlantedTasks(n_modules=2, n_wrenches=24)(np.random.default_rng(0))
    n_star, keys = optimal_structures(task, n_max=3)
    assert (n_star, keys) == (2, [((0, 0), (1, 0))])  # premise: only the horizontal pair
    env = ModQuadAssemblyEnv(tasks=[task], n_max=3)
    env.reset(options={"task": task})
    good = good_actions(env, placements(keys))
    assert {env.cell_of(a) for a in np.flatnonzero(good)} == {(1, 0), (-1, 0)}


def test_expert_episodes_end_optimal_with_consistent_returns():
    tasks = _tasks()
    env = ModQuadAssemblyEnv(tasks="mixed", n_max=5)
    demos = collect(env, tasks, n_max=5, seed=0)
    assert demos.n_tasks == len(tasks)  # no task of this set is solved by one module
    assert demos.good.any(axis=1).all() and not (demos.good & ~demos.valid).any()
    assert set(demos.obs) == set(env.observation_space.spaces)
    for key, space in env.observation_space.spaces.items():
        assert demos.obs[key].shape == (len(demos), *space.shape)
    # a state with one module starts each episode: its return-to-go is the episode's return,
    # w_sat * (1 - frac_0) - w_module * (n* - 1) + w_success (reward module docstring)
    starts = np.flatnonzero(demos.obs["occupancy"].sum(axis=1) == 1)
    assert len(starts) == len(tasks)
    w = RewardWeights()
    for i, task in zip(starts, tasks):
        n_star = optimal_structures(task, n_max=5)[0]
        frac_0 = feasible(Structure([(0, 0)]).configuration_matrix(), task.wrenches).mean()
        expected = w.w_sat * (1 - frac_0) - w.w_module * (n_star - 1) + w.w_success
        assert demos.returns[i] == pytest.approx(expected, abs=1e-5)


def test_parallel_collection_matches_serial():
    tasks = _tasks()
    kwargs = {"tasks": "mixed", "n_max": 5}
    one = collect_parallel(tasks, kwargs, 5, seed=3, workers=1)
    two = collect_parallel(tasks, kwargs, 5, seed=3, workers=2)
    for key in one.obs:
        np.testing.assert_array_equal(one.obs[key], two.obs[key])
    np.testing.assert_array_equal(one.good, two.good)
    np.testing.assert_array_equal(one.returns, two.returns)
    with pytest.raises(ValueError, match="no demonstrations"):
        merge([])


def test_cloning_learns_the_expert_choice():
    import torch
    from sb3_contrib import MaskablePPO

    from agents.imitation import clone
    from modquad_gym.policy.ppo import make_env

    torch.set_num_threads(1)
    tasks = [PlantedTasks(n_modules=2, n_wrenches=24)(np.random.default_rng(s)) for s in (0, 1)]
    env = ModQuadAssemblyEnv(tasks=tasks, n_max=3)
    demos = merge([collect(env, tasks * 4, n_max=3, seed=s) for s in range(2)])
    model = MaskablePPO("MultiInputPolicy", make_env(tasks, n_max=3), seed=0, device="cpu")
    history = clone(model, demos, epochs=60, batch_size=8, learning_rate=3e-3, seed=0)
    assert history[-1]["loss"] < 0.25 * history[0]["loss"]
    assert history[-1]["greedy_good"] == 1.0
    for task in tasks:  # the cloned policy builds the one optimal pair
        obs, _ = env.reset(options={"task": task})
        action, _ = model.predict(obs, action_masks=env.action_masks(), deterministic=True)
        _, _, terminated, _, info = env.step(int(action))
        assert terminated and info["success"] and info["n_modules"] == 2


def test_expert_one_steers_to_the_certified_search_structure():
    """``expert="one"`` targets the first optimum of the exhaustive search, one of the optima
    ``"all"`` targets; its episodes end optimal too, with at most as many good actions."""
    from agents.imitation import expert_targets
    from modquad_gym.search import exhaustive_search

    tasks = _tasks()
    for task in tasks:
        n_one, one = expert_targets(task, 5, "one")
        n_all, every = expert_targets(task, 5, "all")
        assert n_one == n_all == exhaustive_search(task, n_max=5).n_modules
        assert len(one) == 1 and one[0] in every
    env = ModQuadAssemblyEnv(tasks="mixed", n_max=5)
    a = collect(env, tasks, n_max=5, seed=0, expert="one")
    b = collect(env, tasks, n_max=5, seed=0)
    assert a.n_tasks == b.n_tasks == len(tasks)
    assert a.good.sum(axis=1).mean() <= b.good.sum(axis=1).mean()
    with pytest.raises(ValueError, match="expert"):
        expert_targets(tasks[0], 5, "best")
