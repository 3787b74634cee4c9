"""The whitened zonotope (:mod:`modquad_gym.oracle.whitened`, the exact lookahead's children)
against the SVD's: the same gammas up to round-off from the compiled walk, cold and warm, and
from the DAQP fallback, on both sides of the threshold and past the clip; the matrices it
declines; and the oracle's cache, where the full zonotope replaces it when one is asked for."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from test_oracle_compiled import GAUGES, structure, wrenches_at

from modquad_gym.geometry.structure import Structure
from modquad_gym.oracle import TOL, WrenchOracle, Zonotope
from modquad_gym.oracle.backends import gamma_capped_from
from modquad_gym.oracle.daqp_lp import gamma_daqp
from modquad_gym.oracle.tolerance import BAND
from modquad_gym.oracle.whitened import MIN_COLUMNS, WhitenedZonotope, whitened

CAP = 2.0  # the exact lookahead's clip


@settings(max_examples=20, deadline=None)
@given(
    seed=st.integers(0, 2**20),
    n=st.sampled_from([16, 17, 24, 40, 64]),
    f_max=st.sampled_from([1.0, 0.37, 40.0]),
)
def test_whitened_gammas_equal_the_svd_zonotopes(seed, n, f_max):
    """Cold walks, warm walks from the SVD zonotope's own optimal vertices (the columns and
    bounds do not depend on the coordinates), rows at the threshold's band and past the clip:
    gamma within 1e-10 relative; a row proved past the clip on one is proved on the other."""
    A = structure(seed, n) * f_max
    z, w = Zonotope(A, f_max), whitened(A, f_max)
    assert isinstance(w, WhitenedZonotope)
    gauges = (*GAUGES, 1.0 + TOL - BAND / 2, 1.0 + TOL + BAND / 2, 1.9, 2.0 - 1e-12, 2.5)
    W = wrenches_at(z, seed, gauges)
    svd, (tights, signs) = gamma_capped_from(z, W, CAP)
    for start in (None, (tights, signs)):
        got, _ = gamma_capped_from(w, W, CAP, start)
        inside = svd <= CAP
        np.testing.assert_allclose(got[inside], svd[inside], rtol=1e-10, atol=1e-12)
        assert (got[~inside] > CAP * (1 - 1e-12)).all()
    some = slice(0, 6)  # the fallback of a row the walk gives up on: DAQP, as accurate here
    daqp = gamma_daqp(w, w.reduce(W)[0][some])  # (the SVD's coordinates are less well scaled)
    np.testing.assert_allclose(daqp, np.array(gauges[some]), rtol=0, atol=1e-7)


@pytest.mark.parametrize(
    "why, make",
    [
        ("fewer columns than MIN_COLUMNS", lambda: structure(3, MIN_COLUMNS // 4 - 1)),
        ("a straight line (rank 5)", lambda: Structure([(i, 0) for i in range(20)])),
        (
            "ill-conditioned rows",
            lambda: structure(5, 20) * np.array([[1], [1], [1e-7], [1], [1], [1]]),
        ),  # fmt: skip
    ],
)
def test_what_it_declines_goes_to_the_svd(why, make):
    made = make()
    A = made if isinstance(made, np.ndarray) else made.configuration_matrix()
    assert whitened(A) is None, why
    oracle = WrenchOracle()
    assert type(oracle.gamma_zonotope(A, key="k")) is Zonotope


def test_the_full_zonotope_replaces_the_cached_whitened_one():
    """gamma_zonotope caches the whitened one under the key (cached() returns it, with its
    matrix, for the walks); zonotope() under that key returns a full Zonotope and keeps it."""
    A = structure(7, 20)
    oracle = WrenchOracle(cache_size=4)
    walked = oracle.gamma_zonotope(A, key="s")
    assert isinstance(walked, WhitenedZonotope) and oracle.cached("s") is walked
    assert oracle.cached("s").A is A
    full = oracle.zonotope(A, key="s")
    assert type(full) is Zonotope and oracle.cached("s") is full
    assert oracle.gamma_zonotope(A, key="s") is full  # the full one serves the walks too
    for k in range(5):  # the cache stays bounded
        oracle.gamma_zonotope(structure(k, 17), key=k)
    assert oracle.cached("s") is None and len(oracle._cache) == 4
