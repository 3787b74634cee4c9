"""The environment's edges that users hit (issue 34): example task names in ``tasks=``, one task
in ``task=``, the
episode limit following ``n_max``, no hidden answer in ``info`` or task names, the mixed id's
palette tasks, a re-makeable ``NearestValidAction`` and the ids' ``reward_threshold``."""

from __future__ import annotations

import warnings

import gymnasium as gym
import numpy as np
import pytest
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


# --- example: names in tasks= ---------------------------------------------------------------
def test_example_names_work_in_tasks_as_in_the_cli():
    from modquad_gym.tasks import TaskRequirement, example_path

    env = gym.make("ModQuadAssembly-v0", tasks="example:screwdriver", n_max=5)
    _, info = env.reset(seed=0)
    shipped = TaskRequirement.load(example_path("screwdriver"))
    assert info["task_name"] == "screwdriver" and info["n_wrenches"] == shipped.n_wrenches == 2
    np.testing.assert_array_equal(env.unwrapped.task.wrenches, shipped.wrenches)
    # a shipped suite too, and in a list beside a generator name
    suite = gym.make("ModQuadAssembly-v0", tasks="example:suite_small").unwrapped
    names = {suite.reset(seed=s)[1]["task_name"] for s in range(12)}
    assert names == {"screwdriver", "paper_seed0", "planted_seed1"}
    both = gym.make("ModQuadAssembly-v0", tasks=["example:screwdriver", "paper"]).unwrapped
    assert {both.reset(seed=s)[1]["task_name"] for s in range(12)} == {"screwdriver", "paper-abs"}
    with pytest.raises(ValueError, match="unknown example 'nope'; known: .*screwdriver"):
        gym.make("ModQuadAssembly-v0", tasks="example:nope")


def test_task_keyword_takes_one_task_and_names_tasks_when_refused():
    from modquad_gym.tasks import TaskRequirement, example_path

    shipped = TaskRequirement.load(example_path("screwdriver"))
    for task in ("example:screwdriver", example_path("screwdriver"), shipped):
        env = gym.make("ModQuadAssembly-v0", task=task, n_max=5)
        _, info = env.reset(seed=0)
        assert info["task_name"] == "screwdriver"
        np.testing.assert_array_equal(env.unwrapped.task.wrenches, shipped.wrenches)
    refused = {
        "a family of random tasks: pass it as tasks='paper'": {"task": "paper"},
        "not both": {"task": "example:screwdriver", "tasks": "planted"},
        "use tasks=": {"task": "example:suite_small"},
        "task= takes one task .* got 3": {"task": 3},
    }
    with pytest.raises(ValueError, match="not both.*sets tasks= itself"):
        gym.make("ModQuadAssemblyPaper-v0", task=shipped)  # the id registers tasks="paper"
    for words, kwargs in refused.items():
        with pytest.raises(ValueError, match=words):
            gym.make("ModQuadAssembly-v0", **kwargs)


# --- the episode limit follows n_max --------------------------------------------------------
IMPOSSIBLE = np.array([[0.0, 0.0, 1e3, 0.0, 0.0, 0.0]])
"""A lift no structure of <= 128 modules makes (512 rotors of f_max 1): episodes never succeed."""


@pytest.mark.parametrize("env_id", ["ModQuadAssembly-v0", "ModQuadAssemblyScale-v0"])
def test_valid_actions_reach_n_max_modules_for_any_n_max(env_id):
    env = gym.make(env_id, n_max=40, tasks=lambda rng: IMPOSSIBLE)
    assert env.spec.max_episode_steps == env.unwrapped.max_steps == 160
    env.reset(seed=0)
    steps, done = 0, False
    while not done:
        valid = np.flatnonzero(env.unwrapped.action_masks())
        _, _, terminated, truncated, info = env.step(int(valid[-1]))  # a line: one new cell
        steps, done = steps + 1, terminated or truncated
    assert info["n_modules"] == 40 and steps == 39 and terminated and not truncated


def test_invalid_actions_truncate_at_the_envs_own_limit():
    env = gym.make("ModQuadAssemblyPlanted-v0", n_max=3)
    assert env.spec.max_episode_steps == env.unwrapped.max_steps == 12
    env.reset(seed=0)
    ends = [env.step(junk)[2:4] for junk in [-1, 2.5, None, "x"] * 3]  # never raises
    assert ends == [(False, False)] * 11 + [(False, True)]  # truncated, not terminated
    limited = gym.make("ModQuadAssemblyPlanted-v0", n_max=3, max_episode_steps=5)
    assert limited.spec.max_episode_steps == 5  # Gymnasium's TimeLimit on top, when asked
    limited.reset(seed=0)
    assert [limited.step(-1)[3] for _ in range(5)] == [False] * 4 + [True]


# --- no answer in info or in task names -----------------------------------------------------
@pytest.mark.parametrize(
    ("env_id", "name"),
    [
        ("ModQuadAssemblyPlanted-v0", "planted"),
        ("ModQuadAssemblyLarge-v0", "planted-large"),
        ("ModQuadAssemblyMixed-v1", "planted-mixed-external"),
    ],
)
def test_planted_tasks_give_no_answer_away(env_id, name):
    env = gym.make(env_id).unwrapped
    for seed in range(4):
        obs, info = env.reset(seed=seed)
        meta = env.task.meta  # hidden, for benchmarks: in meta only
        hidden = meta.get("planted_cells") or meta["hidden_cells"]
        assert info["task_name"] == name
        text = repr(info)
        assert not set(meta) & set(info)  # no entry of meta reaches info
        assert "planted_cells" not in text and "optimum_upper_bound" not in text
        assert ";".join(f"{x},{y}" for x, y in hidden) not in text
        assert set(obs) == {"occupancy", "action_mask", "task", "structure"} | (
            {"types"} if env.n_types > 1 else set()
        )


def test_generated_task_files_have_neutral_names(tmp_path, capsys):
    from modquad_gym.cli import main
    from modquad_gym.tasks import TaskRequirement

    out = tmp_path / "p.json"
    assert main(["task", "generate", "--kind", "planted", "--seed", "5", "--out", str(out)]) == 0
    task = TaskRequirement.load(out)
    assert task.name == "planted-seed5"  # the seed, not the hidden cells
    assert "[" not in task.name and len(task.meta["planted_cells"]) >= 2


# --- the mixed id draws the mixed tier's palette tasks -------------------------------------
def test_mixed_v1_draws_the_mixed_tiers_tasks_and_v0_is_kept():
    from modquad_gym.scoring.tiers import TIERS

    v1 = gym.make("ModQuadAssemblyMixed-v1").unwrapped
    assert TIERS["mixed"].env_id == "ModQuadAssemblyMixed-v1" and v1.n_types == 3
    for seed in range(3):
        v1.reset(seed=seed)
        task = v1.task
        assert task.kind == "external" and task.f_max == 2.0
        assert task.name == "planted-mixed-external" and len(task.meta["hidden_modules"]) >= 1
    with pytest.warns(DeprecationWarning, match="out of date.*v1"):
        v0 = gym.make("ModQuadAssemblyMixed-v0").unwrapped  # registered, unchanged, deprecated
    kinds = set()
    for seed in range(6):
        v0.reset(seed=seed)
        kinds.add((v0.task.kind, v0.task.name.split("-")[0]))
    assert v0.n_types == 3 and kinds <= {("total", "planted"), ("total", "paper")}


# --- reward_threshold -------------------------------------------------------------------------
def test_reward_threshold_is_the_return_every_success_reaches():
    from modquad_gym.envs import ENV_IDS, RewardWeights
    from modquad_gym.envs.assembly.reward import success_threshold

    w = RewardWeights()
    for env_id, kwargs in ENV_IDS.items():
        n_max = kwargs.get("n_max", 7)
        expected = round(w.w_success - w.w_module * (n_max - 1), 12) if n_max <= 10 else None
        assert gym.spec(env_id).reward_threshold == expected, env_id
    assert gym.spec("ModQuadAssembly-v0").reward_threshold == 0.4
    # the spec follows the arguments, like the step limit
    assert gym.make("ModQuadAssembly-v0", n_max=9).spec.reward_threshold == 0.2
    assert gym.make("ModQuadAssembly-v0", n_max=11).spec.reward_threshold is None
    assert gym.make("ModQuadAssemblyLarge-v0", n_max=7).spec.reward_threshold == 0.4
    heavy = {"w_module": 0.05}
    assert gym.make("ModQuadAssembly-v0", reward_weights=heavy).spec.reward_threshold == 0.7
    assert success_threshold(RewardWeights(w_success=0.5), 7) is None  # success may not pay
    # every successful episode without invalid actions returns at least the threshold
    env = gym.make("ModQuadAssemblyPlanted-v0")
    rng = np.random.default_rng(0)
    returns = []
    for seed in range(25):
        env.reset(seed=seed)
        total, done = 0.0, False
        while not done:
            valid = np.flatnonzero(env.unwrapped.action_masks())
            _, r, terminated, truncated, info = env.step(int(rng.choice(valid)))
            total, done = total + r, terminated or truncated
        if info["success"]:
            returns.append(total)
    assert len(returns) >= 5 and min(returns) >= env.spec.reward_threshold - 1e-12
