"""The learned solvers beyond one episode: branching from stored environment states, the
policy-guided search (its greedy dive, its certificate) and PPO on several module types."""

from __future__ import annotations

import json

import numpy as np
import pytest

from modquad_gym.envs.assembly import ModQuadAssemblyEnv
from modquad_gym.geometry.module import palette
from modquad_gym.policy import DEFAULT_MODEL
from modquad_gym.policy.models import EXTRA_FROM
from modquad_gym.scoring.suites import SUITES_DIR as SUITES
from modquad_gym.search import verified
from modquad_gym.solvers import make_solver
from modquad_gym.tasks import PlantedTasks, load_suite, make_generator


def test_restore_branches_exactly_like_a_replay():
    """Docking from a restored state gives the observation, reward and info that replaying the
    same actions from reset gives; a state of another task is refused."""
    task = PlantedTasks(n_modules=4, n_wrenches=12)(np.random.default_rng(3))
    env = ModQuadAssemblyEnv(tasks=[task], n_max=5)
    env.reset(options={"task": task})
    env.step(env.action_of((1, 0)))
    branch = env.state
    env.step(env.action_of((2, 0)))  # wander off, then come back
    obs_b = env.restore(branch)
    step_b = env.step(env.action_of((0, 1)))
    replay = ModQuadAssemblyEnv(tasks=[task], n_max=5)
    replay.reset(options={"task": task})
    obs_r, *_ = replay.step(replay.action_of((1, 0)))
    step_r = replay.step(replay.action_of((0, 1)))
    for key in obs_r:
        np.testing.assert_array_equal(obs_b[key], obs_r[key])
        np.testing.assert_array_equal(step_b[0][key], step_r[0][key])
    assert step_b[1:4] == step_r[1:4]
    assert {
        k: v for k, v in step_b[4].items() if k not in ("action_mask", "evaluated", "oracle_calls")
    } == {
        k: v
        for k, v in step_r[4].items()  # fmt: skip
        if k not in ("action_mask", "evaluated", "oracle_calls")
    }
    other = PlantedTasks(n_modules=2, n_wrenches=12)(np.random.default_rng(4))
    env.reset(options={"task": other})
    with pytest.raises(ValueError, match="another task"):
        env.restore(branch)


@pytest.mark.skipif(not DEFAULT_MODEL.is_file(), reason="no default model")
def test_guided_search_never_does_worse_than_the_policy_it_dives_with():
    """The dive is the deterministic PPO episode, so the guided search finds a structure
    whenever PPO does, never with more modules."""
    tasks = load_suite(SUITES / "heldout_planted.json")[:8]
    ppo = make_solver("ppo")
    guided = make_solver("ppo-guided")
    assert guided.dive
    for task in tasks:
        p, g = ppo.solve(task), guided.solve(task)
        if p.structure is not None:
            assert g.structure is not None and g.n_modules <= p.n_modules
        if g.structure is not None:
            assert verified(g.structure, task) and g.n_modules >= task.meta["optimum"]


@pytest.fixture(scope="module")
def mixed_model(tmp_path_factory):
    """An untrained MaskablePPO on the three-type environment, saved like a training run."""
    import torch
    from sb3_contrib import MaskablePPO

    from modquad_gym.policy.ppo import make_env

    torch.set_num_threads(1)
    folder = tmp_path_factory.mktemp("mixed")
    kwargs = {"n_max": 4, "modules": "t45,t45m,flat"}
    model = MaskablePPO(
        "MultiInputPolicy",
        make_env(tasks="planted-mixed-external", initial_type="random", **kwargs),
        seed=0,
        device="cpu",
        policy_kwargs={"net_arch": [32]},
    )
    model.save(folder / "model.zip")
    (folder / "config.json").write_text(json.dumps({"env_kwargs": kwargs}))
    return folder / "model.zip"


def _mixed_tasks(n: int = 3):
    gen = make_generator("planted-mixed-external")
    return [gen(np.random.default_rng(s)) for s in range(n)]


@pytest.mark.parametrize("method", ["ppo", "ppo-guided"])
def test_learned_solvers_on_several_module_types(mixed_model, method):
    """A model trained with a palette decodes from each start type; its answers are typed
    structures verified with their weight; another palette is refused."""
    types = palette("t45,t45m,flat")
    solver = make_solver(method, n_max=4, model=mixed_model, modules=types)
    assert solver.policy.starts == [0, 1, 2]
    for task in _mixed_tasks():
        r = solver.solve(task)
        assert r.evaluated >= 1
        if r.structure is not None:
            assert verified(r.structure, task) and set(r.structure.modules) <= set(types)
    with pytest.raises(ValueError, match="trained with the module types"):
        make_solver(method, n_max=4, model=mixed_model, modules=palette("t45,flat"))
    with pytest.raises(ValueError, match="trained with the module types"):
        make_solver(method, n_max=4, model=mixed_model)


def test_guided_method_names_carry_its_settings():
    from modquad_gym.solvers import guided_options

    assert guided_options("ppo-guided") == {}
    assert guided_options("ppo-guided-b128-w3-nodive") == {
        "budget": 128,
        "branching": 3,
        "dive": False,
    }
    for bad in ("ppo-guided-b0", "ppo-guided-x1", "ppo-guided-bb"):
        with pytest.raises(ValueError, match="bad method"):
            guided_options(bad)


def test_validation_suite_is_certified_and_disjoint_from_the_held_out_suite():
    from modquad_gym.scoring.tiers import TIERS, validation_suite
    from modquad_gym.search import exhaustive_search

    tier = TIERS["mixed"]
    val = validation_suite(tier, 2, progress=False)
    held = tier.load_suites()["mixed_external"]
    held_wrenches = [t.wrenches.tobytes() for t in held]
    for task in val:
        assert task.wrenches.tobytes() not in held_wrenches
        r = exhaustive_search(task, n_max=7, **tier.search_kwargs())
        assert task.meta["optimum"] == r.n_modules and task.meta["optimum_modules"]


def test_bench_agents_scores_validation_tasks(tmp_path, capsys):
    from modquad_gym.scoring.agents import main

    out = tmp_path / "val"
    argv = ["--tier", "mixed", "--validation", "2", "--methods", "exhaustive", "random"]
    assert main([*argv, "--out", str(out), "--no-progress"]) == 0
    report = (out / "benchmark.md").read_text()
    assert "Validation tasks" in report and "`validation` (2 tasks)" in report
    with pytest.raises(ValueError, match="not both"):
        main([*argv, "--suite", str(tmp_path / "x.json"), "--out", str(tmp_path / "v2")])
    with pytest.raises(SystemExit) as exc:  # no task to score: a one-line usage error
        main(["--tier", "mixed", "--validation", "0", "--out", str(tmp_path / "v3")])
    assert exc.value.code == 2 and "--validation" in capsys.readouterr().err


def test_the_dive_finishes_past_the_budget_and_every_rollout_respects_the_time_limit():
    """At the field's sizes the policy's own episode docks more modules than the guided
    search's budget: the dive still ends with its structure (it is the incumbent); the time
    limit stops every rollout, the first one too."""
    task = PlantedTasks(n_modules=8, n_wrenches=20)(np.random.default_rng(5))
    guided = make_solver("ppo-guided-b2", n_max=12).solve(task)
    plain = make_solver("ppo", n_max=12).solve(task)
    assert guided.structure is not None and guided.n_modules <= plain.n_modules
    assert guided.evaluated > 2  # the dive's structures, beyond the budget
    mods = palette("t45,t45m,flat")
    mixed = make_generator("planted-mixed-external")(np.random.default_rng(2))
    model = str(DEFAULT_MODEL.parent.parent / "ppo_mixed" / "model.zip")
    none = make_solver("ppo", n_max=7, model=model, modules=mods, time_limit=1e-9).solve(mixed)
    every = make_solver("ppo", n_max=7, model=model, modules=mods).solve(mixed)
    assert none.structure is None and none.evaluated < every.evaluated
    assert every.structure is not None


@pytest.mark.skipif(not DEFAULT_MODEL.is_file(), reason="no default model")
@pytest.mark.parametrize(("n_max", "n_modules", "modules"), [(7, 6, None), (24, 18, None)])
def test_the_dives_are_the_single_pass(n_max, n_modules, modules):
    """With a budget of one structure the guided search answers what the ``ppo`` single pass
    answers, having evaluated the same structures: its dives are that pass's episodes (from
    16 modules with the extra fallbacks' branches where the first episode ends above 16
    modules, as at n_max 24 here; several start types: test_guided_budget.py); with its
    budget never more modules."""
    types = palette(modules) if modules else None
    ppo = make_solver("ppo", n_max, modules=types)
    dive = make_solver("ppo-guided", n_max, modules=types, budget=1)
    guided = make_solver("ppo-guided", n_max, modules=types)
    sizes = []
    for seed in range(3):
        task = PlantedTasks(n_modules=n_modules, n_wrenches=16)(np.random.default_rng(seed))
        p, d, g = ppo.solve(task), dive.solve(task), guided.solve(task)
        assert p.structure is not None and d.structure.key == p.structure.key
        assert d.evaluated == p.evaluated
        assert verified(g.structure, task) and g.n_modules <= p.n_modules
        sizes.append(p.n_modules)
    if n_max == 24:  # the extra fallbacks' branches ran
        assert len(ppo.fallbacks) == 3 and max(sizes) > EXTRA_FROM
