"""The fault-tolerant tier: its held-out suite's optima survive a rotor failure and are no smaller
than the intact optima; scoring asks the searches for tolerant answers and counts only those;
the methods that cannot honour the failure are refused in one line."""

from __future__ import annotations

import numpy as np
import pytest

import modquad_gym as mq
from modquad_gym.cli import main as cli_main
from modquad_gym.geometry.cells import is_connected
from modquad_gym.scoring.agents import run_benchmark, survives
from modquad_gym.scoring.tiers import TIERS, honours_fault

TIER = TIERS["fault"]


def _tasks(n: int):
    return TIER.load_suites(limit=n)[TIER.suites[0]]


def survives_by_hand(structure, task) -> bool:
    """Plain reference: the oracle on A without each rotor's column in turn."""
    A = structure.configuration_matrix()
    W = task.rotor_wrenches(structure)
    return all(mq.feasible(np.delete(A, k, axis=1), W, task.f_max).all() for k in range(A.shape[1]))


def test_the_suite_optima_survive_a_rotor_failure_and_bound_the_intact_optimum():
    for task in _tasks(6):
        meta = task.meta
        assert (meta["optimum_fault"], meta["optimum_n_max"]) == ("rotor", TIER.n_max)
        best = mq.Structure([tuple(c) for c in meta["optimum_cells"]])
        assert best.n_modules == meta["optimum"]
        assert survives(best, task, "rotor") and survives_by_hand(best, task)
        intact = mq.exhaustive_search(task, n_max=TIER.n_max)
        assert intact.n_modules <= meta["optimum"]  # tolerance never costs fewer modules


def test_survives_agrees_with_the_plain_reference_near_the_boundary():
    """Structures one module short of the tolerant optimum and the optimum itself: the fast
    decision and the column-by-column LP agree on every one."""
    task = _tasks(1)[0]
    best = mq.Structure([tuple(c) for c in task.meta["optimum_cells"]])
    smaller = [best.cells[:k] for k in range(1, best.n_modules) if is_connected(best.cells[:k])]
    smaller = [mq.Structure(cells) for cells in smaller]
    line = mq.Structure([(i, 0) for i in range(best.n_modules)])  # rank-deficient: a line
    for s in [best, line, *smaller]:
        assert survives(s, task, "rotor") == survives_by_hand(s, task), s.cells


def test_scoring_asks_for_tolerant_answers_and_counts_only_those():
    suites = {TIER.suites[0]: _tasks(2)}
    rows = run_benchmark(suites, ["greedy", "exhaustive"], TIER.n_max, progress=False,
                         fault="rotor")  # fmt: skip
    tasks = {t.name: t for t in suites[TIER.suites[0]]}
    for r in rows:
        structure = mq.Structure([tuple(c) for c in r.cells]) if r.cells else None
        assert r.success == (structure is not None and survives_by_hand(structure, tasks[r.task]))
    assert all(r.optimal for r in rows if r.method == "exhaustive")
    with pytest.raises(ValueError, match="milp cannot honour it"):
        run_benchmark(suites, ["milp"], TIER.n_max, progress=False, fault="rotor")


def test_methods_that_cannot_honour_the_failure_are_refused_in_one_line(tmp_path, capsys):
    honoured = [m for m in ("exhaustive", "anytime", "milp", "ppo", "ppo-k8", "x:Y", "bogus")
                if honours_fault(m)]  # fmt: skip
    assert honoured == ["exhaustive", "anytime", "ppo", "ppo-k8", "x:Y"]
    argv = ["score", "--tier", "fault", "--methods", "greedy", "milp", "--out", str(tmp_path)]
    assert cli_main(argv) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "milp cannot guarantee" in err[0]
    assert not list(tmp_path.iterdir())  # refused before any work


def test_the_shipped_suite_is_reproduced_from_its_seeds():
    """python -m modquad_gym.scoring.tiers fault: the same draws (within a tolerance: CPUs
    differ in the last bits) and the same certified optima."""
    from modquad_gym.scoring.tiers import build_tier_suite

    for shipped, rebuilt in zip(_tasks(2), build_tier_suite(TIER, 2, progress=False), strict=True):
        np.testing.assert_allclose(rebuilt.wrenches, shipped.wrenches, rtol=1e-12, atol=1e-12)
        assert rebuilt.meta["optimum"] == shipped.meta["optimum"]
        assert set(rebuilt.meta) == set(shipped.meta)  # the same keys (intact_* when planted)


def test_the_learned_methods_design_for_the_failure_and_every_answer_survives():
    """Trained without failures, the policies act zero-shot: the environment's episode ends only
    once every wrench survives, and each answer is verified; none beats the certified optimum,
    and none is certified unless it reaches the failure's own lower bound."""
    suites = {TIER.suites[0]: _tasks(4)}
    tasks = {t.name: t for t in suites[TIER.suites[0]]}
    rows = run_benchmark(suites, ["ppo", "ppo-k8", "ppo-guided"], TIER.n_max, model=TIER.model,
                         progress=False, fault="rotor")  # fmt: skip
    assert {r.method for r in rows} == {"ppo", "ppo-k8", "ppo-guided"}
    for r in rows:
        task = tasks[r.task]
        assert r.success, r
        structure = mq.Structure([tuple(c) for c in r.cells])
        assert survives_by_hand(structure, task)
        assert r.n_modules >= task.meta["optimum"]
    solver = mq.make_solver("ppo", n_max=TIER.n_max, fault="rotor")
    for task in tasks.values():
        r = solver.solve(task)
        assert r.fault == "rotor" and r.lower_bound <= task.meta["optimum"]
        assert r.certified == (r.n_modules == r.lower_bound)
        intact = mq.make_solver("ppo", n_max=TIER.n_max).solve(task)
        assert intact.fault is None and intact.lower_bound <= r.lower_bound


def test_the_suites_planted_tasks_name_their_planted_count_intact_not_a_bound():
    """A planted task's hidden structure answers it intact: under the tier's fault its count is
    below the certified tolerant optimum, so the suite keeps it as ``intact_*`` only."""
    tasks = TIER.load_suites()[TIER.suites[0]]
    planted = [t.meta for t in tasks if "intact_planted_cells" in t.meta]
    named = [{"optimum_upper_bound", "planted_cells"} & set(t.meta) for t in tasks]
    assert planted and not any(named)
    for m in planted:
        assert m["intact_optimum_upper_bound"] == len(m["intact_planted_cells"])
    assert any(m["intact_optimum_upper_bound"] < m["optimum"] for m in planted)


def test_certifying_with_a_fault_renames_the_planted_answer_and_keeps_the_task():
    from modquad_gym.scoring.suites import with_optimum

    task = mq.tasks.PlantedTasks(n_modules=2, n_wrenches=8)(np.random.default_rng(3))
    tolerant, intact = with_optimum(task, 4, fault="rotor"), with_optimum(task, 4)
    assert intact.meta["optimum_upper_bound"] == 2 and "intact_planted_cells" not in intact.meta
    assert "optimum_upper_bound" not in tolerant.meta and "planted_cells" not in tolerant.meta
    assert tolerant.meta["intact_planted_cells"] == task.meta["planted_cells"]
    assert np.array_equal(tolerant.wrenches, task.wrenches) and tolerant.name == task.name
    assert tolerant.meta["optimum"] is None or tolerant.meta["optimum"] >= intact.meta["optimum"]
