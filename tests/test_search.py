"""Searches: the exhaustive search is the true minimum (brute force with an LP), the
centrosymmetric search returns centrosymmetric feasible structures, baselines are seeded."""

import numpy as np
import pytest

import modquad_gym as mq
from modquad_gym.search import (
    SEARCHES,
    centrosymmetric_search,
    exhaustive_search,
    force_lower_bound,
    greedy_search,
    random_search,
)
from modquad_gym.structure import free_neighbours, structure_levels


def planted(n, t, seed):
    rng = np.random.default_rng(seed)
    cells = [(0, 0)]
    while len(cells) < n:
        options = free_neighbours(cells)
        cells.append(options[int(rng.integers(len(options)))])
    A = mq.Structure(cells).configuration_matrix()
    U = rng.uniform(0, 1, (t, A.shape[1]))
    vertex = rng.uniform(size=U.shape) < 0.8
    U[vertex] = rng.integers(0, 2, int(vertex.sum()))
    return (A @ U.T).T


def brute_force_minimum(W, n_max):
    """The smallest n with a feasible structure, by the plain DAQP LP on every structure."""
    for n, level in enumerate(structure_levels(n_max), start=1):
        for key in level:
            A = mq.Structure(key).configuration_matrix()
            if mq.feasible(A, W, method="daqp").all():
                return n
    return None


@pytest.mark.parametrize("n, seed", [(1, 0), (2, 1), (3, 2), (3, 3), (4, 4), (4, 5), (5, 6)])
def test_exhaustive_is_the_minimum(n, seed):
    W = planted(n, 12, seed)
    result = exhaustive_search(W, n_max=5)
    assert result.certified
    assert result.structure is not None and result.n_modules <= n
    assert result.n_modules == brute_force_minimum(W, 5)
    A = result.structure.configuration_matrix()
    assert mq.feasible(A, W, method="scipy").all()  # verified by HiGHS too
    assert result.evaluated >= 1 and result.oracle_calls >= result.evaluated


def test_exhaustive_reports_infeasible_as_certified_none():
    W = np.array([[0, 0, 100.0, 0, 0, 0]])  # far more lift than 3 modules have
    result = exhaustive_search(W, n_max=3)
    assert result.structure is None and result.n_modules is None and result.certified
    assert result.skipped_levels == [1, 2, 3]
    W = np.array([[0, 0, 1.0, 0, 0, 3.0]])  # a yaw torque no small structure makes
    result = exhaustive_search(W, n_max=3)
    assert result.structure is None
    searched = [lv for n, lv in enumerate(structure_levels(3), 1) if n not in result.skipped_levels]
    assert result.evaluated == sum(len(lv) for lv in searched)  # every structure, no pruning


def test_force_lower_bound_is_exact():
    module = mq.TModule()
    for seed in range(6):
        W = planted(4, 10, 100 + seed) * 1.3
        n_lb = force_lower_bound(W, module)
        for level in structure_levels(min(n_lb - 1, 4)):
            for key in level:  # nothing below the bound can exert the forces
                A = mq.Structure(key).configuration_matrix()
                assert not mq.feasible(A, W).all()


@pytest.mark.parametrize("seed", range(5))
def test_centrosymmetric_results(seed):
    W = planted(3 + seed % 3, 10, 200 + seed)
    result = centrosymmetric_search(W, n_max=7)
    exact = exhaustive_search(W, n_max=7)
    if result.structure is not None:
        assert result.structure.is_centrosymmetric()
        assert mq.feasible(result.structure.configuration_matrix(), W, method="scipy").all()
        assert result.n_modules >= exact.n_modules
    block = centrosymmetric_search(W, n_max=7, block_seed=True)
    if block.structure is not None:
        assert block.structure.is_centrosymmetric()
        assert block.n_modules <= (result.n_modules or 99)


def test_centrosymmetric_levels_follow_algorithm_2():
    # an impossible task walks every level: 1, then the 2 lines of 3, then their children
    W = np.array([[0, 0, 1.0, 0, 0, 50.0]])
    result = centrosymmetric_search(W, n_max=5)
    assert result.structure is None
    assert result.evaluated > 3


def test_greedy_and_random_are_feasible_and_seeded():
    W = planted(4, 10, 7)
    for fn in (greedy_search, random_search):
        result = fn(W, n_max=7)
        if result.structure is not None:
            assert mq.feasible(result.structure.configuration_matrix(), W, method="scipy").all()
            assert result.n_modules >= exhaustive_search(W, n_max=7).n_modules
    a = random_search(W, n_max=7, seed=3, restarts=3)
    b = random_search(W, n_max=7, seed=3, restarts=3)
    assert a.to_dict()["cells"] == b.to_dict()["cells"] and a.evaluated == b.evaluated


def test_searches_accept_task_objects_and_reject_bad_input():
    class Task:
        wrenches = planted(2, 5, 9)
        f_max = 1.0

    for name, fn in SEARCHES.items():
        assert fn(Task(), n_max=4).structure is not None, name
    with pytest.raises(ValueError, match="n_max"):
        exhaustive_search(planted(2, 5, 9), n_max=0)
    with pytest.raises(ValueError, match="shape"):
        exhaustive_search(np.zeros((3, 5)))
    with pytest.raises(ValueError, match="f_max"):
        exhaustive_search(planted(2, 5, 9), f_max=-1)


def test_larger_f_max_needs_no_more_modules():
    W = planted(5, 12, 11)
    assert exhaustive_search(W, n_max=6, f_max=2.0).n_modules <= exhaustive_search(W).n_modules
