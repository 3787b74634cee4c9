"""Outside agents scored fairly: the benchmark counts their configurations through the evaluator
it hands them, tells them the tier's n_max and types, hides each task's meta, refuses answers
beyond the budget or off the types, and writes a report and figures about them."""

from __future__ import annotations

import csv
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest

import modquad_gym as mq
from modquad_gym.geometry.module import STOCK_TYPES, palette
from modquad_gym.search import SearchResult
from modquad_gym.solvers import Evaluator, ExternalSolver, admissible, load_solver, make_solver
from modquad_gym.tasks import PlantedTasks, TaskRequirement, save_suite

N_MAX = 3


def _tasks() -> list[TaskRequirement]:
    """Two planted 2-module tasks (a horizontal and a vertical pair), each with its optimum."""
    from modquad_gym.scoring.suites import with_optimum

    gen = PlantedTasks(n_modules=2, n_wrenches=12)
    return [with_optimum(gen(np.random.default_rng(seed)), N_MAX) for seed in (0, 1)]


def test_the_evaluator_decides_exactly_and_counts_each_structure_once():
    task = _tasks()[0]
    ev = Evaluator(task, n_max=N_MAX, tier="current")
    pair, line = mq.Structure([(0, 0), (1, 0)]), mq.Structure([(0, 0), (0, 1)])
    assert ev.evaluate(pair) and not ev.evaluate(line)
    expected = mq.feasible(line.configuration_matrix(), task.wrenches, task.f_max)
    assert (ev.feasible(line) == expected).all()
    assert ev.feasible([(5, 5), (6, 5)]).all()  # the same pair, translated: from memory
    assert (ev.evaluated, ev.oracle_calls) == (2, 2 * len(task.wrenches))
    assert ev.seen([(3, 0), (4, 0)]) and not ev.seen([(0, 0)])
    assert (ev.n_max, ev.tier, ev.modules) == (N_MAX, "current", [mq.Structure([(0, 0)]).module])


def test_the_evaluator_refuses_structures_beyond_n_max_or_off_the_types():
    ev = Evaluator(_tasks()[0], n_max=N_MAX)
    with pytest.raises(ValueError, match="exceed this tier's n_max = 3"):
        ev.feasible([(i, 0) for i in range(4)])
    with pytest.raises(ValueError, match="module type 'flat' is not allowed"):
        ev.feasible(mq.Structure([(0, 0)], module=STOCK_TYPES["flat"]))
    assert ev.evaluated == 0
    assert not admissible(mq.Structure([(i, 0) for i in range(4)]), N_MAX)
    assert not admissible(mq.Structure([(0, 0)], module=STOCK_TYPES["flat"]), N_MAX)
    assert admissible(mq.Structure([(0, 0)], module=STOCK_TYPES["flat"]), 1, palette("t45,flat"))
    assert admissible(mq.Structure([(0, 0)], module=mq.TModule()), 1)  # the same data


class Counting:
    """Decides every 1- and 2-module line through the evaluator, returns the horizontal pair."""

    name = "counting"

    def __init__(self, n_max: int = 7, tier: str | None = None) -> None:
        self.told = (n_max, tier)
        self.seen_meta: list[dict] = []

    def solve(self, problem, evaluator):
        assert isinstance(problem, mq.SearchProblem) and problem.n_max == N_MAX
        self.seen_meta.append(dict(problem.task.meta))
        for cells in ([(0, 0)], [(0, 0), (0, 1)], [(0, 0), (1, 0)]):
            if evaluator.evaluate(cells):
                return cells
        return None


def test_an_outside_agent_is_counted_by_the_benchmark_and_sees_no_meta():
    task = _tasks()[0]
    agent = Counting()
    r = ExternalSolver(agent, "counting", n_max=N_MAX).solve(task)
    assert r.n_modules == 2 and r.evaluated == 3 and r.oracle_calls == 3 * len(task.wrenches)
    assert agent.seen_meta == [{}] and "optimum" in task.meta  # the task itself keeps it


class Cheating:
    """Reads the answer from whatever it is handed: the problem, its task, the evaluator."""

    name = "cheating"

    def solve(self, problem, evaluator):
        for holder in (problem.task, evaluator.task, evaluator.problem.task):
            meta = getattr(holder, "meta", None) or {}
            if "cells" in meta or "planted" in meta:
                return [tuple(c) for c in meta.get("cells", meta.get("planted"))]
        return None


def test_a_cheating_agent_finds_no_answer_in_what_it_is_handed():
    from modquad_gym.scoring.tiers import SUITES_DIR
    from modquad_gym.tasks.suites import load_suite

    tasks = load_suite(SUITES_DIR / "heldout_planted.json")[:3]
    assert all(t.meta for t in tasks)  # the held-out tasks do carry their optimum
    for task in tasks:
        r = ExternalSolver(Cheating(), "cheating", n_max=7).solve(task)
        assert r.structure is None and r.status == "no answer"
        assert task.meta  # the benchmark's own copy keeps it


def test_an_answer_never_evaluated_counts_once_and_a_larger_own_report_wins():
    task = _tasks()[0]
    r = ExternalSolver(lambda t: [(0, 0), (1, 0)], "blind", n_max=N_MAX).solve(task)
    assert (r.evaluated, r.oracle_calls) == (1, len(task.wrenches))  # its answer, decided once

    def reported(t):
        return SearchResult(mq.Structure([(0, 0), (1, 0)]), 2, 50, 600, 0.0, False, "own", N_MAX)

    r = ExternalSolver(reported, "own", n_max=N_MAX).solve(task)
    assert (r.evaluated, r.oracle_calls) == (50, 600)

    def keyword(t, evaluator=None):
        evaluator.evaluate([(0, 0)])
        return None

    r = ExternalSolver(keyword, "kw", n_max=N_MAX).solve(task)
    assert r.structure is None and r.evaluated == 1


def _agent_module(folder: Path) -> str:
    (folder / "outside_agents_for_tests.py").write_text(
        textwrap.dedent("""
        import modquad_gym as mq

        TOLD = []

        class Counting:
            name = "counting"

            def __init__(self, n_max=7, tier=None, modules=None):
                TOLD.append((n_max, tier, [m.name for m in modules] if modules else None))

            def solve(self, task, evaluator):
                for cells in ([(0, 0)], [(0, 0), (0, 1)], [(0, 0), (1, 0)]):
                    if evaluator.evaluate(cells):
                        return cells
                return None

        def too_big(task):
            return [(i, 0) for i in range(4)]
        """)
    )
    return "outside_agents_for_tests"


def test_load_solver_tells_the_agent_the_tier(tmp_path, monkeypatch):
    monkeypatch.syspath_prepend(str(tmp_path))
    name = _agent_module(tmp_path)
    solver = load_solver(f"{name}:Counting", n_max=5, tier="mixed", modules=palette("t45,flat"))
    told = sys.modules[name].TOLD
    assert told[-1] == (5, "mixed", ["t45", "flat"])
    assert solver.n_max == 5 and solver.tier == "mixed"
    assert make_solver(f"{name}:Counting", n_max=4, tier="large").tier == "large"
    assert told[-1] == (4, "large", None)


def test_the_benchmark_reports_the_agent_and_draws_it(tmp_path, monkeypatch):
    from modquad_gym.scoring import agents as benchmark
    from modquad_gym.viz import drawing

    monkeypatch.syspath_prepend(str(tmp_path))
    name = _agent_module(tmp_path)
    titles: list[str] = []
    draw = drawing.draw_structure
    monkeypatch.setattr(drawing, "draw_structure", lambda s, **kw: titles.append(kw["title"])
                        or draw(s, **kw))  # fmt: skip
    suite = save_suite(_tasks(), tmp_path / "tiny.json")
    out = tmp_path / "rep"
    argv = ["--suite", str(suite), "--n-max", str(N_MAX), "--solver", f"{name}:Counting",
            "--solver", f"{name}:too_big", "--out", str(out), "--no-progress"]  # fmt: skip
    assert benchmark.main(argv) == 0
    with open(out / "benchmark.csv") as fh:
        rows = list(csv.DictReader(fh))
    methods = {r["method"] for r in rows}
    assert not any(m.startswith("ppo") for m in methods)  # the searches are the reference
    mine = [r for r in rows if r["method"] == f"{name}:Counting"]
    assert len(mine) == 2 and all(int(r["evaluated"]) >= 2 for r in mine)
    assert all(r["success"] == "1" and r["optimal"] == "1" for r in mine)
    big = [r for r in rows if r["method"] == f"{name}:too_big"]
    assert big and all(r["success"] == "0" for r in big)  # beyond n_max: never a success
    report = (out / "benchmark.md").read_text()
    assert f"## Outside agent `{name}:Counting`" in report and "Told n_max = 3" in report
    for shipped in ("PPO model", "Where PPO falls short", "learning curve", "## Goals"):
        assert shipped not in report
    assert not (out / "learning_curve.png").exists() and (out / "structures.png").is_file()
    assert any(t.startswith("Counting:") for t in titles)


def test_outside_agents_are_not_judged_on_the_learned_methods_goals():
    from modquad_gym.scoring.agents_report import _goals

    def summary(method, evaluated):
        return {"method": method, "success_rate": 1.0, "optimal_share": 1.0,
                "mean_evaluated": evaluated}  # fmt: skip

    rows = [summary("centrosymmetric", 8.0), summary("ppo", 5.0), summary("pkg:Agent", 0.0)]
    lines = _goals(rows, {"ppo": {"configs": "centrosymmetric"}})
    assert any(line.startswith("| ppo |") for line in lines)
    assert not any("pkg:Agent" in line for line in lines)


def test_the_agent_is_compared_with_the_best_other_search_by_optimal_count_then_seconds():
    """milp counts only the structures its program hands the oracle (one per task, usually):
    the best other search is ranked by optimal count, then seconds, and milp's count is
    marked in the tables, with a note saying what it counts."""
    from modquad_gym.scoring.agents_report import _outside, _summary_table

    def summary(method, evaluated, seconds):
        return {"method": method, "tasks": 10, "success_rate": 1.0, "mean_modules": 4.4,
                "optimal_share": 1.0, "mean_gap": 0.0, "mean_evaluated": evaluated,
                "mean_oracle_calls": 100.0, "mean_seconds": seconds}  # fmt: skip

    rows = [summary("milp", 1.0, 1.2129), summary("beam", 18.8, 0.0108),
            summary("pkg:Agent", 3.0, 0.001)]  # fmt: skip
    text = "\n".join(_outside(rows, 7, "current"))
    assert "best other search here (by optimal count, then seconds), beam," in text
    assert "0.0108 s and 18.8 configurations per task" in text
    table = "\n".join(_summary_table(rows))
    assert "| 1.0\\* |" in table and "| 18.8 |" in table
    assert "\\* milp: its configurations count only the structures" in table
    assert "\\*" not in "\n".join(_summary_table(rows[1:]))
