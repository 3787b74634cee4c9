"""The oracle against a reference that shares no code with it: HiGHS (``scipy.optimize.linprog``)
on the raw A, ``gamma = min t s.t. A u = w, |u - f_max/2| <= t f_max/2`` (an infeasible LP: w
off the range of A, gamma inf), with no SVD, no reduced coordinates and no rank rule. The
product's own tests compare its fast paths with its ``"scipy"`` method, which shares
``Zonotope.reduce`` with them; this one does not.

Every method's decisions and margins (:data:`~modquad_gym.METHODS`), and the whitened path of the
exact lookahead (:mod:`modquad_gym.oracle.whitened`), on rank-deficient matrices (rank 1 to 5,
zero and duplicated columns), ill-conditioned and scaled ones, at wrenches of known gauge about
the boundary (1 +- 1e-9 .. 1e-3 and just outside the tolerance band) and off the range. Decisions
must agree wherever the reference's gamma lies outside the documented band
(:data:`~modquad_gym.oracle.tolerance.BAND` about ``1 + TOL``), gammas within ``BAND``.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.optimize import linprog

import modquad_gym as mq
from modquad_gym.oracle.backends import gamma_capped_from
from modquad_gym.oracle.tolerance import BAND, RESIDUAL_TOL, TOL
from modquad_gym.oracle.whitened import MAX_CONDITION, MIN_COLUMNS, whitened

HIGHS = {"primal_feasibility_tolerance": 1e-10, "dual_feasibility_tolerance": 1e-10}
THRESHOLD = 1.0 + TOL
GAUGES = (1e-3, 1e-5, 1e-7, 1e-9, 0.0, -1e-9, -1e-7, -1e-5, -1e-3, TOL + 2 * BAND, TOL - 2 * BAND)
"""Offsets from 1 of the gauges of the boundary wrenches (the last two: just outside the band)."""
CAP = 2.0  # the exact lookahead's clip (its margins are clipped to [-1, 1])


def gamma_reference(A: np.ndarray, w: np.ndarray, f_max: float) -> float:
    """HiGHS on A itself: u = f_max/2 (1 + x), min t s.t. A u = w, |x| <= t; rows scaled by
    max|A| f_max only (so that HiGHS's absolute tolerances mean the same at any scale)."""
    m = A.shape[1]
    scale = max(float(np.abs(A).max()) * f_max, 1e-300)
    G = A * (f_max / 2) / scale
    r = (w - A.sum(axis=1) * f_max / 2) / scale
    eye, ones = np.eye(m), -np.ones((m, 1))
    res = linprog(
        np.r_[np.zeros(m), 1.0],
        A_ub=np.block([[eye, ones], [-eye, ones]]),
        b_ub=np.zeros(2 * m),
        A_eq=np.hstack([G, np.zeros((6, 1))]),
        b_eq=r,
        bounds=[(None, None)] * m + [(0, None)],
        method="highs",
        options=HIGHS,
    )
    if res.status == 2:
        return np.inf
    assert res.status == 0, res.message
    return float(res.fun)


def _random(rng, rank: int, m: int, condition: float = 1.0) -> np.ndarray:
    """A (6, m) matrix of ``rank`` with singular values from 1 down to 1 / condition."""
    U, _ = np.linalg.qr(rng.standard_normal((6, rank)))
    V, _ = np.linalg.qr(rng.standard_normal((m, rank)))
    return U @ np.diag(np.logspace(0, -np.log10(condition), rank)) @ V.T


def _matrices():
    rng = np.random.default_rng(1)

    def stock(*cells, module=None):
        return mq.Structure(list(cells), module=module).configuration_matrix()

    one, pair = stock((0, 0)), stock((0, 0), (1, 0))
    column = rng.standard_normal((6, 1))
    return {
        "rank 1 (four equal columns)": (np.hstack([column] * 4), 1.0),
        "rank 2": (_random(rng, 2, 7), 1.0),
        "rank 3": (_random(rng, 3, 9), 1.0),
        "rank 4 (one module)": (one, 1.0),
        "rank 5 (a line of three)": (stock((0, 0), (1, 0), (2, 0)), 1.0),
        "rank 4, vertical rotors": (stock((0, 0), (1, 0), module=mq.TModule(eta=0.0)), 1.0),
        "zero columns": (np.hstack([one, np.zeros((6, 3))]), 1.0),
        "duplicated columns": (np.hstack([one, one]), 1.0),
        "L, f_max 1e6": (stock((0, 0), (1, 0), (0, 1)), 1e6),
        "2x2, f_max 1e-6": (stock((0, 0), (1, 0), (0, 1), (1, 1)), 1e-6),
        "condition 1e3": (_random(rng, 6, 10, 1e3), 1.0),
        "condition 1e6": (_random(rng, 6, 10, 1e6), 1.0),
        "1e8 A, f_max 1e-8": (pair * 1e8, 1e-8),
        "1e-8 A": (pair * 1e-8, 1.0),
    }


MATRICES = _matrices()


def _boundary_wrenches(A, f_max, rng, directions=None) -> np.ndarray:
    """Wrenches of gauge 1 + offset (GAUGES) about the centre: support points A u, u_j = f_max
    where d . A_j > 0, scaled about hover at half thrust; plus the centre and zero."""
    c = A.sum(axis=1) * f_max / 2
    ds = list(rng.standard_normal((3, 6))) if directions is None else directions
    W = [c, np.zeros(6)]
    for d in ds:
        v = A @ np.where(d @ A > 0, f_max, 0.0)
        W += [c + (1 + g) * (v - c) for g in GAUGES]
    return np.array(W)


def _off_range(A, f_max, W, rng) -> np.ndarray:
    """W moved off the range of A by 1e3 times the off-range rule's residual, measured in
    units of the larger of f_max and the matrix's own wrench scale max|A| f_max (which the
    reference resolves); none for a full-rank A."""
    null = np.linalg.svd(A)[0][:, np.linalg.matrix_rank(A) :]  # numpy's rank, not the oracle's
    if null.shape[1] == 0:
        return np.zeros((0, 6))
    n = null @ rng.standard_normal(null.shape[1])
    n /= np.linalg.norm(n)
    sizes = f_max * max(1.0, float(np.abs(A).max())) + np.linalg.norm(W, axis=1)
    return W + 1e3 * RESIDUAL_TOL * sizes[:, None] * n


@pytest.fixture(scope="module", params=list(MATRICES))
def case(request):
    A, f_max = MATRICES[request.param]
    rng = np.random.default_rng(list(MATRICES).index(request.param))
    W = _boundary_wrenches(A, f_max, rng)
    vertices = (A @ rng.integers(0, 2, (A.shape[1], 3)) * f_max).T  # bang-bang allocations
    W = np.vstack([W, vertices, _off_range(A, f_max, W, rng)])
    return request.param, A, f_max, W, np.array([gamma_reference(A, w, f_max) for w in W])


def test_the_reference_measures_the_gauges_it_was_built_with(case):
    """Against the construction (gauge 1 + offset exactly): the reference itself is sound."""
    name, A, f_max, W, ref = case
    built = ref[2 : 2 + 3 * len(GAUGES)].reshape(3, len(GAUGES))
    assert np.allclose(built, 1.0 + np.array(GAUGES), rtol=0, atol=BAND / 10), name
    assert ref[0] == pytest.approx(0.0, abs=BAND / 10)


@pytest.mark.parametrize("method", mq.METHODS)
def test_every_method_decides_and_measures_as_the_reference(case, method):
    name, A, f_max, W, ref = case
    ok = mq.feasible(A, W, f_max, method)
    margin = mq.margin(A, W, f_max, method)
    clear = np.abs(ref - THRESHOLD) > BAND
    wrong = np.flatnonzero((ok != (ref <= THRESHOLD)) & clear)
    assert wrong.size == 0, (name, method, ref[wrong], ok[wrong])
    assert np.array_equal(margin >= 0, ok), (name, method)
    assert np.array_equal(np.isinf(ref), margin == -np.inf), (name, method)
    measured = np.isfinite(ref) & (np.abs(ref - 1.0) > TOL + BAND)  # outside the margin's 0 band
    err = np.abs((1.0 - margin[measured]) - ref[measured]) / np.maximum(1.0, ref[measured])
    assert err.max(initial=0.0) <= BAND, (name, method, err.max())


@pytest.mark.parametrize("factor", [0.9, 2.0])
def test_the_whitened_path_near_its_condition_limit(factor):
    """Just under :data:`MAX_CONDITION` the whitened gammas (clipped at CAP, as the lookahead
    walks them) are the reference's, along the weakest direction too; at twice it the matrix
    is declined (the SVD's zonotope takes it)."""
    rng = np.random.default_rng(5)
    U, _ = np.linalg.qr(rng.standard_normal((6, 6)))
    V, _ = np.linalg.qr(rng.standard_normal((MIN_COLUMNS, 6)))
    A = U @ np.diag(np.logspace(0, -np.log10(factor * MAX_CONDITION), 6)) @ V.T
    z = whitened(A)
    if factor > 1:
        assert z is None
        return
    assert z is not None
    weak = [U[:, -1] * sign + 1e-3 * rng.standard_normal(6) for sign in (1, -1)]
    W = _boundary_wrenches(A, 1.0, rng, [*rng.standard_normal((2, 6)), *weak])
    c = A.sum(axis=1) / 2
    W = np.vstack([W, c + 1.5 * (W[2:] - c), c + 2.5 * (W[2:] - c)])  # below and past the clip
    ref = np.array([gamma_reference(A, w, 1.0) for w in W])
    gamma, _ = gamma_capped_from(z, W, CAP)
    inside = ref <= CAP
    assert (ref > CAP).any() and inside.sum() >= len(W) / 2
    assert np.abs(gamma[inside] - ref[inside]).max() <= BAND
    assert (gamma[ref > CAP * (1 + BAND)] > CAP).all()
    clear = np.abs(ref - THRESHOLD) > BAND
    assert np.array_equal((gamma <= THRESHOLD)[clear], (ref <= THRESHOLD)[clear])
