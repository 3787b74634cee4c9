"""An outside agent cannot score what it did not solve: the scorer rebuilds every answer from
its integer cells on the tier's own types (a Structure subclass that claims another module
count or matrix changes nothing), hands the agent a deep copy of each task under a neutral name
(editing it edits nothing of the scorer's), refuses an answer verified below the certified
optimum, and counts what it can count."""

from __future__ import annotations

import textwrap

import numpy as np
import pytest

import modquad_gym as mq
from modquad_gym.scoring.agents import run_benchmark
from modquad_gym.scoring.suites import with_optimum
from modquad_gym.solvers import ExternalSolver
from modquad_gym.tasks import PlantedTasks

N_MAX = 3
MODULE = "cheat_agents_for_tests"

AGENTS = textwrap.dedent("""
    import numpy as np
    import modquad_gym as mq

    SEEN = []

    def _liar(count):
        class Liar(mq.Structure):
            @property
            def n_modules(self):
                return count
        return Liar

    class OverBudget:
        name = "over-budget"
        def solve(self, task, evaluator):  # 4 real modules at n_max 3, claiming 1
            return _liar(1)([(i, 0) for i in range(4)], module=evaluator.modules[0])

    class ClaimsOne:
        name = "claims-one"
        def solve(self, task, evaluator):  # a real feasible 2-module answer, claiming 1
            for cells in ([(0, 0), (1, 0)], [(0, 0), (0, 1)]):
                if evaluator.evaluate(cells):
                    return _liar(1)(cells, module=evaluator.modules[0])

    class Strong:
        name = "strong"
        def solve(self, task, evaluator):  # one module whose matrix says 1000 x the thrust
            class Scaled(mq.Structure):
                def configuration_matrix(self, *a, **k):
                    return 1000.0 * super().configuration_matrix(*a, **k)
            return Scaled([(0, 0)], module=evaluator.modules[0])

    class ZeroWrenches:
        name = "zero-wrenches"
        def solve(self, task, evaluator):  # unlocks the handed task's wrenches, zeroes them
            SEEN.append(task.name)
            w = task.task.wrenches
            w.flags.writeable = True
            w[:] = 0.0
            return [(0, 0)]
""")


@pytest.fixture(scope="module")
def agents(importable):
    """The agents above as an importable module."""
    return importable(MODULE, AGENTS)


def _suite() -> dict[str, list]:
    """Two planted 2-module tasks with their certified optimum (2)."""
    gen = PlantedTasks(n_modules=2, n_wrenches=12)
    return {"tiny": [with_optimum(gen(np.random.default_rng(s)), N_MAX) for s in (0, 1)]}


def _rows(methods: list[str], suites=None) -> dict[str, list]:
    rows = run_benchmark(suites or _suite(), methods, N_MAX, progress=False)
    return {m: [r for r in rows if r.method == m] for m in methods}


def test_an_answer_is_scored_by_its_cells_not_by_what_its_object_claims(agents):
    rows = _rows([f"{MODULE}:{a}" for a in ("OverBudget", "ClaimsOne", "Strong")])
    over, claims, strong = rows.values()
    assert not any(r.success for r in over)  # 4 modules at n_max 3, whatever it says
    assert all(r.success and r.n_modules == 2 and r.gap == 0 for r in claims)
    assert all(len(r.cells) == 2 for r in claims)
    assert not any(r.success for r in strong)  # the scorer's own matrix decides


def test_the_agent_edits_its_own_copy_of_a_task_under_a_neutral_name(agents):
    suites = _suite()
    before = [t.wrenches.copy() for t in suites["tiny"]]
    agents.SEEN.clear()
    (rows,) = _rows([f"{MODULE}:ZeroWrenches"], suites).values()
    assert not any(r.success for r in rows)  # one module lifts none of these tasks
    assert all(np.array_equal(t.wrenches, w) for t, w in zip(suites["tiny"], before))
    assert agents.SEEN == ["task-1", "task-2"]  # not the suite's keys
    assert [r.task for r in rows] == [t.name for t in suites["tiny"]]  # the report's are


def test_the_handed_problem_shares_no_array_and_no_meta_with_the_scorers():
    (task,) = _suite()["tiny"][:1]
    got: list = []
    ExternalSolver(lambda t: got.append(t), "x", n_max=N_MAX).solve(task)
    (given,) = got
    assert given.task.name == "task-1" and given.task.meta == {} and task.meta["optimum"] == 2
    assert not np.shares_memory(given.task.wrenches, task.wrenches)
    assert not np.shares_memory(given.wrenches, task.wrenches)


def test_an_answer_below_the_certified_optimum_is_an_error_naming_method_and_task(tmp_path):
    from modquad_gym.scoring import agents as benchmark
    from modquad_gym.tasks import save_suite

    (task,) = _suite()["tiny"][:1]
    wrong = task.relabelled(task.name, {**task.meta, "optimum": 3})  # above the real 2
    with pytest.raises(ValueError, match=r"exhaustive: task '.*': an answer of 2 modules "
                       r"verified below the suite's certified optimum 3"):  # fmt: skip
        run_benchmark({"tiny": [wrong]}, ["exhaustive"], N_MAX, progress=False)
    of_a_fault = task.relabelled(task.name, {**task.meta, "optimum": 3, "optimum_fault": "rotor"})
    (row,) = run_benchmark({"tiny": [of_a_fault]}, ["exhaustive"], N_MAX, progress=False)
    assert row.gap == -1  # the optimum of another failure bounds nothing here
    path = save_suite([wrong], tmp_path / "wrong.json")
    argv = ["--suite", str(path), "--n-max", "3", "--methods", "greedy", "--out",
            str(tmp_path / "r"), "--no-progress"]  # fmt: skip
    assert benchmark.script(argv) == 2


def test_an_answer_beyond_n_max_counts_as_one_configuration():
    (task,) = _suite()["tiny"][:1]
    r = ExternalSolver(lambda t: [(i, 0) for i in range(4)], "big", n_max=N_MAX).solve(task)
    assert (r.evaluated, r.oracle_calls, r.n_modules) == (1, 0, 4)


@pytest.mark.parametrize("value", [float("nan"), "many", 2.5, float("inf")])
def test_a_count_that_is_not_one_is_a_line_naming_agent_attribute_and_value(value):
    (task,) = _suite()["tiny"][:1]

    class Reports:
        name = "reports"
        oracle_calls = value

        def solve(self, t):
            return [(0, 0)]

    said = r"solver 'reports' reports oracle_calls = .*: not a count"
    with pytest.raises(ValueError, match=said):
        ExternalSolver(Reports(), "reports", n_max=N_MAX).solve(task)


def test_counts_come_from_what_the_evaluator_decided_not_from_its_attributes():
    (task,) = _suite()["tiny"][:1]

    def forgets(t, evaluator):
        evaluator.evaluate([(0, 0)])
        with pytest.raises(AttributeError):
            evaluator.evaluated = 0  # read-only: its decisions are the count
        return [(0, 0), (1, 0)]

    r = ExternalSolver(forgets, "forgets", n_max=N_MAX).solve(task)
    assert (r.evaluated, r.oracle_calls) == (2, 2 * len(task.wrenches))


def test_an_answer_of_types_copied_from_the_evaluator_is_counted_once(agents):
    (task,) = _suite()["tiny"][:1]
    r = ExternalSolver(agents.ClaimsOne(), "claims-one", n_max=N_MAX).solve(task)
    assert r.n_modules == 2 and type(r.structure) is mq.Structure
    assert r.structure.module is mq.Structure([(0, 0)]).module  # the scorer's own type
    asked = 1 if set(r.structure.cells) == {(0, 0), (1, 0)} else 2  # its evaluate() calls
    assert r.evaluated == asked  # its answer was decided through the evaluator: not again


def test_the_docs_say_what_scoring_in_the_agents_process_cannot_guard():
    from pathlib import Path

    docs = Path(__file__).resolve().parents[1] / "docs"
    protocol = " ".join((docs / "benchmarks.md").read_text().split())
    for said in ("**This is honour-based**", "a **lower bound**", "no time limit per task",
                 "named `task-1`, `task-2`"):  # fmt: skip
        assert said in protocol
    envs = " ".join((docs / "environments.md").read_text().split())
    assert "never hand a held-out suite to an agent under evaluation" in envs
    notes = " ".join((docs / "design-notes.md").read_text().split())
    assert "A state object handed out is trusted as it is, by identity" in notes
