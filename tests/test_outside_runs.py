"""Outside agents through every door: made once, with the run's seed (the command line, score(),
make_solver and the leaderboard alike, the first two writing the same rows), refused under a
committed method's name, and their leaderboard submissions verified again before they rank."""

from __future__ import annotations

import csv
import re
import textwrap
from pathlib import Path

import numpy as np
import pytest

from modquad_gym.scoring.suites import with_optimum
from modquad_gym.tasks import PlantedTasks, save_suite

MODULE = "seeded_agents_for_tests"

AGENTS = textwrap.dedent("""
    import numpy as np
    import modquad_gym as mq

    MADE = []

    class Seeded:
        name = "seeded-walk"
        def __init__(self, n_max=7, seed=0):
            MADE.append(int(seed))  # int(None) fails: the seed must reach it
            self.n_max, self.rng = n_max, np.random.default_rng(int(seed))
        def solve(self, task, evaluator):
            s = mq.Structure([(0, 0)], module=evaluator.modules[0])
            while not evaluator.evaluate(s):
                if s.n_modules >= evaluator.n_max:
                    return None
                cells = list(s.attachable_cells())
                s = s.with_cells(cells[self.rng.integers(len(cells))])
            return s

    class Impostor(Seeded):
        name = "exhaustive"
""")


@pytest.fixture(scope="module")
def agents(importable):
    return importable(MODULE, AGENTS)


@pytest.fixture(scope="module")
def suite(tmp_path_factory) -> Path:
    gen = PlantedTasks(n_modules=2, n_wrenches=12)
    tasks = [with_optimum(gen(np.random.default_rng(s)), 3) for s in (0, 1, 2)]
    return save_suite(tasks, tmp_path_factory.mktemp("suite") / "tiny.json")


def _rows(path: Path) -> list[dict]:
    with open(path, newline="") as fh:
        return [{k: v for k, v in r.items() if k != "seconds"} for r in csv.DictReader(fh)]


def test_the_seed_reaches_the_one_constructor_call_of_every_door(agents, suite, tmp_path):
    from modquad_gym.scoring import agents as benchmark
    from modquad_gym.scoring.options import command_line, score_options
    from modquad_gym.solvers import make_solver

    given = dict(suite=[suite], n_max=3, methods=["greedy", f"{MODULE}:Seeded"], seed=3,
                 no_progress=True)  # fmt: skip
    agents.MADE.clear()
    argv = command_line(**given, out=tmp_path / "cli").split()[2:]
    assert benchmark.main(argv) == 0
    assert agents.MADE == [3]  # once, told --seed 3
    benchmark.score(score_options(**given, out=tmp_path / "py"), command_line(**given))
    assert agents.MADE == [3, 3]
    assert _rows(tmp_path / "cli" / "benchmark.csv") == _rows(tmp_path / "py" / "benchmark.csv")
    make_solver(f"{MODULE}:Seeded", 3, seed=5)
    assert agents.MADE == [3, 3, 5]


def test_a_worker_offers_the_seed_to_an_outside_agent_and_asks_the_loaded_one(agents):
    """The solvers a worker makes (``_made``: the agents not made beforehand) tell an outside
    agent the run's seed; ``--seed``'s check asks the loaded agent whether its constructor took
    it, and a registered method whether it draws at random: the one question, ``takes_seed``."""
    from modquad_gym.scoring.agents import _solvers, takes_seed

    spec = f"{MODULE}:Seeded"
    agents.MADE.clear()
    solvers = _solvers(("random", spec), 3, None, 11, None)
    assert agents.MADE == [11] and solvers["random"].settings.seed == 11
    assert takes_seed(spec, {spec: solvers[spec]}) and takes_seed(spec)
    assert not takes_seed("greedy") and takes_seed("random")


def test_the_leaderboard_makes_the_agent_once_per_tier_and_seed(agents, monkeypatch):
    from benchmarks import leaderboard_scoring
    from modquad_gym.scoring import agents as benchmark

    monkeypatch.setattr(benchmark, "run_benchmark", lambda *a, **k: [])  # no task scored
    agents.MADE.clear()
    leaderboard_scoring.score_agent(f"{MODULE}:Seeded", ["current", "large"], 1, [4, 7], False)
    assert agents.MADE == [4, 7, 4, 7]


def test_an_agent_under_a_committed_methods_name_is_refused_before_any_work(agents, monkeypatch):
    from benchmarks import leaderboard_scoring
    from modquad_gym.scoring import agents as benchmark

    monkeypatch.setattr(benchmark, "run_benchmark", lambda *a, **k: pytest.fail("work began"))
    with pytest.raises(ValueError, match="the agent's name 'exhaustive' is a committed method's"):
        leaderboard_scoring.score_agent(f"{MODULE}:Impostor", ["current"], 1, [0], False)


@pytest.fixture(scope="module")
def submission(agents, tmp_path_factory) -> Path:
    """An honest submission: the seeded walk on the current tier's first task of each suite."""
    from benchmarks.leaderboard_scoring import score_agent, write_submission

    records = score_agent(f"{MODULE}:Seeded", ["current"], 1, [0], False)
    return write_submission(records, tmp_path_factory.mktemp("sub") / "agent.csv")


def _forged(source: Path, path: Path, row: int, **changes) -> Path:
    with open(source, newline="") as fh:
        records = list(csv.DictReader(fh))
    records[row - 1].update(changes)
    with open(path, "w", newline="") as fh:
        writer = csv.DictWriter(fh, list(records[0]))
        writer.writeheader()
        writer.writerows(records)
    return path


def test_a_submission_is_verified_again_and_its_optimum_read_from_the_suite(submission, tmp_path):
    from benchmarks.leaderboard_entries import submission_entries
    from modquad_gym.scoring.tiers import get_tier

    tier = get_tier("current")
    (honest,) = submission_entries(submission, tier, 100)
    assert honest.tasks == 2 and honest.method == "seeded-walk"
    with open(submission, newline="") as fh:
        records = list(csv.DictReader(fh))
    row = next(n for n, r in enumerate(records, start=1) if r["success"] == "1")
    first = records[row - 1]
    moved = _forged(submission, tmp_path / "optimum.csv", 1, optimum="1")
    assert submission_entries(moved, tier, 100)[0].optimal == honest.optimal  # the suite's
    forged = {
        "no cells": dict(cells=""),
        "another count": dict(n_modules=str(int(first["n_modules"]) - 1)),
        "failed but answered": dict(success="0", n_modules=""),
        "one module": dict(cells="0,0", n_modules="1"),
    }
    for what, changes in forged.items():
        path = _forged(submission, tmp_path / f"{what}.csv", row, **changes)
        said = rf"{re.escape(str(path))}: row {row} \(line {row + 1}\): "
        with pytest.raises(ValueError, match=said):
            submission_entries(path, tier, 100)
    nan = _forged(submission, tmp_path / "nan.csv", 2, evaluated="nan")
    with pytest.raises(ValueError, match=r"row 2 \(line 3\): evaluated 'nan' is not a count"):
        submission_entries(nan, tier, 100)
    taken = _forged(submission, tmp_path / "taken.csv", 1, method="greedy")
    with pytest.raises(ValueError, match="the agent's name 'greedy' is a committed method's"):
        submission_entries(taken, tier, 100)
