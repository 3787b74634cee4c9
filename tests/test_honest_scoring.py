"""Review 21 (honesty): the seeds of the benchmark's own tasks are reserved (an environment warns,
``train.py`` refuses them, the docs say so), and the environment page says which ids keep the
planted answer in ``task.meta``."""

from __future__ import annotations

import re
import warnings
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest

from modquad_gym.envs import ENV_IDS
from modquad_gym.scoring import agents as benchmark
from modquad_gym.scoring.suites import PLANTED_SEED0, SUITES_DIR, VALIDATION_SEED0
from modquad_gym.tasks import load_suite

try:  # the tests of the scorer and the pages run on a tree without the reserved seeds too
    from modquad_gym.tasks.reserved import (
        HELDOUT_SEEDS,
        VALIDATION_SEEDS,
        ReservedSeedWarning,
        reserved_draws,
        span,
    )
except ImportError:
    HELDOUT_SEEDS = VALIDATION_SEEDS = ReservedSeedWarning = reserved_draws = span = None

ROOT = Path(__file__).resolve().parents[1]


def test_every_benchmark_seed_lies_in_a_reserved_range():
    """Each shipped suite's task seeds, each tier's seed range, the validation draws and the
    scale suites' validation draws: inside the ranges the docs and the warning name."""
    from modquad_gym.scoring.scale_tasks import FAMILIES, task_seed
    from modquad_gym.scoring.tiers import TIERS

    seeds = [t.meta["seed"] for path in sorted(SUITES_DIR.glob("*.json"))
             for t in load_suite(path)]  # fmt: skip
    assert len(seeds) > 300
    assert all(s in HELDOUT_SEEDS for s in seeds), sorted(set(seeds) - set(HELDOUT_SEEDS))[:5]
    for tier in (t for t in TIERS.values() if t.seed0):
        assert {tier.seed0, tier.seed0 + tier.n_tasks - 1} <= set(HELDOUT_SEEDS), tier.name
    assert {VALIDATION_SEED0, VALIDATION_SEED0 + 100_000 - 1} <= set(VALIDATION_SEEDS)
    for family in FAMILIES:
        assert task_seed(family, 128, 99, validation=True) in HELDOUT_SEEDS


def test_a_reserved_seed_warns_once_per_env_and_the_task_is_the_held_out_one():
    env = gym.make("ModQuadAssemblyPlanted-v0")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        env.reset(seed=PLANTED_SEED0)
        env.reset(seed=PLANTED_SEED0 + 1)  # the same env: once
        env.reset(seed=0)
    mine = [w for w in caught if issubclass(w.category, ReservedSeedWarning)]
    assert len(mine) == 1 and issubclass(mine[0].category, UserWarning)
    text = str(mine[0].message)
    assert "reset(seed=1000000)" in text and span(HELDOUT_SEEDS) in text
    held_out = load_suite(SUITES_DIR / "heldout_planted.json")[0]
    env.reset(seed=PLANTED_SEED0)  # why: the env draws the held-out task itself
    np.testing.assert_allclose(env.unwrapped.task.wrenches, held_out.wrenches, atol=1e-12)
    vec = gym.make_vec("ModQuadAssembly-v0", num_envs=2, vectorization_mode="sync")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        vec.reset(seed=VALIDATION_SEEDS.start - 1)  # env 1 resets with 500,000
        with reserved_draws():  # the project's own path: silent
            gym.make("ModQuadAssembly-v0").reset(seed=VALIDATION_SEEDS.start)
    assert [str(w.message)[:22] for w in caught if w.category is ReservedSeedWarning] == [
        "reset(seed=500000): se"
    ]


def test_scoring_and_validation_draw_their_tasks_without_a_warning():
    from modquad_gym.scoring.tiers import get_tier, validation_suite

    with warnings.catch_warnings():
        warnings.simplefilter("error", ReservedSeedWarning)
        validation_suite(get_tier("current"), 2, progress=False)
        suites = get_tier("current").load_suites(1)
        benchmark.run_benchmark(suites, ["greedy", "ppo"], 7, progress=False)


@pytest.mark.parametrize("argv", [["--seed", "1000000"], ["--seed", "499999"],
                                  ["--seeds", "0", "8999999"]], ids=" ".join)  # fmt: skip
def test_train_refuses_a_seed_whose_environments_reset_with_a_reserved_one(argv, tmp_path,
                                                                           capsys):  # fmt: skip
    from agents.cli import parse_args

    with pytest.raises(SystemExit) as exc:  # two envs by default: 499,999 and 500,000
        parse_args(["--out", str(tmp_path / "run"), *argv])
    err = capsys.readouterr().err.strip().splitlines()[-1]
    assert exc.value.code == 2 and argv[0] in err and "reserved" in err and "Traceback" not in err
    assert not (tmp_path / "run").exists()


def test_train_config_refuses_a_reserved_seed_and_takes_one_beside_the_range():
    from agents.config import TrainConfig

    with pytest.raises(ValueError, match=r"--seed 999998: .*seeds 999,998-999,999"):
        TrainConfig(seed=999_998)
    assert TrainConfig(seed=VALIDATION_SEEDS.start - 1, n_envs=1).seed == 499_999
    assert TrainConfig(seed=HELDOUT_SEEDS.stop).seed == 9_000_000


def test_the_docs_name_the_reserved_ranges_for_outside_researchers():
    ranges = (span(VALIDATION_SEEDS), span(HELDOUT_SEEDS))
    for page in ("docs/leaderboard.md", "results/leaderboard.md",
                 "docs/getting-started/agents.md"):  # fmt: skip
        text = " ".join((ROOT / page).read_text().split())
        part = text.split("## Add your own agent")[-1]
        assert all(r in part for r in ranges), page
        assert "never reset an environment, draw a task or train" in part, page


def _ids_after(marker: str, text: str) -> set[str]:
    """The env ids the page lists after ``marker``, up to the end of that sentence's list."""
    said = text.split(marker, 1)[1].split(" (", 1)[0]
    return set(re.findall(r"`(ModQuadAssembly[\w-]*)`", said))


def test_the_environment_page_lists_the_ids_that_give_the_answer_away():
    """The ids whose tasks keep a planted structure in ``meta``, and those whose ``task_name``
    tells planted from random tasks, found by drawing each id's own tasks."""
    planted, telling = set(), set()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DeprecationWarning)  # Mixed-v0 is superseded
        for env_id in ENV_IDS:
            env = gym.make(env_id).unwrapped
            tasks = [env.generator(np.random.default_rng(s)) for s in range(12)]
            if any({"planted_cells", "hidden_cells"} & set(t.meta) for t in tasks):
                planted.add(env_id)
            if len({t.name for t in tasks}) > 1:
                telling.add(env_id)
    text = " ".join((ROOT / "docs" / "environments.md").read_text().split())
    assert _ids_after("**the planted answer is in `task.meta` on**", text) == planted
    assert _ids_after("**`task_name` tells planted from random tasks on**", text) == telling
    assert "ModQuadAssembly-v0" in planted and "task names are neutral" not in text
