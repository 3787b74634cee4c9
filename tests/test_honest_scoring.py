"""Review 21 (honesty): the seeds of the benchmark's own tasks are reserved (an environment warns,
``train.py`` refuses them, the docs say so), ``modquad score`` re-verifies every success in a
fresh process, its report records the seed, the versions and each method's setup seconds, and
the environment page says which ids keep the planted answer in ``task.meta``."""

from __future__ import annotations

import re
import warnings
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest

import modquad_gym
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


PATCHER = '''
class Agent:
    """A line of n_max modules, and the scorer's in-process checks told to say yes."""
    name = "patcher"
    def __init__(self, n_max):
        import importlib
        A = importlib.import_module("modquad_gym.scoring.agents")
        A.verified = A.judged = lambda *args: True
        try:
            importlib.import_module("modquad_gym.scoring.verdicts").verified = lambda *a: True
        except ImportError:
            pass
        self.n = n_max
    def solve(self, task):
        return [(i, 0) for i in range(self.n)]
'''

PRECOMPUTE = '''
import time

class Agent:
    """Works for 0.3 s in its constructor, then answers with one evaluator call."""
    name = "precompute"
    def __init__(self, n_max):
        t0 = time.perf_counter()
        while time.perf_counter() - t0 < 0.3:
            pass
        self.n = n_max
    def solve(self, task, evaluator):
        for n in range(1, self.n + 1):
            if evaluator.evaluate([(i, 0) for i in range(n)]):
                return [(i, 0) for i in range(n)]
        return None
'''


def test_a_success_a_fresh_process_refuses_stops_the_run(importable, tmp_path, monkeypatch,
                                                          capsys):  # fmt: skip
    import importlib

    patched = ((benchmark, "judged"), (benchmark, "verified"),
               ("modquad_gym.scoring.verdicts", "verified"))  # fmt: skip
    for module, name in patched:  # what the agent replaces, restored afterwards
        try:
            module = importlib.import_module(module) if isinstance(module, str) else module
            monkeypatch.setattr(module, name, getattr(module, name))
        except (ImportError, AttributeError):
            pass
    importable("honest_patcher_for_tests", PATCHER)
    out = tmp_path / "scores"
    spec = "honest_patcher_for_tests:Agent"
    argv = ["--tier", "current", "--solver", spec, "--methods", spec, "--limit", "2", "--out",
            str(out), "--no-progress"]  # fmt: skip
    assert benchmark.script(argv) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith(
        "modquad score: error: the agent's process verified an answer the exact oracle refuses: "
    ), err
    assert "honest_patcher_for_tests:Agent on task 'paper-2000000'" in err[0]
    assert "do not exert every task wrench" in err[0] and not out.exists()


def test_the_recheck_redraws_validation_tasks_and_finds_each_row_by_its_place():
    """Validation tasks are drawn again from their seeds; two tasks of one name are told apart
    by their place; a success whose cells fail its task is refused, naming method and task."""
    from dataclasses import replace

    from modquad_gym.scoring.recheck import recheck, suite_sources
    from modquad_gym.scoring.tiers import get_tier, validation_suite

    tier = get_tier("current")
    suites = {"validation": validation_suite(tier, 2, progress=False)}
    rows = benchmark.run_benchmark(suites, ["greedy", "exhaustive"], 7, progress=False)
    sources = suite_sources(None, tier, 2)
    assert recheck(rows, 2, sources, 7, None, None)[0] == sum(r.success for r in rows) == 4
    swapped = [replace(r, task="val-1") if r.task == "val-0" else r for r in rows]
    with pytest.raises(ValueError, match=r"greedy on task 'val-1' of validation: the suite has "
                       r"no task 'val-1' at place 1"):  # fmt: skip
        recheck(swapped, 2, sources, 7, None, None)
    lied = [replace(r, cells=[[0, 0]], n_modules=1) if r.method == "exhaustive" else r
            for r in rows]  # fmt: skip
    refused = (
        r"^the agent's process verified an answer the exact oracle refuses: exhaustive "
        r"on task 'val-0' of validation: its 1 module at \[\[0, 0\]\] do not exert"
    )
    with pytest.raises(ValueError, match=refused):
        recheck(lied, 2, sources, 7, None, None)


def test_the_report_records_seed_versions_setup_seconds_and_the_recheck(importable, tmp_path):
    import numpy
    import scipy

    importable("honest_precompute_for_tests", PRECOMPUTE)
    out = tmp_path / "scores"
    spec = "honest_precompute_for_tests:Agent"
    argv = ["--tier", "current", "--solver", spec, "--methods", "greedy", "random", spec,
            "--limit", "2", "--out", str(out), "--no-progress"]  # fmt: skip
    assert benchmark.script(argv) == 0
    text = (out / "benchmark.md").read_text()
    assert "- Seed: 0 (the default: `--seed` not given)" in text
    versions = re.search(r"- Versions: (.*)\.\n", text).group(1)
    for name, version in (("modquad_gym", modquad_gym.__version__), ("numpy", numpy.__version__),
                          ("scipy", scipy.__version__)):  # fmt: skip
        assert f"{name} {version}" in versions
    assert "gymnasium " in versions and "daqp " in versions
    rows = int(re.search(r"fresh process .*?: (\d+) success rows", text).group(1))
    assert rows == sum(r["success"] == "1" for r in _csv(out / "benchmark.csv"))
    setup = dict(re.findall(r"^\| (\S+) \| (\d+\.\d+) \|$", text, re.M))
    assert set(setup) == {"greedy", "random", spec} and float(setup[spec]) >= 0.3
    per_task = [float(r["seconds"]) for r in _csv(out / "benchmark.csv") if r["method"] == spec]
    assert max(per_task) < 0.3  # the constructor's time is setup, not the tasks'
    argv[argv.index("--out") + 1] = str(tmp_path / "seeded")
    assert benchmark.script([*argv, "--seed", "3"]) == 0
    assert "- Seed: 3 (given by `--seed`)" in (tmp_path / "seeded" / "benchmark.md").read_text()


def _csv(path: Path) -> list[dict]:
    import csv

    with open(path, newline="") as fh:
        return list(csv.DictReader(fh))


def _ids_after(marker: str, text: str) -> set[str]:
    """The env ids the page lists after ``marker``, up to the end of that sentence's list."""
    said = text.split(marker, 1)[1].split(" (", 1)[0]
    return set(re.findall(r"`(ModQuadAssembly[\w-]*)`", said))


def test_the_environment_page_lists_the_ids_that_give_the_answer_away():
    """The ids whose tasks keep a planted structure in ``meta`` (with a fault it is the intact
    answer, ``intact_*``: not listed), and those whose ``task_name`` tells planted from random
    tasks, found by drawing each id's own tasks."""
    from modquad_gym.tasks.planted_meta import fault_meta

    planted, telling = set(), set()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DeprecationWarning)  # Mixed-v0 is superseded
        for env_id in ENV_IDS:
            env = gym.make(env_id).unwrapped
            drawn = [env.generator(np.random.default_rng(s)) for s in range(12)]
            tasks = [fault_meta(t, env.fault) for t in drawn]  # as reset holds them
            if any({"planted_cells", "hidden_cells"} & set(t.meta) for t in tasks):
                planted.add(env_id)
            if len({t.name for t in tasks}) > 1:
                telling.add(env_id)
    text = " ".join((ROOT / "docs" / "environments.md").read_text().split())
    assert _ids_after("**the planted answer is in `task.meta` on**", text) == planted
    assert _ids_after("**`task_name` tells planted from random tasks on**", text) == telling
    assert "ModQuadAssembly-v0" in planted and "task names are neutral" not in text
