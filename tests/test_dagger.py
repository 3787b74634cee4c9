"""The expert in the loop (agents/dagger.py): the certified search labels the learner's states,
on an optimal path and off it (a minimum completion of what was built)."""

from __future__ import annotations

import numpy as np
import pytest

from agents.dagger import completion_targets, learner_states
from agents.imitation import expert_targets, good_actions, placements
from modquad_gym.envs.assembly import ModQuadAssemblyEnv
from modquad_gym.search import exhaustive_search
from modquad_gym.tasks import PlantedTasks

torch = pytest.importorskip("torch")
pytest.importorskip("sb3_contrib")


def _task(seed: int = 3):
    return PlantedTasks(n_modules=4, n_wrenches=12)(np.random.default_rng(seed))


def test_off_path_states_are_labelled_towards_a_minimum_completion():
    """After a docking that leaves every optimum, the labels dock towards the smallest
    structure that still contains what was built: following them ends there."""
    task = _task()
    env = ModQuadAssemblyEnv(tasks=[task], n_max=7, lookahead=True)
    n_star, keys = expert_targets(task, 7)
    env.reset(options={"task": task})
    optima = placements(keys)
    while good_actions(env, optima).any():  # along an optimum until a docking can leave it
        valid, good = env.action_masks(), good_actions(env, optima)
        env.step(int(np.flatnonzero(valid & ~good)[0] if (valid & ~good).any() else good.argmax()))
    assert not env.state.done
    best = exhaustive_search(task, n_max=7, start=env.structure).n_modules
    assert best > n_star
    rng = np.random.default_rng(0)
    while not env.state.done:
        good = good_actions(env, completion_targets(env, task, 7))
        assert good.any() and not (good & ~env.action_masks()).any()
        env.step(int(rng.choice(np.flatnonzero(good))))
    assert env.state.success and env.state.n_modules == best


def test_learner_states_label_what_the_learner_visits():
    """An untrained policy's greedy episodes: every kept state has good actions among its
    valid ones, its return-to-go is the learner's own, and the statistics count the tasks."""
    from sb3_contrib import MaskablePPO

    from modquad_gym.policy.network import CandidatePolicy
    from modquad_gym.policy.policy import make_env

    torch.set_num_threads(1)
    tasks = [_task(s) for s in (3, 4, 5)]
    model = MaskablePPO(CandidatePolicy, make_env(tasks, n_max=6, lookahead=True), seed=0,
                        device="cpu", policy_kwargs={"hidden": 8})  # fmt: skip
    env = ModQuadAssemblyEnv(tasks=tasks, n_max=6, lookahead=True)
    demos, stats = learner_states(model.policy, env, tasks, 6, seed=0)
    assert stats["tasks"] == demos.n_tasks == 3 and 0.0 <= stats["learner_good"] <= 1.0
    assert len(demos) >= 3 and (demos.good.sum(axis=1) >= 1).all()
    assert not (demos.good & ~demos.valid).any()
    assert demos.obs["candidates"].shape[0] == len(demos) == len(demos.returns)
