"""The compiled certificates (method ``"compiled"``, the decisions of ``"auto"``) against HiGHS.

Wrenches are placed at chosen gauges gamma about the hover centre, down to within GUARD of the
threshold 1 + TOL on both sides (where no certificate may decide and the exact LP must), on
structures of every rank (one module: 4, straight lines: 5) and up to 64 modules (m = 256).
"""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from modquad_gym.geometry.structure import Structure, normalise
from modquad_gym.oracle import TOL, WrenchOracle, Zonotope, decide_with
from modquad_gym.oracle.compiled import verdicts
from modquad_gym.oracle.highs_lp import gamma_highs
from modquad_gym.oracle.tolerance import ACCEPT, BAND, GUARD, REJECT
from modquad_gym.tasks import random_cells

GAUGES = (0.0, 0.3, 0.9, 0.999, 1.0, 1.0 + TOL - 1e-6, 1.0 + TOL - 2 * BAND, 1.0 + TOL,
          1.0 + TOL + 2 * BAND, 1.0 + 2e-6, 1.001, 1.5, 30.0)  # fmt: skip
"""Gauges gamma at which test wrenches are placed (the threshold is 1 + TOL)."""


def structure(seed: int, n: int) -> np.ndarray:
    """Configuration matrix of a random connected structure of n modules."""
    key = normalise(random_cells(np.random.default_rng(seed), n))
    return Structure.from_trusted(key).configuration_matrix()


def wrenches_at(z: Zonotope, seed: int, gauges) -> np.ndarray:
    """Wrenches (rows) whose gauge about the hover centre is each of ``gauges`` (in random
    directions of range(A)), by scaling each direction by its exact (HiGHS) gamma."""
    rng = np.random.default_rng(seed)
    D = rng.standard_normal((len(gauges), z.rank))
    gamma = gamma_highs(z, D)
    R = D * (np.asarray(gauges) / gamma)[:, None]
    return z.f_max * (R + z.c) @ z.Q.T


def reference(z: Zonotope, W: np.ndarray) -> np.ndarray:
    return decide_with(z, W, "scipy")


@settings(max_examples=25, deadline=None)
@given(
    seed=st.integers(0, 2**20),
    n=st.integers(1, 7),
    f_max=st.sampled_from([1.0, 0.37, 2.0, 1e-6, 1e6]),
)
def test_compiled_decisions_equal_highs_near_the_boundary(seed, n, f_max):
    z = Zonotope(structure(seed, n), f_max)
    gauges = np.array(GAUGES * 3)
    W = wrenches_at(z, seed, gauges)
    got = decide_with(z, W, "compiled")
    clear = np.abs(gauges - (1.0 + TOL)) > BAND
    np.testing.assert_array_equal(got[clear], reference(z, W)[clear])
    # outside the band the answer is the tolerance rule itself
    np.testing.assert_array_equal(got[clear], gauges[clear] <= 1.0 + TOL)


def test_wrenches_within_guard_are_left_to_the_lp():
    z = Zonotope(structure(3, 5))
    W = wrenches_at(z, 0, [1.0 + TOL] * 8 + [0.5, 2.0])
    R, _ = z.reduce(W)
    v = verdicts(z, R)
    assert (v[:8] == -1).all() and v[8] == 1 and v[9] == 0
    assert ACCEPT == 1.0 + TOL - GUARD and REJECT == 1.0 + TOL + GUARD
    np.testing.assert_array_equal(decide_with(z, W, "compiled"), decide_with(z, W, "daqp"))


@pytest.mark.parametrize(
    "cells",
    [[(0, 0)], [(0, 0), (1, 0), (2, 0)], [(0, 0), (0, 1), (0, 2), (0, 3)],
     [(0, 0), (1, 0), (0, 1), (1, 1)]],
)  # fmt: skip
def test_rank_deficient_off_range_and_huge_wrenches(cells):
    A = Structure(cells).configuration_matrix()
    z = Zonotope(A)
    rng = np.random.default_rng(len(cells))
    n = len(cells)
    W = np.vstack([rng.normal(size=(20, 6)) + [0, 0, 2 * n, 0, 0, 0], [[0, 0, 1e120, 0, 0, 0]],
                   [[1e200, 0, 1e200, 0, 0, 1e200]], [[0, 0, n, 0, 0, 0]],
                   wrenches_at(z, n, GAUGES)])  # fmt: skip
    np.testing.assert_array_equal(decide_with(z, W, "compiled"), reference(z, W))


def test_remembered_directions_keep_answers_across_calls():
    """Directions remembered from one batch are certificates for the next batches."""
    A = structure(11, 6)
    z = Zonotope(A)
    for seed in range(6):
        W = wrenches_at(z, seed, np.linspace(0.2, 3.0, 40))
        np.testing.assert_array_equal(decide_with(z, W, "compiled"), reference(Zonotope(A), W))
    assert z.prepared["compiled"][2][0] > 0  # directions were remembered


@pytest.mark.parametrize("n", [32, 64])
def test_large_structures_near_the_boundary(n):
    """m = 128 and m = 256 rotors: gauges on both sides of the threshold, HiGHS agrees."""
    z = Zonotope(structure(n, n))
    gauges = np.array([0.5, 0.95, 0.999, 1.0 + TOL - 5 * GUARD, 1.0 + TOL + 5 * GUARD, 1.001,
                       1.05, 2.0] * 2)  # fmt: skip
    W = wrenches_at(z, n, gauges)
    got = decide_with(z, W, "compiled")
    np.testing.assert_array_equal(got, gauges <= 1.0 + TOL)
    np.testing.assert_array_equal(got, reference(z, W))


def test_screened_counts_undecided_wrenches_as_fallback():
    A = structure(3, 4)
    oracle = WrenchOracle()
    z = oracle.zonotope(A, "k")
    W = wrenches_at(z, 1, [0.5, 1.0 + TOL, 2.0])
    WD, h = np.zeros((3, 1)), np.zeros(1)
    per_wrench, tested, satisfied = oracle.screened(A, W, WD, h, 0.0, "k")
    on_threshold = int(decide_with(z, W[1:2], "daqp")[0])  # inside the band: the LP's call
    assert (tested, satisfied, oracle.fallback, oracle.calls) == (3, 1 + on_threshold, 1, 3)
    np.testing.assert_array_equal(per_wrench, 0.0)
    _, tested, satisfied = oracle.screened(A, W, WD, h, -1.0, "k")  # the screen rejects all
    assert (tested, satisfied) == (0, 0)
