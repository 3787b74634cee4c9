"""The streaming search engine: polyomino counts, canonical order, agreement with the search as
it was (benchmarks/reference_search.py), exact level bounds, and bounded resources."""

from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import benchmarks.reference_search as reference
import modquad_gym as mq
from modquad_gym.core.distributed import Engine
from modquad_gym.geometry import polyominoes
from modquad_gym.geometry.structure import free_neighbours, normalise, structure_levels
from modquad_gym.search import exhaustive_search, optimal_structures, scan_chunks
from modquad_gym.search.bounds import (
    compute_level_bounds,
    force_lower_bound,
    level_directions,
    level_excluded,
)
from modquad_gym.search.problem import EXACT_MODULES


def random_structure(n, rng):
    cells = [(0, 0)]
    while len(cells) < n:
        options = free_neighbours(cells)
        cells.append(options[int(rng.integers(len(options)))])
    return mq.Structure(cells)


def planted(n, t, rng, vertex=0.9):
    A = random_structure(n, rng).configuration_matrix()
    U = rng.uniform(0, 1, (t, A.shape[1]))
    on = rng.uniform(size=U.shape) < vertex
    U[on] = rng.integers(0, 2, int(on.sum()))
    return (A @ U.T).T


@pytest.mark.parametrize("n", range(1, 13))
def test_counts_match_oeis_a001168(n):
    assert polyominoes.count(n) == polyominoes.A001168[n - 1]


@pytest.mark.slow
@pytest.mark.parametrize("n", [13, 14])
def test_counts_match_oeis_a001168_large(n):
    assert polyominoes.count(n) == polyominoes.A001168[n - 1]


def test_levels_are_distinct_connected_and_complete():
    """Each level is exactly the set of one-module extensions of the previous one."""
    levels = list(structure_levels(7))
    for n, level in enumerate(levels, start=1):
        assert len(set(level)) == len(level) == polyominoes.A001168[n - 1]
        assert all(mq.Structure(key).n_modules == n for key in level)  # connected, distinct
    for smaller, level in zip(levels, levels[1:]):
        grown = {normalise(k + (c,)) for k in smaller for c in free_neighbours(k)}
        assert grown == set(level)


@pytest.mark.parametrize("chunk", [1, 7, 1000])
def test_canonical_order_does_not_depend_on_the_chunk(chunk):
    whole = np.concatenate(list(polyominoes.PolyominoStream(8, 1 << 16)))
    chunked = np.concatenate(list(polyominoes.PolyominoStream(8, chunk)))
    assert np.array_equal(whole, chunked)
    middle = np.concatenate(list(polyominoes.level_chunks(8, chunk, 1, 3)))
    assert np.array_equal(middle, whole[chunk : 3 * chunk])


@pytest.mark.parametrize("seed", range(24))
def test_same_minimum_as_the_reference_search(seed):
    rng = np.random.default_rng(seed)
    W = planted(int(rng.integers(1, 9)), int(rng.integers(4, 20)), rng)
    old = reference.exhaustive_search(W, n_max=9)
    new = exhaustive_search(W, n_max=9)
    assert new.n_modules == old.n_modules and new.certified
    if new.structure is not None:
        assert mq.feasible(new.structure.configuration_matrix(), W, method="scipy").all()
        n, keys = reference.optimal_structures(W, n_max=9)
        assert new.structure.key in set(keys)


@pytest.mark.parametrize("seed", range(6))
def test_optimal_structures_agree_with_the_reference(seed):
    rng = np.random.default_rng(100 + seed)
    W = planted(int(rng.integers(2, 7)), 6, rng)
    n_old, old = reference.optimal_structures(W, n_max=7)
    n_new, new = optimal_structures(W, n_max=7)
    assert n_new == n_old and set(new) == set(old) and len(new) == len(old)


def test_answer_does_not_depend_on_chunk_or_workers():
    rng = np.random.default_rng(7)
    W = planted(9, 10, rng)
    answers = {
        exhaustive_search(W, n_max=10, chunk=c, engine=e).structure.key
        for c, e in [(16384, None), (97, None), (5000, Engine(2))]
    }
    assert len(answers) == 1


def test_scan_chunks_splits_a_level_into_ranges():
    rng = np.random.default_rng(8)
    W = planted(6, 8, rng)
    n, keys = optimal_structures(W, n_max=6)
    first = [scan_chunks(W, 1.0, mq.TModule(), n, 50, a, a + 1)[0] for a in range(0, 20)]
    assert next(k for k in first if k is not None) == keys[0]


@settings(max_examples=25, deadline=None)
@given(st.integers(0, 10**6), st.integers(2, 8))
def test_level_bounds_never_skip_a_feasible_level(seed, n):
    """Every wrench a structure of n modules can exert passes the level-n bound."""
    rng = np.random.default_rng(seed)
    s = random_structure(n, rng)
    A = s.configuration_matrix()
    U = rng.integers(0, 2, (16, A.shape[1])).astype(float)  # vertices: on the boundary
    W = (A @ U.T).T
    assert not level_excluded(W, 1.0, s.module, n)
    assert not level_excluded(3.0 * W, 3.0, s.module, n)  # scale-invariant with f_max


def test_level_bounds_are_the_maximum_over_the_level():
    module = mq.TModule()
    D = level_directions()
    bounds = compute_level_bounds(module, 4)
    supports = [
        np.maximum(D @ mq.Structure(k).configuration_matrix(), 0).sum(axis=1)
        for k in next(iter(reversed(list(structure_levels(4)))))
    ]
    assert np.allclose(bounds[0], np.max(supports, axis=0), rtol=1e-12, atol=1e-12)


def test_level_bounds_skip_levels_of_a_torque_task():
    W = np.array([[0.0, 0.0, 3.0, 1.5, 0.0, 0.0]])
    r = exhaustive_search(W, n_max=8)
    assert r.skipped_levels and max(r.skipped_levels) > force_lower_bound(W, mq.TModule())


def test_impossible_forces_answer_at_once_for_any_n_max():
    W = np.array([[0.0, 0.0, -3.0, 0.0, 0.0, 0.0]])  # rotors never pull down
    for search in mq.search.SEARCHES.values():
        r = search(W, n_max=10**9)
        assert r.structure is None and "force bound" in r.proof


def test_n_max_beyond_the_limit_is_refused_before_work():
    W = np.array([[0.0, 0.0, 3.0, 50.0, 0.0, 0.0]])
    with pytest.raises(ValueError, match="n_max=30"):
        exhaustive_search(W, n_max=30)
    assert EXACT_MODULES >= 14


@pytest.mark.parametrize("bad", [True, 2.0, "7", 0, -1, None])
def test_n_max_must_be_a_positive_integer(bad):
    with pytest.raises(ValueError, match="n_max"):
        exhaustive_search(np.array([[0, 0, 1.0, 0, 0, 0]]), n_max=bad)


def test_empty_task_is_a_clear_error():
    with pytest.raises(ValueError, match="no wrenches"):
        exhaustive_search(np.zeros((0, 6)), n_max=3)


SEARCH_128 = """
import json
import numpy as np
import modquad_gym as mq
from benchmarks.measure import own_peak_mb  # this process's own peak, not its parent's
from modquad_gym.tasks import PlantedTasks

task = PlantedTasks(n_modules=(128, 128), n_wrenches=(8, 8))(np.random.default_rng(3))
r = mq.anytime_search(task, n_max=128, time_limit=60)
print(json.dumps({"cells": None if r.structure is None else [list(c) for c in r.structure.cells],
                  "n_modules": r.n_modules, "lower_bound": r.lower_bound,
                  "peak_kb": round(own_peak_mb() * 1024)}))
"""
"""The 128-module search alone in a fresh process, whose lifetime peak is the search's (an
earlier test's memory in pytest's process is not)."""


def test_a_task_planted_in_128_modules():
    """n_max 128 (issue 35): the default search answers a task planted in 128 modules with a
    verified structure within 5 % of the planted size and a proved bound, in bounded memory."""
    import json
    import subprocess
    import sys

    from modquad_gym.geometry.structure import Structure
    from modquad_gym.tasks import PlantedTasks

    task = PlantedTasks(n_modules=(128, 128), n_wrenches=(8, 8))(np.random.default_rng(3))
    root = Path(__file__).resolve().parents[1]  # where benchmarks.measure is found
    out = subprocess.run([sys.executable, "-c", SEARCH_128], capture_output=True, text=True,
                         timeout=600, check=True, cwd=root)  # fmt: skip
    r = json.loads(out.stdout.splitlines()[-1])
    assert r["cells"] is not None and r["n_modules"] <= 1.05 * 128
    structure = Structure([tuple(c) for c in r["cells"]])
    assert mq.search.verified(structure, task) and r["lower_bound"] <= r["n_modules"]
    assert r["peak_kb"] < 1024**2  # 1 GB for the whole process (188 MB measured here)
    with pytest.raises(ValueError, match="n_max=129"):
        mq.anytime_search(task, n_max=129)
