"""Fault tolerance (issue 37): ``mq.tolerates`` and ``mq.fault_margin`` against a plain LP per
failure, on random structures to 8 modules, wrenches near the boundary, rank-deficient cases."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import modquad_gym as mq
from modquad_gym.geometry.polyominoes import PolyominoStream
from modquad_gym.oracle.faults import FaultTolerance, failure_sets

SETTINGS = settings(
    max_examples=10, deadline=None, suppress_health_check=[HealthCheck.too_slow], derandomize=True
)


def reference(structure: mq.Structure, W: np.ndarray, f_max: float, fault: str):
    """(tolerated (t,), worst margin (t,)): every failure's matrix decided by HiGHS alone."""
    A = structure.configuration_matrix()
    ok = np.ones(len(W), dtype=bool)
    worst = np.full(len(W), np.inf)
    for S in failure_sets(A.shape[1], fault):
        rest = np.delete(A, S, axis=1)
        if rest.shape[1] == 0:
            zero = np.linalg.norm(W, axis=1) == 0
            ok &= zero
            worst = np.minimum(worst, np.where(zero, 0.0, -np.inf))
            continue
        margin = mq.margin(rest, W, f_max, method="scipy")  # >= 0 exactly when feasible
        ok &= margin >= 0
        worst = np.minimum(worst, margin)
    return ok, worst


def shapes(n: int) -> list:
    return [tuple(map(tuple, c)) for chunk in PolyominoStream(n, 1 << 12) for c in chunk.tolist()]


@st.composite
def cases(draw):
    n = draw(st.integers(1, 8))
    pool = shapes(n) if n <= 6 else shapes(n)[:: 97 if n == 7 else 499]
    cells = draw(st.sampled_from(pool))
    s = mq.Structure(cells)
    m = 4 * n
    seed = draw(st.integers(0, 2**31 - 1))
    rng = np.random.default_rng(seed)
    # allocations at vertices, on faces and inside, scaled around the boundary of W
    U = rng.uniform(0, 1, (8, m))
    U[:4] = rng.integers(0, 2, (4, m))
    U[4:6, rng.integers(0, m)] = 0.0
    scale = rng.choice([0.3, 0.8, 0.97, 0.999, 1.0, 1.001, 1.03], size=(8, 1))
    W = (U @ s.configuration_matrix().T) * scale
    f_max = float(draw(st.sampled_from([1.0, 2.5])))
    return s, W * f_max, f_max


@SETTINGS
@given(case=cases(), fault=st.sampled_from(["rotor", "module"]))
def test_tolerates_agrees_with_an_lp_per_failure(case, fault):
    s, W, f_max = case
    ref_ok, ref_margin = reference(s, W, f_max, fault)
    clear = np.abs(ref_margin) > 1e-6  # outside the oracle's agreement band
    ok = mq.tolerates(s, W, f_max, fault=fault)
    assert np.array_equal(ok[clear], ref_ok[clear])
    margin = mq.fault_margin(s, W, f_max, fault=fault)
    assert np.array_equal(margin >= 0, ok)
    finite = clear & np.isfinite(ref_margin)
    assert np.allclose(margin[finite], ref_margin[finite], atol=1e-6)


@pytest.mark.parametrize(
    "cells", [[(0, 0)], [(0, 0), (1, 0)], [(0, 0), (1, 0), (2, 0), (3, 0)], [(0, 0), (0, 1)]]
)
@pytest.mark.parametrize("fault", ["rotor", "module"])
def test_rank_deficient_structures(cells, fault):
    """A single module (rank 4) and lines (rank 5) lose rank when a rotor fails: every failure
    is decided on the failed matrix itself, and agrees with the LP."""
    s = mq.Structure(cells)
    A = s.configuration_matrix()
    rng = np.random.default_rng(len(cells))
    W = (rng.uniform(0, 1, (12, A.shape[1])) @ A.T) * rng.uniform(0.2, 1.0, (12, 1))
    ok = mq.tolerates(s, W, fault=fault)
    ref_ok, ref_margin = reference(s, W, 1.0, fault)
    clear = np.abs(ref_margin) > 1e-6
    assert np.array_equal(ok[clear], ref_ok[clear])


def test_hover_of_a_square_tolerates_a_rotor_not_a_single_module():
    square = mq.Structure([(0, 0), (1, 0), (0, 1), (1, 1)])
    hover = np.array([[0, 0, 4.0, 0, 0, 0]])
    assert mq.feasible(square.configuration_matrix(), hover).all()
    assert mq.tolerates(square, hover, fault="rotor").all()
    one = mq.Structure([(0, 0)])
    light = np.array([[0, 0, 0.5, 0, 0, 0]])
    assert mq.feasible(one.configuration_matrix(), light).all()
    assert not mq.tolerates(one, light, fault="rotor").any()  # rank drops, the torque is lost
    assert not mq.tolerates(one, light, fault="module").any()  # nothing is left
    assert mq.tolerates(one, np.zeros((1, 6)), fault="module").all()


def test_most_pairs_are_settled_by_the_shared_certificate():
    """The certificate decides most (wrench, failure) pairs without an LP on the failed matrix,
    and every tolerated wrench is feasible for the intact structure."""
    s = mq.Structure([(0, 0), (1, 0), (0, 1), (1, 1), (2, 0), (2, 1), (0, 2)])
    A = s.configuration_matrix()
    rng = np.random.default_rng(0)
    W = (rng.uniform(0, 1, (300, 28)) @ A.T) * rng.uniform(0.3, 1.0, (300, 1))
    ft = FaultTolerance(A, 1.0, failure_sets(28, "rotor"))
    ok = ft.decide(W)
    assert ft.certified >= 0.9 * 300 * 28
    assert ft.tests < 0.05 * 300 * 28
    assert not (ok & ~mq.feasible(A, W)).any()


@pytest.mark.parametrize(
    "bad, match",
    [
        (dict(fault="wing"), "fault must be one of"),
        (dict(f_max=0.0), "f_max"),
        (dict(W=np.ones((2, 5))), "6"),
        (dict(W=np.array([[np.nan, 0, 1, 0, 0, 0]])), "finite"),
    ],
)
def test_bad_arguments_are_one_clear_error(bad, match):
    args = dict(structure=mq.Structure([(0, 0), (1, 0)]), W=np.zeros((1, 6)), f_max=1.0)
    args.update(bad)
    with pytest.raises(ValueError, match=match):
        mq.tolerates(**args)
