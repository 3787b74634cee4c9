"""The oracle on numerically hard but valid inputs: the all-zero matrix, an LP that fails
(HiGHS reports no optimum), an ill-conditioned matrix."""

import numpy as np
import pytest

from modquad_gym.geometry.structure import Structure
from modquad_gym.oracle import (
    BAND,
    METHODS,
    TOL,
    WrenchOracle,
    Zonotope,
    allocate,
    daqp_lp,
    decide_from_gamma,
    feasible,
    gamma_with,
    kernels,
    lambda_ratio,
    margin,
)
from modquad_gym.oracle.daqp_lp import gamma_daqp
from modquad_gym.oracle.lp import GammaLP


def conditioned(cond: float) -> tuple[np.ndarray, np.ndarray]:
    """(A, w): a full-rank 6 x 8 matrix with singular values (1, 1, 1, 1, 1, 1 / cond) and a
    wrench A u with every rotor u_j in [0.25, 0.75] (feasible, gamma about 0.37) that leans on
    the weak direction."""
    rng = np.random.default_rng(6)
    U, _ = np.linalg.qr(rng.normal(size=(6, 6)))
    V, _ = np.linalg.qr(rng.normal(size=(8, 6)))
    A = (U * np.array([1, 1, 1, 1, 1, 1 / cond])) @ V.T
    u = 0.5 + 0.25 * V[:, 5] / np.abs(V[:, 5]).max()
    return A, A @ u


@pytest.mark.parametrize("method", METHODS)
def test_all_zero_matrix_reaches_only_the_zero_wrench(method):
    """Rank 0: the zero wrench (within the off-range rule) is the centre, margin 1; any other
    is off range, margin -inf; no numpy error from an empty reduction."""
    A = np.zeros((6, 4))
    W = np.array([[0.0] * 6, [1e-10, 0, 0, 0, 0, 0], [1.0, 0, 0, 0, 0, 0]])
    assert feasible(A, W, method=method).tolist() == [True, True, False]
    assert margin(A, W, method=method).tolist() == [1.0, 1.0, -np.inf]
    if method == "scipy":
        assert lambda_ratio(A, W, method=method).tolist() == [np.inf, np.inf, 0.0]
        u, gamma = allocate(A, W[0])
        assert gamma == 0.0 and np.allclose(u, 0.5)


def _failed(self, r):
    """What HiGHS returns when it reports no optimum (status 2: infeasible)."""
    return type("Result", (), {"status": 2, "message": "forced failure", "x": None})()


def test_highs_failure_falls_back_to_the_walk(monkeypatch):
    """The gamma LP is always feasible and bounded, so a HiGHS failure is numerical: the
    scipy method then takes the compiled walk's gamma; allocate, which needs HiGHS's
    allocation, raises a one-line ValueError naming the matrix's condition number."""
    A, w = conditioned(10.0)
    want = gamma_with(Zonotope(A), w[None], "compiled")
    monkeypatch.setattr(GammaLP, "solve", _failed)
    got = gamma_with(Zonotope(A), w[None], "scipy")
    np.testing.assert_allclose(got, want, rtol=1e-12)
    with pytest.raises(ValueError, match=r"^A: .*forced failure.*condition number is 10\b") as e:
        allocate(A, w)
    assert "\n" not in str(e.value)


def test_highs_and_walk_failing_is_a_value_error(monkeypatch):
    """Where the walk gives up too (nan), a one-line ValueError naming the condition number,
    not a RuntimeError traceback."""
    A, w = conditioned(10.0)
    monkeypatch.setattr(GammaLP, "solve", _failed)
    monkeypatch.setattr(kernels, "gamma_rows", lambda G, P, prep, R, cap, out, dirs: None)
    with pytest.raises(ValueError, match=r"^A: .*gave up.*condition number is 10\b") as e:
        margin(A, w, method="scipy")
    assert "\n" not in str(e.value)


@pytest.mark.parametrize("method", METHODS)
def test_ill_conditioned_matrix_has_an_answer(method):
    """Condition 5e8 (full rank by the rank rule): HiGHS used to report 'infeasible' on the
    gamma LP (a RuntimeError); every method now answers, feasible, and the gammas agree with
    the compiled walk's."""
    A, w = conditioned(5e8)
    walk = gamma_with(Zonotope(A), w[None], "compiled")[0]
    assert feasible(A, w, method=method).tolist() == [True]
    np.testing.assert_allclose(1.0 - margin(A, w, method=method), walk, atol=1e-6)


@pytest.mark.parametrize("cond", [1e7, 1e8])
def test_lp_gammas_are_accurate_on_an_ill_conditioned_matrix(cond):
    """HiGHS and DAQP meet ``G x = r`` to an absolute tolerance, and the correction onto it
    divides by the smallest singular value: on ``G x = r`` itself the LP methods' gammas were
    5-25 % high at condition 1e7-1e8 (allocate's too). On the equilibrated rows
    ``V x = r / sigma`` they agree with the compiled walk's to round-off."""
    A, w = conditioned(cond)
    walk = gamma_with(Zonotope(A), w[None], "compiled")[0]
    for method in ("auto", "daqp", "scipy"):
        np.testing.assert_allclose(1.0 - margin(A, w, method=method), [walk], atol=1e-8)
    u, gamma = allocate(A, w)
    assert abs(gamma - walk) <= 1e-8
    np.testing.assert_allclose(A @ u, w, atol=1e-9)


def known_gammas(A: np.ndarray, rng, n: int) -> tuple[np.ndarray, np.ndarray]:
    """(W, s): wrenches of known gamma s (f_max 1): boundary points A u* (u* the bang-bang
    maximiser of y . A u: gamma exactly 1; y rounded to integers for every third, to hit the
    lattice's degenerate facets and edges) scaled about the centre by s, for n directions y."""
    c = A.sum(axis=1) / 2.0
    W, s_ = [], []
    for k in range(n):
        y = rng.normal(size=6)
        y = np.round(y) if k % 3 == 0 else y
        w = A @ np.where(A.T @ y > 0, 1.0, 0.0)
        for s in (1.0, 1.0 + TOL - 2 * BAND, 1.0 + TOL + 2 * BAND, 0.3, 1.5):
            W.append(c + s * (w - c))
            s_.append(s)
    return np.array(W), np.array(s_)


LATTICE = [(i, j) for i in range(8) for j in range(8)]
"""64 t45 modules, 8 x 8: the largest stock lattice the tests use."""


@pytest.mark.slow
@pytest.mark.parametrize("method", ("auto", "daqp"))
def test_stock_lattice_known_gammas_are_decided_right(method):
    """500 wrenches of known gamma on the 64-module lattice, 200 of them 2 BAND from the
    threshold: every decision follows the rule. On ``G x = r`` DAQP's gamma of a wrench at
    1 + TOL - 2 BAND was 3.7e-7 high, and auto (whose walk gave up on it) rejected it."""
    A = Structure(LATTICE).configuration_matrix()
    W, s = known_gammas(A, np.random.default_rng(3), 100)
    assert np.array_equal(feasible(A, W, method=method), s <= 1.0 + TOL)


@pytest.mark.parametrize("s", [1e-12, 2.0**-39, 1e-6, 1e12])  # f_max = 1 / s <= 1e12
@pytest.mark.parametrize("cells", [[(0, 0), (0, 1), (1, 0), (1, 1)], [(0, 0), (0, 1), (0, 2)]])
def test_scaled_matrix_is_the_same_wrench_set(cells, s):
    """(A s, f_max / s) has the wrench set of (A, f_max): the same rank, decisions, margins and
    lambda ratios for every method (2 x 2: rank 6; a line: rank 5, wrenches in its range, as
    the off-range rule is relative to f_max). The rank rule had a floor of 1 on A's scale
    (A4 * 1e-12 was rank 0 and every small wrench feasible), and the LPs and the walk had
    thresholds calibrated for A of order one (A4 * 1e-6 misjudged 6 of 50 wrenches)."""
    A = Structure(cells).configuration_matrix()
    rng = np.random.default_rng(len(cells))
    W = rng.uniform(-0.4, 1.4, size=(40, A.shape[1])) @ A.T
    W = np.vstack([W, 2.0 * A.sum(axis=1), np.zeros(6)])  # gamma 3; the zero wrench
    assert Zonotope(A * s, 1.0 / s).rank == Zonotope(A).rank
    for method in METHODS:
        assert np.array_equal(feasible(A * s, W, 1.0 / s, method), feasible(A, W, 1.0, method))
        np.testing.assert_allclose(
            margin(A * s, W, 1.0 / s, method), margin(A, W, 1.0, method), atol=1e-8
        )
    np.testing.assert_allclose(lambda_ratio(A * s, W, 1.0 / s), lambda_ratio(A, W), rtol=1e-9)
    screen = (np.zeros((len(W), 1)), np.zeros(1), 0.0)  # nothing screened out
    got = WrenchOracle(1.0 / s).screened(A * s, W, *screen)
    assert got[1:] == WrenchOracle().screened(A, W, *screen)[1:]
    assert got[2] == np.count_nonzero(feasible(A, W))


def test_daqp_gammas_just_above_the_threshold_are_rechecked(monkeypatch):
    """DAQP's gammas are upper bounds that its proximal iterations leave up to ~1e-7 high: one
    within RECHECK above 1 + TOL is recomputed by HiGHS, so such an error never rejects a
    feasible wrench; gammas further above are DAQP's own."""
    A = Structure([(0, 0), (0, 1), (1, 0), (1, 1)]).configuration_matrix()
    rng = np.random.default_rng(5)
    W, s = known_gammas(A, rng, 4)
    z = Zonotope(A)
    exact = gamma_with(z, W, "scipy")
    off = 5e-7  # a DAQP error 5 BAND high
    high = iter(exact + off)
    monkeypatch.setattr(daqp_lp, "gamma_and_direction", lambda z, r: (next(high), None))
    got = gamma_daqp(z, z.reduce(W)[0])
    recheck = (exact + off > 1.0 + TOL) & (exact + off <= 1.0 + 2.0 * TOL)  # RECHECK = TOL
    assert recheck.any() and (~recheck).any()
    np.testing.assert_allclose(got[recheck], exact[recheck], atol=1e-12)
    np.testing.assert_array_equal(got[~recheck], exact[~recheck] + off)
    assert np.array_equal(decide_from_gamma(got), s <= 1.0 + TOL)


@pytest.mark.slow
def test_stock_lattice_gammas_have_the_documented_accuracy():
    """The accuracy modquad_gym.oracle.tolerance states for stock structures, on the 64-module
    lattice's known-gamma wrenches (with 2x headroom for other CPUs' round-off): HiGHS within
    5e-11, the compiled walk within 2e-13 where it reaches the optimum (on all but at most 1 of
    1200 wrenches: here 2 of 500), DAQP an upper bound (never low by more than 3e-15) up to
    1.3e-7 high."""
    from benchmarks.oracle_accuracy import walk_gammas

    A = Structure(LATTICE).configuration_matrix()
    W, s = known_gammas(A, np.random.default_rng(3), 100)
    z = Zonotope(A)
    assert np.abs(gamma_with(z, W, "scipy") - s).max() <= 1e-10
    walk = walk_gammas(z, W)
    assert np.abs(walk - s)[np.isfinite(walk)].max() <= 4e-13
    assert np.count_nonzero(np.isnan(walk)) <= 2
    daqp = gamma_with(z, W, "daqp") - s
    assert -6e-15 <= daqp.min() and daqp.max() <= 2.6e-7
