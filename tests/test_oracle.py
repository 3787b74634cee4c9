"""The oracle's methods agree with the HiGHS LP reference, also near the boundary, inside the
tolerance band and for rank-deficient structures; every fast path is cross-checked against
HiGHS; hypothesis checks the zonotope's defining properties."""

import itertools
import zlib

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import modquad_gym as mq
from benchmarks.reference_oracle import cache, register
from benchmarks.reference_oracle.cvxpy_lp import cvxpy_problem, lambda_cvxpy
from benchmarks.reference_oracle.hrep import (
    decide_hrep,
    gamma_hrep,
    hyperplane_shifting,
    zonotope_hrep,
)
from modquad_gym.oracle import (
    BACKENDS,
    BAND,
    METHODS,
    TOL,
    Backend,
    Zonotope,
    decide_from_gamma,
    decide_with,
    gamma_with,
    margin_from_gamma,
    ray_lp,
)
from modquad_gym.oracle.daqp_lp import gamma_daqp
from modquad_gym.oracle.highs_lp import gamma_highs
from modquad_gym.oracle.lp import HIGHS_OPTIONS

register()  # the cross-check methods, as rows of the oracle's table

STRUCTURES = {
    "single (rank 4)": [(0, 0)],
    "pair (rank 5)": [(0, 0), (1, 0)],
    "line of 3 (rank 5)": [(0, 0), (0, 1), (0, 2)],
    "L (rank 6)": [(0, 0), (1, 0), (0, 1)],
    "2x2": [(0, 0), (1, 0), (0, 1), (1, 1)],
    "7 modules": [(0, 0), (1, 0), (2, 0), (1, 1), (1, -1), (0, -1), (3, 0)],
}
FAST = ("auto", "compiled", "certified", "daqp", "hrep")
EVERY = ("auto", "compiled", "certified", "daqp", "scipy", "cvxpy", "hrep")
# wrenches scaled to these multiples of the boundary (gamma = s): the rule says feasible exactly
# when s <= 1 + TOL, margin 0 for s in [1 - TOL, 1 + TOL]
SCALES = (1 - 1.5e-6, 1 - 0.5e-6, 1 + 0.5e-6, 1 + 1.5e-6)


def seed(name: str) -> int:
    """A stable seed per test case (``hash`` of a str changes between runs)."""
    return zlib.crc32(name.encode())


def matrix(name):
    return mq.Structure(STRUCTURES[name]).configuration_matrix()


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
    g = gamma_with(z, W, "scipy")
    ok = np.isfinite(g) & (g > 1e-3)
    base = W[ok]
    gb = g[ok]
    near = np.vstack(
        [c + (base - c) * ((1 - 1e-3) / gb)[:, None], c + (base - c) * ((1 + 1e-3) / gb)[:, None]]
    )
    return np.vstack([W, near])


def scaled_to_boundary(A, rng, scales=SCALES, t=3, f_max=1.0):
    """(W, s): t random directions from the hover wrench, each scaled so that gamma = s (by the
    HiGHS gamma), for every s in ``scales``."""
    m = A.shape[1]
    c = A.sum(axis=1) * f_max / 2
    base = (A @ rng.uniform(0, f_max, (t, m)).T).T
    g = gamma_with(Zonotope(A, f_max), base, "scipy")
    W = np.vstack([c + (base - c) * (s / g)[:, None] for s in scales])
    return W, np.repeat(scales, t)


def boundary_mix(A, rng, t=80):
    """The benchmark's boundary-heavy workload: gamma ~ U(0.5, 1.5)."""
    c = A.sum(axis=1) / 2
    base = (A @ rng.uniform(0, 1, (t, A.shape[1])).T).T
    g = gamma_with(Zonotope(A), base, "scipy")
    return c + (base - c) * (rng.uniform(0.5, 1.5, t) / g)[:, None]


def clear_of_band(g):
    return np.abs(g - (1 + TOL)) > BAND


# ------------------------------------------------------------------ the tolerance rule
def test_rule_helpers():
    g = np.array([0.0, 1 - 2e-6, 1 - TOL, 1.0, 1 + TOL, 1 + 2e-6, np.inf])
    np.testing.assert_array_equal(decide_from_gamma(g), [1, 1, 1, 1, 1, 0, 0])
    m = margin_from_gamma(g)
    np.testing.assert_allclose(m, [1, 2e-6, 0, 0, 0, -2e-6, -np.inf])
    np.testing.assert_array_equal(m >= 0, decide_from_gamma(g))


def test_audit_example_one_module_in_the_band():
    """One module, a wrench at 1 + 1.5e-6 times the boundary: every method says infeasible and
    the margin is -1.5e-6; at 1 + 0.5e-6 every method says feasible with margin 0."""
    A = matrix("single (rank 4)")
    W, s = scaled_to_boundary(A, np.random.default_rng(seed("audit")), scales=(1 + 1.5e-6,))
    W2, _ = scaled_to_boundary(A, np.random.default_rng(seed("audit")), scales=(1 + 0.5e-6,))
    for method in EVERY + ("quickhull",):
        assert not mq.feasible(A, W, method=method).any(), method
        np.testing.assert_allclose(mq.margin(A, W, method=method), -1.5e-6, atol=1e-8)
        assert mq.feasible(A, W2, method=method).all(), method
        np.testing.assert_array_equal(mq.margin(A, W2, method=method), 0.0)
    assert (mq.lambda_ratio(A, W) < 1).all() and (mq.lambda_ratio(A, W2) >= 1).all()


@pytest.mark.parametrize("name", ["single (rank 4)", "pair (rank 5)", "L (rank 6)", "7 modules"])
@pytest.mark.parametrize("method", EVERY)
def test_band_scaled_wrenches(name, method):
    """Every method follows the rule on wrenches scaled into and just outside the tolerance
    band, and its margin sign equals its decision, also on random and off-range wrenches."""
    rng = np.random.default_rng(seed(name + method))
    A = matrix(name)
    t = 2 if method in ("scipy", "cvxpy") else 4
    W, s = scaled_to_boundary(A, rng, t=t)
    d = mq.feasible(A, W, method=method)
    m = mq.margin(A, W, method=method)
    np.testing.assert_array_equal(d, s <= 1 + TOL)
    np.testing.assert_array_equal(m >= 0, d)
    inside_band = np.abs(s - 1) <= TOL
    np.testing.assert_array_equal(m[inside_band], 0.0)
    np.testing.assert_allclose(m[~inside_band], 1 - s[~inside_band], atol=1e-8)
    extra = sample_wrenches(A, rng, t=2 if method in ("scipy", "cvxpy") else 12)
    np.testing.assert_array_equal(
        mq.margin(A, extra, method=method) >= 0, mq.feasible(A, extra, method=method)
    )


@pytest.mark.parametrize("name", ["single (rank 4)", "pair (rank 5)"])
def test_quickhull_follows_the_rule(name):
    A = matrix(name)
    W, s = scaled_to_boundary(A, np.random.default_rng(seed(name)), t=3)
    d = mq.feasible(A, W, method="quickhull")
    np.testing.assert_array_equal(d, s <= 1 + TOL)
    np.testing.assert_array_equal(mq.margin(A, W, method="quickhull") >= 0, d)


@pytest.mark.parametrize("name", ["single (rank 4)", "pair (rank 5)", "2x2"])
def test_lambda_ratio_follows_the_rule(name):
    rng = np.random.default_rng(seed(name))
    A = matrix(name)
    W, s = scaled_to_boundary(A, rng, t=3)
    W = np.vstack([W, sample_wrenches(A, rng, t=4)])
    ok = mq.feasible(A, W)
    lam = mq.lambda_ratio(A, W)
    np.testing.assert_array_equal(lam >= 1, ok)
    np.testing.assert_array_equal(lam[: len(s)] >= 1, s <= 1 + TOL)
    lam_cvx = mq.lambda_ratio(A, W[:6], method="cvxpy")
    np.testing.assert_allclose(lam_cvx, lam[:6], rtol=1e-7)
    np.testing.assert_array_equal(lam_cvx >= 1, ok[:6])


# ------------------------------------------------------------- agreement with HiGHS
@pytest.mark.parametrize("name", list(STRUCTURES))
def test_methods_agree_with_highs(name):
    rng = np.random.default_rng(seed(name))
    A = matrix(name)
    W = sample_wrenches(A, rng)
    z = Zonotope(A)
    g_ref = gamma_with(z, W, "scipy")
    d_ref = mq.feasible(A, W, method="scipy")
    np.testing.assert_array_equal(d_ref, decide_from_gamma(g_ref))
    clear = clear_of_band(g_ref)
    assert d_ref[clear].sum() > 5 and (~d_ref[clear]).sum() > 5  # both sides are exercised
    fin = np.isfinite(g_ref)
    # margins: 1 - gamma, snapped to 0 within TOL of it; exact away from the snapping edges
    edges = np.abs(np.abs(g_ref - 1) - TOL) < 1e-7
    for method in FAST:
        d = mq.feasible(A, W, method=method)
        np.testing.assert_array_equal(d[clear], d_ref[clear], err_msg=method)
        m = mq.margin(A, W, method=method)
        np.testing.assert_array_equal(m >= 0, d, err_msg=method)
        ok = fin & ~edges
        np.testing.assert_allclose(m[ok], margin_from_gamma(g_ref[ok]), atol=1e-8, err_msg=method)
        assert np.all(np.isneginf(m[~fin]))


@pytest.mark.parametrize("n", [7, 10])
@pytest.mark.parametrize("method, kept", [("compiled", "compiled"), ("certified", "directions")])
def test_fast_paths_agree_with_highs_on_the_boundary_workload(n, method, kept):
    """The benchmark's boundary-heavy workload (certificates, simplex or Douglas-Rachford rounds
    and LP fallbacks all used) against HiGHS, for fresh structures and for a reused zonotope
    whose cache of separating directions is filled."""
    from modquad_gym.tasks import random_cells

    def random_structure(n, rng):
        return mq.Structure(random_cells(rng, n))

    rng = np.random.default_rng(seed(f"boundary {n}"))
    for _ in range(2):
        A = random_structure(n, rng).configuration_matrix()
        W = boundary_mix(A, rng)
        g_ref = gamma_with(Zonotope(A), W, "scipy")
        clear = clear_of_band(g_ref)
        z = Zonotope(A)
        first = decide_with(z, W, method)
        np.testing.assert_array_equal(first[clear], decide_from_gamma(g_ref)[clear])
        assert (z.kernel if kept == "compiled" else cache(z).get(kept)) is not None
        again = decide_with(z, W[::-1], method)[::-1]
        np.testing.assert_array_equal(again, first)
        # the LP gamma itself
        np.testing.assert_allclose(gamma_daqp(z, z.reduce(W)[0]), g_ref, atol=1e-9)


@pytest.mark.parametrize("name", ["single (rank 4)", "pair (rank 5)", "L (rank 6)"])
def test_slow_references_agree(name):
    """cvxpy (the paper's LP) and Algorithm 1 (Quickhull) on small structures."""
    rng = np.random.default_rng(7)
    A = matrix(name)
    W = sample_wrenches(A, rng, t=8)
    z = Zonotope(A)
    g_ref = gamma_with(z, W, "scipy")
    clear = np.abs(g_ref - (1 + TOL)) > 1e-6  # quickhull's joggled hull: ~1e-7
    for method in ("cvxpy", "quickhull"):
        d = mq.feasible(A, W, method=method)
        np.testing.assert_array_equal(d[clear], decide_from_gamma(g_ref)[clear], err_msg=method)
    fin = np.isfinite(g_ref)
    np.testing.assert_allclose(gamma_with(z, W, "cvxpy")[fin], g_ref[fin], atol=1e-9)


def test_cvxpy_problem_is_the_papers_lp_compiled_once():
    """max lambda s.t. B u = o + lambda d_hat, 0 <= u <= f_max: DPP, one problem per shape;
    with o = 0 the literal paper LP, lambda* >= |w| exactly when w is in W."""
    prob, par, lam, u = cvxpy_problem((6, 12))
    assert prob.is_dpp()
    assert cvxpy_problem((6, 12))[0] is prob
    A = matrix("L (rank 6)")
    z = Zonotope(A)
    rng = np.random.default_rng(seed("paper lp"))
    W, s = scaled_to_boundary(A, rng, scales=(0.7, 1.3), t=2)
    for w, expect in zip(W, s < 1):
        d = z.Q.T @ w
        lams, us = lambda_cvxpy(z, np.zeros((1, 6)), d[None])
        assert (lams[0] >= np.linalg.norm(w)) == expect == bool(mq.feasible(A, w)[0])
        np.testing.assert_allclose(A @ us[0], lams[0] * w / np.linalg.norm(w), atol=1e-7)


def test_rank_deficient_off_range_is_infeasible():
    A = matrix("pair (rank 5)")
    z = Zonotope(A)
    assert z.rank == 5
    normal = np.linalg.svd(A)[0][:, 5]  # orthogonal to range(A)
    w = A.sum(axis=1) / 2 + 1e-4 * normal  # the centre, nudged off range
    for method in EVERY + ("quickhull",):
        assert not mq.feasible(A, w, method=method)[0], method
        assert np.isneginf(mq.margin(A, w, method=method)[0]), method
    assert mq.lambda_ratio(A, w)[0] == 0.0


def test_allocation_is_exact_and_centred():
    rng = np.random.default_rng(4)
    A = matrix("2x2")
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


# ------------------------------------------------------------------- H-representation
def _facets_brute_force(G):
    """Unit facet normals by an SVD null vector per (r-1)-subset: the slow reference."""
    r, m = G.shape
    out = []
    for S in itertools.combinations(range(m), r - 1):
        U, sv, _ = np.linalg.svd(G[:, S])
        if sv.min() > 1e-9 * np.abs(G).max():
            out.append(U[:, -1])
    return np.array(out)


def test_one_lp_builder_for_allocate_daqp_and_the_ray():
    """allocate solves the same gamma LP as the "scipy" method, and the DAQP method's LP is the
    ray LP (B = G, the cube [-1, 1], from 0): lambda* = |r| / gamma."""
    A = matrix("L (rank 6)")
    z = Zonotope(A)
    W = sample_wrenches(A, np.random.default_rng(seed("one builder")), t=6)
    R = z.reduce(W)[0]
    g_scipy = gamma_with(z, W, "scipy")
    for w, r, g in zip(W, R, g_scipy):
        assert mq.allocate(A, w)[1] == pytest.approx(g, abs=1e-9)
        lam = ray_lp(z.G, np.zeros(z.rank), r, -1.0, 1.0, HIGHS_OPTIONS)
        assert np.linalg.norm(r) / lam == pytest.approx(gamma_daqp(z, r[None])[0], abs=1e-8)


def test_backend_table_is_the_only_dispatch(monkeypatch):
    """METHODS are the table's names; a backend added as one row (here gamma from the
    brute-force facets) serves feasible and margin and agrees with HiGHS."""
    assert set(METHODS) <= set(BACKENDS) and METHODS[0] == "auto"

    def gamma_brute(z, R):
        N = _facets_brute_force(z.G)
        return (np.abs(R @ N.T) / np.abs(N @ z.G).sum(axis=1)).max(axis=1)

    monkeypatch.setitem(BACKENDS, "brute", Backend(gamma_brute))
    A = matrix("L (rank 6)")
    W = sample_wrenches(A, np.random.default_rng(seed("brute backend")), t=8)
    g_ref = gamma_with(Zonotope(A), W, "scipy")
    clear = clear_of_band(g_ref)
    d = mq.feasible(A, W, method="brute")
    np.testing.assert_array_equal(d[clear], decide_from_gamma(g_ref)[clear])
    np.testing.assert_allclose(mq.margin(A, W, method="brute"), margin_from_gamma(g_ref), atol=1e-9)


@pytest.mark.parametrize("name", ["single (rank 4)", "pair (rank 5)", "line of 3 (rank 5)", "2x2"])
def test_hrep_matches_brute_force(name):
    z = Zonotope(matrix(name))
    N, h = zonotope_hrep(z)
    np.testing.assert_allclose(np.linalg.norm(N, axis=1), 1.0)
    np.testing.assert_allclose(h, np.abs(N @ z.G).sum(axis=1))
    ref = _facets_brute_force(z.G)
    # every brute-force facet is in the H-representation (up to sign), and nothing else
    cos = np.abs(ref @ N.T).max(axis=1)
    np.testing.assert_allclose(cos, 1.0, atol=1e-9)
    assert np.abs(N @ ref.T).max(axis=1).min() > 1 - 1e-9
    # and no direction twice
    assert (np.abs(N @ N.T) - np.eye(len(N))).max() < 1 - 1e-9


def test_hrep_build_is_chunked_and_complete():
    z = Zonotope(matrix("7 modules"))
    N1, h1 = hyperplane_shifting(z.G, chunk=1000)
    N2, h2 = hyperplane_shifting(z.G, chunk=1 << 20)
    assert N1.shape == N2.shape

    def canon(N):
        return N[np.lexsort(np.round(N, 8).T)]

    np.testing.assert_allclose(canon(N1), canon(N2), atol=1e-8)
    rng = np.random.default_rng(seed("hrep chunks"))
    R = rng.normal(size=(200, z.rank))
    np.testing.assert_allclose((np.abs(R @ N1.T) / h1).max(1), (np.abs(R @ N2.T) / h2).max(1))


def test_hrep_gamma_matches_highs_at_m28():
    A = matrix("7 modules")
    W = sample_wrenches(A, np.random.default_rng(seed("hrep m28")), t=10)
    z = Zonotope(A)
    R, off = z.reduce(W)
    np.testing.assert_allclose(gamma_hrep(z, R[~off]), gamma_highs(z, R[~off]), atol=1e-9)


def test_hrep_support_rejection_skips_the_build():
    """Wrenches far outside are rejected by the support function alone: no H-representation is
    built; a batch with feasible wrenches builds it and still agrees with HiGHS."""
    A = matrix("7 modules")
    c = A.sum(axis=1) / 2
    rng = np.random.default_rng(seed("support"))
    far = c + 5.0 * (A @ rng.uniform(0, 1, (10, 28)).T).T - 5.0 * c
    far[:, 2] = -1.0  # pulling down: no rotor can
    z = Zonotope(A)
    R, off = z.reduce(far)
    assert not decide_hrep(z, R).any()
    assert "hrep" not in cache(z)
    W = sample_wrenches(A, rng, t=6)
    np.testing.assert_array_equal(
        mq.feasible(A, W, method="hrep")[clear_of_band(gamma_with(z, W, "scipy"))],
        mq.feasible(A, W, method="scipy")[clear_of_band(gamma_with(z, W, "scipy"))],
    )


# ------------------------------------------------------------------ hypothesis properties
structure_names = st.sampled_from(list(STRUCTURES))


@settings(max_examples=40, deadline=None)
@given(structure_names, st.integers(0, 2**32 - 1), st.floats(0.2, 5.0))
def test_box_images_are_feasible(name, seed_, f_max):
    A = matrix(name)
    rng = np.random.default_rng(seed_)
    u = rng.uniform(0, f_max, (6, A.shape[1]))
    u[0] = 0.0  # the zero wrench
    u[1] = f_max  # every rotor at full thrust
    u[2] = rng.integers(0, 2, A.shape[1]) * f_max  # a 0/f_max vertex
    W = (A @ u.T).T
    assert mq.feasible(A, W, f_max).all()
    assert (mq.margin(A, W, f_max) >= 0).all()


@settings(max_examples=40, deadline=None)
@given(structure_names, st.integers(0, 2**32 - 1), st.floats(0.0, 1.0))
def test_feasible_set_is_star_shaped_about_zero(name, seed_, s):
    A = matrix(name)
    rng = np.random.default_rng(seed_)
    W = sample_wrenches(A, rng, t=4)
    ok = mq.feasible(A, W)
    assert mq.feasible(A, s * W[ok]).all()


@settings(max_examples=40, deadline=None)
@given(structure_names, st.integers(0, 2**32 - 1), st.sampled_from(FAST))
def test_margin_sign_equals_feasible(name, seed_, method):
    A = matrix(name)
    rng = np.random.default_rng(seed_)
    W = np.vstack([sample_wrenches(A, rng, t=4), scaled_to_boundary(A, rng, t=1)[0]])
    np.testing.assert_array_equal(
        mq.margin(A, W, method=method) >= 0, mq.feasible(A, W, method=method)
    )


# ------------------------------------------------------------------------- bad input
A1 = mq.Structure([(0, 0), (1, 0), (0, 1)]).configuration_matrix()


@pytest.mark.parametrize(
    "A, W, f_max, message",
    [
        (A1, np.zeros((3, 5)), 1.0, r"shape \(t, 6\)"),
        (A1, np.zeros((2, 3, 6)), 1.0, r"shape \(t, 6\)"),
        (A1, np.array([[0, 0, np.nan, 0, 0, 0.0]]), 1.0, "row 1 is not finite"),
        (A1, np.array([[0, 0, 1, 0, 0, 0.0], [np.inf, 0, 0, 0, 0, 0]]), 1.0, "row 2"),
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
    with pytest.raises(ValueError, match=message):
        mq.lambda_ratio(A, W, f_max)


def test_unknown_method_and_quickhull_limit():
    with pytest.raises(ValueError, match="unknown method"):
        mq.feasible(A1, np.zeros((1, 6)), method="magic")
    with pytest.raises(ValueError, match="lambda_ratio supports"):
        mq.lambda_ratio(A1, np.zeros((1, 6)), method="hrep")
    A7 = matrix("7 modules")
    with pytest.raises(ValueError, match="at most 12"):
        mq.feasible(A7, np.zeros((1, 6)), method="quickhull")
