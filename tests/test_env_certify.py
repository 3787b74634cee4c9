"""The env's compiled decisions (envs/assembly/certify.py) against the oracle they stand in for.

Every fast answer is cross-checked against the plain path: ``WrenchOracle.feasible`` (method
``"auto"``) for single decisions, ``StructureEvaluator.against_plain`` for the support test and
counts, with wrenches placed at chosen gauges gamma around the threshold 1 + TOL (down to inside
the band where the compiled tests must hand the wrench to the oracle).
"""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from modquad_gym.envs.assembly.certify import ACCEPT, REJECT, FastDecider
from modquad_gym.envs.assembly.evaluator import StructureEvaluator
from modquad_gym.geometry.structure import Structure, normalise
from modquad_gym.oracle import BAND, RESIDUAL_TOL, TOL, WrenchOracle
from modquad_gym.oracle.highs_lp import gamma_highs
from modquad_gym.tasks import PaperTasks, PlantedTasks, random_cells

GAUGES = (0.0, 0.3, 0.9, 0.999, 1.0, 1.0 + TOL - 1e-6, 1.0 + TOL - 2 * BAND, 1.0 + TOL,
          1.0 + TOL + 2 * BAND, 1.0 + 2e-6, 1.001, 1.5, 30.0)  # fmt: skip
"""Gauges gamma at which test wrenches are placed (the threshold is 1 + TOL)."""


def structure(seed: int, n: int) -> tuple[tuple, np.ndarray]:
    """(key, configuration matrix) of a random connected structure of n modules."""
    key = normalise(random_cells(np.random.default_rng(seed), n))
    return key, Structure.from_trusted(key).configuration_matrix()


def wrenches_at(oracle: WrenchOracle, A: np.ndarray, key, seed: int, gauges) -> np.ndarray:
    """Wrenches (rows) whose gauge about the hover centre is each of ``gauges`` (in random
    directions of range(A)), by scaling each direction by its exact (HiGHS) gamma."""
    z = oracle.zonotope(A, key)
    rng = np.random.default_rng(seed)
    D = rng.standard_normal((len(gauges), z.rank))
    gamma = gamma_highs(z, D)
    R = D * (np.asarray(gauges) / gamma)[:, None]
    return oracle.f_max * (R + z.c) @ z.Q.T


@settings(max_examples=25, deadline=None)
@given(
    seed=st.integers(0, 2**20),
    n=st.integers(1, 7),
    f_max=st.sampled_from([1.0, 0.37, 2.0, 1e-6, 1e6]),
)
def test_fast_decisions_equal_the_oracles_near_the_boundary(seed, n, f_max):
    key, A = structure(seed, n)
    plain, fast_oracle = WrenchOracle(f_max), WrenchOracle(f_max)
    fast = FastDecider(fast_oracle)
    W = wrenches_at(plain, A, key, seed, GAUGES * 3)
    expected = plain.feasible(A, W, key=key)
    assert np.array_equal(fast.feasible(A, W, key), expected)
    # outside the band the answer is the tolerance rule itself
    gauges = np.array(GAUGES * 3)
    clear = np.abs(gauges - (1.0 + TOL)) > BAND
    assert np.array_equal(expected[clear], gauges[clear] <= 1.0 + TOL)


def test_wrenches_inside_the_band_go_to_the_oracle():
    key, A = structure(3, 5)
    oracle = WrenchOracle(1.0)
    fast = FastDecider(oracle)
    W = wrenches_at(oracle, A, key, 0, [1.0 + TOL] * 8 + [0.5, 2.0])
    out = fast.feasible(A, W, key)
    assert fast.fallback >= 8  # no certificate holds within BAND of the threshold
    assert np.array_equal(out, WrenchOracle(1.0).feasible(A, W, key=key))
    assert ACCEPT < 1.0 + TOL < REJECT


def test_off_range_and_huge_wrenches_match_the_oracle():
    oracle = WrenchOracle(1.0)
    fast = FastDecider(oracle)
    for n, cells in (
        (1, [(0, 0)]),
        (3, [(0, 0), (1, 0), (2, 0)]),
        (4, [(0, 0), (1, 0), (0, 1), (1, 1)]),
    ):  # noqa: E501
        key = normalise(cells)
        A = Structure.from_trusted(key).configuration_matrix()
        rng = np.random.default_rng(n)
        W = np.vstack([rng.normal(size=(20, 6)) + [0, 0, 2 * n, 0, 0, 0], [[0, 0, 1e120, 0, 0, 0]],
                       [[1e200, 0, 1e200, 0, 0, 1e200]], [[0, 0, n, 0, 0, 0]]])  # fmt: skip
        assert np.array_equal(fast.feasible(A, W, key), WrenchOracle(1.0).feasible(A, W, key=key))


@pytest.mark.parametrize("method", ["auto", "daqp"])
def test_evaluator_fast_path_only_for_auto(method):
    ev = StructureEvaluator(Structure([(0, 0)]).module, 7, 1.0, 48, method)
    assert (ev.fast is not None) == (method == "auto")


@settings(max_examples=20, deadline=None)
@given(
    seed=st.integers(0, 2**20), n=st.integers(1, 7), family=st.sampled_from(["paper", "planted"])
)
def test_against_equals_against_plain(seed, n, family):
    """Support deficits bit for bit, and the same tested and satisfied counts."""
    rng = np.random.default_rng(seed)
    gen = PaperTasks(n_wrenches=(1, 60)) if family == "paper" else PlantedTasks()
    task = gen(rng)
    module = Structure([(0, 0)]).module
    fast = StructureEvaluator(module, 7, task.f_max, 48, "auto")
    plain = StructureEvaluator(module, 7, task.f_max, 48, "auto")
    plain.fast = None
    arrays = fast.task_arrays(task, np.asarray(task.wrenches, dtype=float))
    key = normalise(random_cells(rng, n))
    cap = fast.capability_of(key)
    got = fast.fast.against(cap.A, key, arrays.W, arrays.WD, cap.h_Wn, cap.slack)
    want = plain.against_plain(plain.capability_of(key), key, arrays.W, arrays.WD)
    assert got[0].tobytes() == want[0].tobytes()
    assert got[1:] == want[1:]
    n_sat, vec, tests = fast.evaluate(key, arrays, 0.0, {})
    n_sat_p, vec_p, tests_p = plain.evaluate(key, arrays, 0.0, {})
    assert (n_sat, tests, vec.tobytes()) == (n_sat_p, tests_p, vec_p.tobytes())


def test_remembered_directions_keep_answers_across_calls():
    """Directions remembered from one task's wrenches are certificates for the next tasks."""
    key, A = structure(11, 6)
    oracle = WrenchOracle(1.0)
    fast = FastDecider(oracle)
    for seed in range(6):
        W = wrenches_at(oracle, A, key, seed, np.linspace(0.2, 3.0, 40))
        assert np.array_equal(fast.feasible(A, W, key), WrenchOracle(1.0).feasible(A, W, key=key))


@pytest.mark.parametrize("cells", [[(0, 0)], [(0, 0), (1, 0)], [(0, 0), (0, 1), (0, 2)]])
def test_off_range_residuals_near_the_rule_match_the_oracle(cells):
    """Rank-deficient structures: residuals placed at factors of RESIDUAL_TOL (1 + |w|) around
    the oracle's off-range rule give the oracle's answers and counts."""
    module = Structure([(0, 0)]).module
    fast = StructureEvaluator(module, 7, 1.0, 48, "auto")
    plain = StructureEvaluator(module, 7, 1.0, 48, "auto")
    plain.fast = None
    key = normalise(cells)
    cap = fast.capability_of(key)
    z = fast.oracle.zonotope(cap.A, key)
    normal = np.linalg.svd(z.Q, full_matrices=True)[0][:, -1]  # orthogonal to range(A)
    inside = wrenches_at(fast.oracle, cap.A, key, 5, [0.2, 0.6, 0.95] * 3)
    rows = []
    for w in inside:
        for factor in (0.0, 0.5, 0.98, 0.999, 1.0, 1.001, 1.02, 2.0):
            bound = RESIDUAL_TOL * (1.0 + np.linalg.norm(w))
            rows.append(w + factor * bound * normal)
    W = np.array(rows)
    WD = W @ fast.features.D.T / fast.features.denom
    got = fast.fast.against(cap.A, key, W, WD, cap.h_Wn, cap.slack)
    want = plain.against_plain(plain.capability_of(key), key, W, WD)
    assert got[0].tobytes() == want[0].tobytes() and got[1:] == want[1:]


def structure_against_numpy(features, head, h_Wn, h_Tn, per_wrench, satisfied_fraction):
    """The element-wise numpy version that the compiled structure_against replaced."""
    out = head.copy()
    k = features.k
    np.subtract(h_Tn, h_Wn, out=out[k : 2 * k], casting="same_kind")
    j = 2 * k
    out[j] = satisfied_fraction
    out[j + 3] = np.count_nonzero(h_Wn >= h_Tn) / k
    out[j + 4] = np.add.reduce(per_wrench) / len(per_wrench)
    out[j + 5] = np.maximum.reduce(per_wrench)
    out[j + 6] = np.minimum.reduce(per_wrench)
    np.maximum(out, -1.0, out=out)
    return np.minimum(out, 1.0, out=out)


@settings(max_examples=40, deadline=None)
@given(seed=st.integers(0, 2**20), t=st.integers(1, 300), spread=st.sampled_from([0.1, 1.0, 5.0]))
def test_compiled_structure_vector_is_bit_identical(seed, t, spread):
    rng = np.random.default_rng(seed)
    ev = StructureEvaluator(Structure([(0, 0)]).module, 7, 1.0, 48, "auto")
    key = normalise(random_cells(rng, int(rng.integers(1, 8))))
    cap = ev.capability_of(key)
    h_Tn = cap.h_Wn + spread * rng.standard_normal(len(cap.h_Wn))
    h_Tn[::7] = cap.h_Wn[::7]  # ties count as covered
    per_wrench = spread * rng.standard_normal(t)
    frac = float(rng.random())
    got = ev.features.structure_against(cap.head, cap.h_Wn, h_Tn, per_wrench, frac)
    want = structure_against_numpy(ev.features, cap.head, cap.h_Wn, h_Tn, per_wrench, frac)
    assert got.dtype == want.dtype and got.tobytes() == want.tobytes()


def task_numpy(features, W):
    """The numpy version of AssemblyFeatures.task that the compiled one replaced."""
    proj = W @ features.D.T
    h_T = proj.max(axis=0)
    F, T, fz = W[:, :3], W[:, 3:], W[:, 2]
    f = np.sqrt(np.add.reduce(F * F, axis=1))
    tau = np.sqrt(np.add.reduce(T * T, axis=1))
    t = len(W)
    fz_mean = np.add.reduce(fz) / t
    dev = fz - fz_mean
    dev *= dev
    fz_std = math.sqrt(np.add.reduce(dev) / t)
    s = features.scale
    ts = features.side * s
    vec = np.empty(features.task_size)
    vec[: features.k] = h_T
    vec[: features.k] /= s
    vec[features.k :] = (
        np.add.reduce(f) / t / s,
        f.max() / s,
        np.add.reduce(tau) / t / ts,
        tau.max() / ts,
        fz_mean / s,
        fz_std / s,
        math.log1p(t) / math.log1p(1000),
    )
    np.clip(vec, -1.0, 1.0, out=vec)
    return vec.astype(np.float32), h_T / features.denom, proj / features.denom


@settings(max_examples=40, deadline=None)
@given(
    seed=st.integers(0, 2**20),
    t=st.sampled_from([1, 2, 7, 8, 9, 16, 80, 300]),
    scale=st.sampled_from([1e-6, 0.5, 3.0, 1e4]),
    zeros=st.booleans(),
)
def test_compiled_task_features_are_bit_identical(seed, t, scale, zeros):
    rng = np.random.default_rng(seed)
    W = scale * rng.standard_normal((t, 6))
    if zeros:
        W[:, [1, 3, 5]] = 0.0  # exact zeros, as in the screwdriver task
    features = StructureEvaluator(Structure([(0, 0)]).module, 7, 1.0, 48, "auto").features
    for got, want in zip(features.task(W), task_numpy(features, W)):
        assert got.dtype == want.dtype and got.shape == want.shape
        assert got.tobytes() == want.tobytes()
