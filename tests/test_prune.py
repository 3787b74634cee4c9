"""The prune post-pass (``prune=True``): every answer it gives is feasible for the problem (its
fault too), connected, made of the method's own modules, never below the certified optimum;
it removes what is redundant, stops at the time limit, and answers the same through every door
(tests/test_one_door.py drives the CLI with it)."""

from __future__ import annotations

import numpy as np
import pytest

import modquad_gym as mq
from modquad_gym.geometry.cells import is_connected
from modquad_gym.scoring.scale_tasks import draw
from modquad_gym.search import SEARCHES, verified
from modquad_gym.search.prune import prune, pruned
from modquad_gym.search.result import SearchRun
from modquad_gym.solvers import make_solver
from modquad_gym.tasks import PlantedTasks, load_task


def _planted(seed: int, n: int):
    return PlantedTasks(n_modules=n, n_wrenches=12)(np.random.default_rng(seed))


def _assert_pruned_from(small: mq.SearchResult, big: mq.SearchResult, problem) -> None:
    assert small.structure is not None and verified(small.structure, problem)
    assert is_connected(small.structure.cells)
    assert set(small.structure.cells) <= set(big.structure.cells)
    assert small.n_modules <= big.n_modules
    assert small.lower_bound == big.lower_bound <= small.n_modules


@pytest.mark.parametrize("seed", range(6))
def test_pruned_structures_are_feasible_connected_and_never_below_the_optimum(seed):
    rng = np.random.default_rng(seed)
    problem = mq.SearchProblem(_planted(seed, 2 + seed % 3), n_max=9)
    best = mq.exhaustive_search(problem).structure
    padded = best
    for _ in range(1 + seed % 3):  # modules docked at random free cells around the optimum
        free = padded.attachable_cells()
        padded = padded.with_cells(free[rng.integers(len(free))])
    run = SearchRun("test", problem)
    smaller = prune(run, padded, lambda: False)
    assert verified(smaller, problem) and is_connected(smaller.cells)
    assert set(smaller.cells) <= set(padded.cells)
    assert best.n_modules <= smaller.n_modules < padded.n_modules
    assert run.checker.evaluated >= padded.n_modules - smaller.n_modules
    untouched = prune(SearchRun("test", problem), padded, lambda: True)  # out of time
    assert untouched is padded


def test_a_pruned_search_result_keeps_its_fault_and_bound_and_adds_its_counts():
    problem = mq.SearchProblem(load_task("example:screwdriver"), n_max=10, fault="rotor")
    big = mq.random_search(problem, seed=6, time_limit=60.0)
    small = mq.random_search(problem, seed=6, time_limit=60.0, prune=True)
    _assert_pruned_from(small, big, problem)
    assert small.n_modules < big.n_modules and small.fault == "rotor"  # 5 -> 4 modules
    assert small.n_modules >= mq.exhaustive_search(problem).n_modules
    assert small.evaluated > big.evaluated and small.seconds >= big.seconds


def test_prune_gives_up_once_the_time_limit_is_spent():
    problem = mq.SearchProblem(_planted(5, 3), n_max=9)
    big = mq.random_search(problem, seed=1, time_limit=30.0)
    assert big.structure is not None
    spent = pruned(big, problem, time_limit=big.seconds)  # nothing left for the post-pass
    assert spent.structure.cells == big.structure.cells
    assert spent.evaluated == big.evaluated


def test_the_methods_that_build_take_prune_and_the_others_refuse_it():
    takes = {name for name, entry in SEARCHES.items() if entry.prunes}
    assert takes == {"greedy", "random", "beam", "genetic"}
    with pytest.raises(TypeError, match="has no option 'prune'"):
        make_solver("anytime", prune=True)
    with pytest.raises(TypeError, match="has no option 'prune'"):
        mq.exhaustive_search(_planted(0, 2), prune=True)


def test_the_learned_single_pass_prunes_what_it_docked_too_many():
    task = draw("torque", 24, 1, validation=True)  # a validation draw, never a held-out task
    plain = make_solver("ppo", n_max=40).solve(task)
    small = make_solver("ppo", n_max=40, prune=True).solve(task)
    assert plain.structure is not None
    _assert_pruned_from(small, plain, mq.SearchProblem(task, n_max=40))
    assert small.n_modules < plain.n_modules and small.method == "ppo"


def test_a_flag_that_is_not_true_or_false_is_refused_at_every_door(capsys):
    from modquad_gym.cli import main

    task = load_task("example:screwdriver")
    makers = (
        lambda: make_solver("greedy", prune="no"),
        lambda: mq.greedy_search(task, prune=1),
        lambda: make_solver("ppo", prune="yes"),
        lambda: make_solver("ppo-guided", dive="no"),
        lambda: make_solver("centrosymmetric", block_seed="no"),
    )
    for make in makers:
        with pytest.raises(ValueError, match="must be True or False"):
            make()
    argv = ["solve", "--task", "example:screwdriver", "--method", "greedy", "--option",
            "prune=maybe"]  # fmt: skip
    assert main(argv) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "prune=maybe" in err, err


def test_prune_keeps_the_start_every_answer_contains():
    task = _planted(0, 1)  # one module is enough: a 3-module start is redundant but kept
    start = [(0, 0), (1, 0), (2, 0)]
    assert mq.exhaustive_search(task, n_max=3).n_modules == 1
    for given in (start, iter(start), mq.Structure(start)):  # a generator is read once
        r = mq.greedy_search(task, n_max=5, start=given, prune=True)
        assert set(start) <= set(r.structure.cells) and r.n_modules == 3
    problem = mq.SearchProblem(task, n_max=5)
    free = prune(SearchRun("test", problem), mq.Structure(start), lambda: False)
    assert free.n_modules == 1  # nothing kept: the post-pass drops both spare modules
