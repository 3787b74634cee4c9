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
    assert env.spec.max_episode_steps is None and env.unwrapped.max_steps == 160
    env.reset(seed=0)
    steps, done = 0, False
    while not done:
        valid = np.flatnonzero(env.unwrapped.action_masks())
        _, _, terminated, truncated, info = env.step(int(valid[-1]))  # a line: one new cell
        steps, done = steps + 1, terminated or truncated
    assert info["n_modules"] == 40 and steps == 39 and terminated and not truncated


def test_invalid_actions_truncate_at_the_envs_own_limit():
    env = gym.make("ModQuadAssemblyPlanted-v0", n_max=3)
    assert env.spec.max_episode_steps is None and env.unwrapped.max_steps == 12
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


# --- planted sizes follow n_max ---------------------------------------------------------------
@pytest.mark.parametrize(
    ("env_id", "n_max"),
    [
        ("ModQuadAssemblyPlanted-v0", 3),
        ("ModQuadAssemblyLarge-v0", 8),
        ("ModQuadAssemblyScale-v0", 7),
        ("ModQuadAssemblyMixed-v1", 2),
        ("ModQuadAssembly-v0", 3),
    ],
)
def test_planted_tasks_have_a_solution_within_a_smaller_n_max(env_id, n_max):
    from modquad_gym.oracle import feasible
    from modquad_gym.tasks.generators import planted_structure

    env = gym.make(env_id, n_max=n_max).unwrapped
    sizes = set()
    for seed in range(6):
        env.reset(seed=seed)
        bound = env.task.meta.get("optimum_upper_bound")
        if bound is None:  # a paper task of the mixed source
            continue
        sizes.add(bound)
        hidden = planted_structure(env.task) if env.n_types == 1 else None
        if hidden is not None:  # the hidden structure solves it, within n_max
            A, W = hidden.configuration_matrix(), env.task.wrenches
            assert feasible(A, W, f_max=env.task.f_max).all()
    assert sizes and max(sizes) <= n_max, sizes


def test_default_ids_draw_the_same_episodes_as_before_the_cap():
    """At their registered n_max the ids' named sources are left as they are: the first
    episodes equal those of an env given the uncapped source itself."""
    from modquad_gym.envs import ENV_IDS
    from modquad_gym.tasks import NAMED_GENERATORS

    for env_id, kwargs in ENV_IDS.items():
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # Mixed-v0 is deprecated
            env = gym.make(env_id).unwrapped
        uncapped = NAMED_GENERATORS[kwargs.get("tasks", "mixed")]()
        assert env.generator == uncapped, env_id
        rest = {k: v for k, v in kwargs.items() if k != "tasks"}
        before = type(env)(tasks=uncapped, **rest)
        for seed in range(2):
            rng = np.random.default_rng(seed)
            (a, _), (b, _) = env.reset(seed=seed), before.reset(seed=seed)
            for _ in range(4):
                assert all(np.array_equal(a[k], b[k]) for k in a), (env_id, seed)
                act = int(rng.choice(np.flatnonzero(env.action_masks())))
                a, ra, done, _, _ = env.step(act)
                b, rb, _, _, _ = before.step(act)
                assert ra == rb, (env_id, seed)
                if done:
                    break


# --- reset options ---------------------------------------------------------------------------
def test_unknown_reset_options_name_every_known_one():
    env = gym.make("ModQuadAssembly-v0", modules="t45,flat").unwrapped
    with pytest.raises(ValueError, match=r"\['foo'\]; known: \['task', 'initial_type'\]"):
        env.reset(seed=0, options={"foo": 1})
    assert env.reset(seed=0, options={"initial_type": 1})[1]["modules"] == ["flat"]
    with pytest.raises(ValueError, match=r"\['initial_type'\]; known: \['task'\]$"):
        gym.make("ModQuadAssembly-v0").reset(seed=0, options={"initial_type": 0})


@pytest.mark.parametrize(
    "options",
    [{"foo": 1}, {"initial_type": 5}, {"task": "paper"}, {"task": np.zeros((2, 5))}],
)
def test_a_failed_reset_leaves_the_env_as_it_was(options):
    env = gym.make("ModQuadAssembly-v0", modules="t45,flat").unwrapped
    same = gym.make("ModQuadAssembly-v0", modules="t45,flat").unwrapped
    for e in (env, same):
        e.reset(seed=0)
        e.step(e.action_of((1, 0)))
    with pytest.raises(ValueError):
        env.reset(seed=5, options=options)
    # the old episode goes on, and the generator was not reseeded
    assert env.np_random.bit_generator.state == same.np_random.bit_generator.state
    a, b = env.step(env.action_of((2, 0))), same.step(same.action_of((2, 0)))
    assert a[4]["cells"] == b[4]["cells"] == [[0, 0], [1, 0], [2, 0]]
    assert all(np.array_equal(a[0][k], b[0][k]) for k in a[0])


def test_a_task_source_that_fails_ends_the_episode():
    from gymnasium.error import ResetNeeded

    draws = iter([np.array([[0.0, 0.0, 2.0, 0.0, 0.0, 0.0]]), "junk"])
    env = gym.make("ModQuadAssembly-v0", tasks=lambda rng: next(draws)).unwrapped
    env.reset(seed=0)
    with pytest.raises(ValueError, match="returned str"):
        env.reset(seed=1)
    with pytest.raises(ResetNeeded, match="call reset"):
        env.step(0)


# --- NearestValidAction on the faces encoding, max_steps' documented limit --------------------
def test_nearest_valid_action_refuses_the_faces_encoding_in_one_line():
    with pytest.raises(ValueError, match="NearestValidAction needs .*actions='grid', got "
                       "actions='faces'"):  # fmt: skip
        NearestValidAction(gym.make("ModQuadAssemblyScale-v0"))


def test_max_steps_limit_is_the_documented_one():
    from modquad_gym.envs import ModQuadAssemblyEnv
    from modquad_gym.envs.assembly.env import MAX_STEPS_LIMIT

    assert f"n_max - 1 to {MAX_STEPS_LIMIT}" in " ".join(ModQuadAssemblyEnv.__doc__.split())
    assert gym.make("ModQuadAssembly-v0", max_steps=MAX_STEPS_LIMIT).unwrapped.max_steps == 512
    with pytest.raises(ValueError, match="max_steps must be <= 512"):
        gym.make("ModQuadAssembly-v0", max_steps=MAX_STEPS_LIMIT + 1)
