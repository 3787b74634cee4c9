"""The oracle's methods agree with the HiGHS LP reference, also near the boundary and for
rank-deficient structures; hypothesis checks the zonotope's defining properties."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import modquad_gym as mq
from modquad_gym.oracle import TOL, Zonotope, _gamma

STRUCTURES = {
    "single (rank 4)": [(0, 0)],
    "pair (rank 5)": [(0, 0), (1, 0)],
    "line of 3 (rank 5)": [(0, 0), (0, 1), (0, 2)],
    "L (rank 6)": [(0, 0), (1, 0), (0, 1)],
    "2x2": [(0, 0), (1, 0), (0, 1), (1, 1)],
    "7 modules": [(0, 0), (1, 0), (2, 0), (1, 1), (1, -1), (0, -1), (3, 0)],
}
FAST = ("auto", "daqp", "hrep")
BAND = 1e-5  # documented tolerance band skipped in agreement checks (TOL = 1e-6)


def sample_wrenches(A, rng, t=40, f_max=1.0):
    """Inside, outside, off-range and near-boundary (1 +- 1e-3) wrenches for A."""
    m = A.shape[1]
    c = A.sum(axis=1) * f_max / 2
    inside = (A @ rng.uniform(0, f_max, (t, m)).T).T
    scaled = c + (inside - c) * rng.uniform(0.5, 3.0, (t, 1))
    k = max(1, t // 4)
    noise = inside[:k] + rng.normal(scale=0.05, size=(k, 6))  # mostly off range if rank < 6
    W = np.vstack([inside, scaled, noise, rng.normal(size=(k, 6))])
    z = Zonotope(A, f_max)
    g = _gamma(z, W, "scipy")
    ok = np.isfinite(g) & (g > 1e-3)
    base = W[ok]
    gb = g[ok]
    near = np.vstack(
        [c + (base - c) * ((1 - 1e-3) / gb)[:, None], c + (base - c) * ((1 + 1e-3) / gb)[:, None]]
    )
    return np.vstack([W, near])


@pytest.mark.parametrize("name", list(STRUCTURES))
def test_methods_agree_with_highs(name):
    rng = np.random.default_rng(abs(hash(name)) % 2**32)
    A = mq.Structure(STRUCTURES[name]).configuration_matrix()
    W = sample_wrenches(A, rng)
    z = Zonotope(A)
    g_ref = _gamma(z, W, "scipy")
    d_ref = mq.feasible(A, W, method="scipy")
    clear = ~(np.abs(g_ref - 1) < BAND)
    assert d_ref[clear].sum() > 5 and (~d_ref[clear]).sum() > 5  # both sides are exercised
    for method in FAST:
        d = mq.feasible(A, W, method=method)
        np.testing.assert_array_equal(d[clear], d_ref[clear], err_msg=method)
        m = mq.margin(A, W, method=method)
        fin = np.isfinite(g_ref)
        np.testing.assert_allclose(m[fin], 1 - g_ref[fin], atol=1e-6, err_msg=method)
        assert np.all(np.isneginf(m[~fin]))
    # the decision LP of HiGHS agrees with its own gamma LP
    np.testing.assert_array_equal(d_ref[clear], (g_ref <= 1 + TOL)[clear])


@pytest.mark.parametrize("name", ["single (rank 4)", "pair (rank 5)", "L (rank 6)"])
def test_slow_references_agree(name):
    """cvxpy (the paper's LP) and Algorithm 1 (Quickhull) on small structures."""
    rng = np.random.default_rng(7)
    A = mq.Structure(STRUCTURES[name]).configuration_matrix()
    W = sample_wrenches(A, rng, t=8)
    z = Zonotope(A)
    g_ref = _gamma(z, W, "scipy")
    clear = ~(np.abs(g_ref - 1) < 1e-4)
    for method in ("cvxpy", "quickhull"):
        d = mq.feasible(A, W, method=method)
        np.testing.assert_array_equal(d[clear], (g_ref <= 1)[clear], err_msg=method)


def test_rank_deficient_off_range_is_infeasible():
    A = mq.Structure([(0, 0), (1, 0)]).configuration_matrix()
    z = Zonotope(A)
    assert z.rank == 5
    normal = np.linalg.svd(A)[0][:, 5]  # orthogonal to range(A)
    w = A.sum(axis=1) / 2 + 1e-4 * normal  # the centre, nudged off range
    for method in ("auto", "daqp", "scipy", "hrep", "cvxpy"):
        assert not mq.feasible(A, w, method=method)[0], method
    assert np.isneginf(mq.margin(A, w)[0])


def test_lambda_ratio_matches_decisions():
    rng = np.random.default_rng(3)
    A = mq.Structure(STRUCTURES["2x2"]).configuration_matrix()
    W = sample_wrenches(A, rng, t=12)
    lam = mq.lambda_ratio(A, W)
    g = _gamma(Zonotope(A), W, "scipy")
    clear = (np.abs(lam - 1) > 1e-5) & (np.abs(g - 1) > BAND)
    np.testing.assert_array_equal((lam >= 1)[clear], (g <= 1)[clear])


def test_allocation_is_exact_and_centred():
    rng = np.random.default_rng(4)
    A = mq.Structure(STRUCTURES["2x2"]).configuration_matrix()
    w = A @ rng.uniform(0.2, 0.8, 16)
    u, gamma = mq.allocate(A, w)
    np.testing.assert_allclose(A @ u, w, atol=1e-8)
    assert np.all(u >= 0) and np.all(u <= 1)
    assert np.max(np.abs(u - 0.5)) == pytest.approx(gamma / 2, abs=1e-8)


def test_oracle_cache_and_counts():
    oracle = mq.WrenchOracle()
    s = mq.Structure(STRUCTURES["L (rank 6)"])
    W = sample_wrenches(s.configuration_matrix(), np.random.default_rng(5), t=8)
    a = oracle.feasible(s.configuration_matrix(), W, key=s.key)
    z = oracle.zonotope(s.configuration_matrix(), s.key)
    b = oracle.feasible(s.configuration_matrix(), W, key=s.key)
    assert oracle.zonotope(s.configuration_matrix(), s.key) is z
    np.testing.assert_array_equal(a, b)
    assert oracle.calls == 2 * len(W)


def test_hrep_build_is_chunked_and_complete():
    A = mq.Structure(STRUCTURES["2x2"]).configuration_matrix()
    z1, z2 = Zonotope(A), Zonotope(A)
    N1, h1 = z1.hrep(chunk=64)
    N2, h2 = z2.hrep(chunk=100000)
    assert N1.shape == N2.shape
    np.testing.assert_allclose(h1, h2)


# ------------------------------------------------------------------ hypothesis properties
structure_names = st.sampled_from(list(STRUCTURES))


@settings(max_examples=40, deadline=None)
@given(structure_names, st.integers(0, 2**32 - 1), st.floats(0.2, 5.0))
def test_box_images_are_feasible(name, seed, f_max):
    A = mq.Structure(STRUCTURES[name]).configuration_matrix()
    rng = np.random.default_rng(seed)
    u = rng.uniform(0, f_max, (6, A.shape[1]))
    u[0] = 0.0  # the zero wrench
    u[1] = f_max  # every rotor at full thrust
    u[2] = rng.integers(0, 2, A.shape[1]) * f_max  # a 0/f_max vertex
    W = (A @ u.T).T
    assert mq.feasible(A, W, f_max).all()
    assert (mq.margin(A, W, f_max) >= 0).all()


@settings(max_examples=40, deadline=None)
@given(structure_names, st.integers(0, 2**32 - 1), st.floats(0.0, 1.0))
def test_feasible_set_is_star_shaped_about_zero(name, seed, s):
    A = mq.Structure(STRUCTURES[name]).configuration_matrix()
    rng = np.random.default_rng(seed)
    W = sample_wrenches(A, rng, t=4)
    ok = mq.feasible(A, W)
    assert mq.feasible(A, s * W[ok]).all()


@settings(max_examples=40, deadline=None)
@given(structure_names, st.integers(0, 2**32 - 1))
def test_margin_sign_equals_feasible(name, seed):
    A = mq.Structure(STRUCTURES[name]).configuration_matrix()
    W = sample_wrenches(A, np.random.default_rng(seed), t=4)
    np.testing.assert_array_equal(mq.margin(A, W) >= 0, mq.feasible(A, W, method="daqp"))


# ------------------------------------------------------------------------- bad input
A1 = mq.Structure([(0, 0), (1, 0), (0, 1)]).configuration_matrix()


@pytest.mark.parametrize(
    "A, W, f_max, message",
    [
        (A1, np.zeros((3, 5)), 1.0, r"shape \(t, 6\)"),
        (A1, np.zeros((2, 3, 6)), 1.0, r"shape \(t, 6\)"),
        (A1, np.array([[0, 0, np.nan, 0, 0, 0.0]]), 1.0, "row 0 is not finite"),
        (A1, np.array([[0, 0, 1, 0, 0, 0.0], [np.inf, 0, 0, 0, 0, 0]]), 1.0, "row 1"),
        (A1, np.zeros((1, 6)), 0.0, "f_max"),
        (A1, np.zeros((1, 6)), -1.0, "f_max"),
        (np.zeros((5, 12)), np.zeros((1, 6)), 1.0, "6 x m"),
        (np.full((6, 4), np.nan), np.zeros((1, 6)), 1.0, "non-finite entry"),
    ],
)
def test_bad_input_raises(A, W, f_max, message):
    with pytest.raises(ValueError, match=message):
        mq.feasible(A, W, f_max)
    with pytest.raises(ValueError, match=message):
        mq.margin(A, W, f_max)


def test_unknown_method_and_quickhull_limit():
    with pytest.raises(ValueError, match="unknown method"):
        mq.feasible(A1, np.zeros((1, 6)), method="magic")
    A7 = mq.Structure(STRUCTURES["7 modules"]).configuration_matrix()
    with pytest.raises(ValueError, match="at most 12"):
        mq.feasible(A7, np.zeros((1, 6)), method="quickhull")
