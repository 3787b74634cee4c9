"""Searches: the exhaustive search is the true minimum (brute force with an LP), the
centrosymmetric search returns centrosymmetric feasible structures, baselines are seeded."""

import numpy as np
import pytest

import modquad_gym as mq
from modquad_gym.geometry.structure import free_neighbours, normalise, structure_levels
from modquad_gym.search import (
    SEARCHES,
    centrosymmetric_search,
    exhaustive_search,
    force_lower_bound,
    greedy_search,
    random_search,
)


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


def planted_on(cells, t, seed):
    """Wrenches inside the zonotope of the structure ``cells``, most at 0/1 rotor vertices."""
    rng = np.random.default_rng(seed)
    A = mq.Structure(cells).configuration_matrix()
    U = rng.uniform(0, 1, (t, A.shape[1]))
    vertex = rng.uniform(size=U.shape) < 0.8
    U[vertex] = rng.integers(0, 2, int(vertex.sum()))
    return (A @ U.T).T


# Centrosymmetric structures that Algorithm 2 reaches: from one module (odd counts) by adding
# a module and its partner about the COM, or from the 2 x 2 block (block_seed=True).
REACHABLE = [
    ([(0, 0), (1, 0), (2, 0)], False),  # horizontal line: (0,0) + (-1,0), (1,0)
    ([(0, 0), (0, 1), (0, 2)], False),  # vertical line
    ([(1, 0), (0, 1), (1, 1), (2, 1), (1, 2)], False),  # plus: a line + the other pair
    ([(0, 0), (1, 0), (1, 1), (1, 2), (2, 2)], False),  # S: a vertical line + a diagonal pair
    ([(0, 0), (1, 0), (0, 1), (1, 1)], True),  # the block seed
    ([(0, 0), (1, 0), (0, 1), (1, 1), (2, 0), (-1, 1)], True),  # block + a pair
]


@pytest.mark.parametrize("cells, block_seed", REACHABLE)
def test_centrosymmetric_finds_a_planted_centrosymmetric_structure(cells, block_seed):
    n = len(cells)
    assert mq.Structure(cells).is_centrosymmetric()
    W = planted_on(cells, 10, seed=n)
    result = centrosymmetric_search(W, n_max=n, block_seed=block_seed)
    assert result.structure is not None  # the planted structure is on the search's path
    assert result.n_modules <= n
    assert result.certified == (result.n_modules == result.lower_bound)  # met the exact bound
    assert result.structure.is_centrosymmetric()
    assert mq.feasible(result.structure.configuration_matrix(), W, method="scipy").all()
    optimum = exhaustive_search(W, n_max=n).n_modules
    assert result.lower_bound <= optimum <= result.n_modules
    assert result.evaluated >= 1


def test_centrosymmetric_reports_none_when_no_centrosymmetric_structure_works():
    # wrenches of the L tromino: the only centrosymmetric structures of up to 3 modules (one
    # module, the two straight lines of 3) cannot produce them (checked here by brute force)
    cells = [(0, 0), (1, 0), (0, 1)]
    W = planted_on(cells, 10, seed=0)
    symmetric = [
        key
        for level in structure_levels(3)
        for key in level
        if mq.Structure(key).is_centrosymmetric()
    ]
    assert sorted(map(len, symmetric)) == [1, 2, 2, 3, 3]  # pairs: unreachable from one module
    for key in symmetric:
        assert not mq.feasible(mq.Structure(key).configuration_matrix(), W, method="daqp").all()
    for block_seed in (False, True):
        result = centrosymmetric_search(W, n_max=3, block_seed=block_seed)
        assert result.structure is None and result.n_modules is None
        assert not result.certified and result.evaluated == 3  # 1 module, 2 lines
        assert result.lower_bound <= 3
    assert exhaustive_search(W, n_max=3).n_modules == 3  # the L itself is feasible


def test_centrosymmetric_levels_follow_algorithm_2():
    # an impossible task walks every level: one module, the 2 lines of 3, then every 5-module
    # structure made from a line by a pair of cells symmetric about its centre
    W = np.array([[0, 0, 1.0, 0, 0, 50.0]])
    result = centrosymmetric_search(W, n_max=5)
    assert result.structure is None  # and the level bounds prove that no structure works:
    assert result.certified and result.lower_bound == 6 and "exact bounds" in result.proof
    lines = {((0, 0), (1, 0), (2, 0)), ((0, 0), (0, 1), (0, 2))}
    fives = 0
    for key in list(structure_levels(5))[-1]:
        s = mq.Structure(key)
        if not s.is_centrosymmetric():
            continue
        pairs = {tuple(sorted((c, s.centrosymmetric_partner(c)))) for c in key}
        if any(normalise(set(key) - set(pair)) in lines for pair in pairs if len(set(pair)) == 2):
            fives += 1
    assert fives > 0
    assert result.evaluated == 1 + 2 + fives


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


def test_greedy_evaluates_each_child_structure_once():
    # from one module the 4 free cells give 2 structures (the horizontal and vertical pair);
    # from a pair the 6 free cells give 5 (the two ends of the line give the same line of 3)
    W = np.array([[0, 0, 1.0, 0, 0, 50.0]])  # impossible: greedy walks to n_max
    assert greedy_search(W, n_max=2).evaluated == 1 + 2
    result = greedy_search(W, n_max=3)
    assert result.structure is None and result.evaluated == 1 + 2 + 5
    W = planted(4, 10, 7)
    a, b = greedy_search(W, n_max=7), greedy_search(W, n_max=7)
    assert a.to_dict()["cells"] == b.to_dict()["cells"] and a.evaluated == b.evaluated


def test_low_force_benchmark_tasks_skip_no_level():
    """The benchmark's low-force tasks: the hidden structure satisfies them, their forces fit
    one module (the force bound skips no level) and f_z stays small."""
    from benchmarks.search import low_force_task, random_structure

    rng = np.random.default_rng(3)
    hidden = random_structure(8, rng)
    W = low_force_task(hidden, 12, rng)
    assert W.shape == (12, 6)
    assert mq.feasible(hidden.configuration_matrix(), W).all()
    assert force_lower_bound(W, hidden.module) == 1
    assert (W[:, 2] > 0).all() and (W[:, 2] <= 2.5 + 1e-9).all()


def test_levels_all_ruled_out_by_bounds_are_the_proof():
    """No level searched (every one excluded by the level bounds): the result says so, as the
    force bound's does, and ``modquad optima`` records it (it recorded no proof)."""
    result = exhaustive_search(np.array([[0, 0, 2.5, 3.0, 0, 0]]), n_max=5)
    assert result.structure is None and result.evaluated == 0 and result.certified
    assert result.proof == "level bounds: no structure of 1 to 5 modules reaches the task"
