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


# --- with a fault, task.meta offers the planted answer as the intact one only ---------------
FAULT_ENVS = [
    ("ModQuadAssemblyFaultTolerant-v0", {}, (6, 11)),  # planted seeds of its mixed source
    ("ModQuadAssembly-v0", {"fault": "rotor", "tasks": "planted", "n_max": 6}, (0, 1)),
]


@pytest.mark.parametrize(("env_id", "kwargs", "seeds"), FAULT_ENVS)
def test_with_a_fault_no_planted_count_is_offered_as_a_bound(env_id, kwargs, seeds):
    """The planted structure answers the task intact: under a failure its count is often below
    the tolerant optimum (the review's seed 1: 4 against 7), so with a fault ``meta`` names it
    ``intact_*`` and offers no ``optimum_upper_bound``; any bound it does offer is never below
    the tolerant optimum, exhaustive and certified. The episode's task is the intact env's."""
    env = gym.make(env_id, **kwargs).unwrapped
    plain = gym.make(env_id, **{**kwargs, "fault": None}).unwrapped
    below = 0
    for seed in seeds:
        env.reset(seed=seed)
        plain.reset(seed=seed)
        meta, intact = env.task.meta, plain.task.meta
        assert not {"optimum_upper_bound", "planted_cells", "hidden_cells"} & set(meta), meta
        assert meta["intact_optimum_upper_bound"] == intact["optimum_upper_bound"]
        assert meta["intact_planted_cells"] == intact["planted_cells"]
        assert np.array_equal(env.task.wrenches, plain.task.wrenches)
        assert env.task.name == plain.task.name == "planted"
        r = mq.exhaustive_search(env.task, n_max=env.n_max, fault=env.fault)
        optimum = r.n_modules if r.status == "optimal" else env.n_max + 1  # none within n_max
        assert r.status in ("optimal", "infeasible"), r.status
        bounds = {k: v for k, v in meta.items() if "bound" in k and not k.startswith("intact_")}
        assert all(v >= optimum for v in bounds.values()), (bounds, optimum)
        below += meta["intact_optimum_upper_bound"] < optimum
    assert below, "the intact count bounds every tolerant optimum here: the test shows nothing"


def test_with_a_fault_a_given_planted_task_is_renamed_and_left_as_it_was():
    """The rule holds for a task given at reset (and a palette's hidden cells and types); the
    given task itself keeps its meta, and without a fault the env holds the task itself."""
    task = mq.tasks.PlantedTasks()(np.random.default_rng(1))
    env = gym.make("ModQuadAssembly-v0", fault="module").unwrapped
    env.reset(seed=0, options={"task": task})
    assert "optimum_upper_bound" not in env.task.meta and "optimum_upper_bound" in task.meta
    assert env.task.meta["intact_planted_cells"] == task.meta["planted_cells"]
    plain = gym.make("ModQuadAssembly-v0").unwrapped
    plain.reset(seed=0, options={"task": task})
    assert plain.task is task
    mixed = gym.make("ModQuadAssemblyMixed-v1", fault="rotor").unwrapped
    mixed.reset(seed=0)
    keys = set(mixed.task.meta)
    assert {"intact_hidden_cells", "intact_hidden_modules", "intact_optimum_upper_bound"} <= keys
    assert not {"hidden_cells", "hidden_modules", "optimum_upper_bound"} & keys
