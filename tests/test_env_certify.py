"""The env's compiled parts against the plain numpy they replaced: the per-step decisions
(:meth:`WrenchOracle.screened`, compiled with method ``"auto"``) against the numpy screen and
the DAQP LP, the structure vector and the task features bit for bit. The oracle's compiled
certificates themselves are cross-checked against HiGHS in ``test_oracle_compiled.py``.
"""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from test_oracle_compiled import wrenches_at

from modquad_gym.envs.assembly.evaluator import StructureEvaluator
from modquad_gym.geometry.structure import Structure, normalise
from modquad_gym.oracle import RESIDUAL_TOL, WrenchOracle
from modquad_gym.tasks import PaperTasks, PlantedTasks, random_cells


def plain_screen(ev: StructureEvaluator, key, W, WD):
    """The numpy screen and the DAQP LP on the same structure (a fresh oracle)."""
    cap = ev.capability_of(key)
    return WrenchOracle(ev.oracle.f_max, method="daqp").screened(cap.A, W, WD, cap.h_Wn, cap.slack)


@settings(max_examples=20, deadline=None)
@given(
    seed=st.integers(0, 2**20), n=st.integers(1, 7), family=st.sampled_from(["paper", "planted"])
)
def test_screened_equals_the_plain_screen(seed, n, family):
    """Support deficits bit for bit, and the same tested and satisfied counts."""
    rng = np.random.default_rng(seed)
    gen = PaperTasks(n_wrenches=(1, 60)) if family == "paper" else PlantedTasks()
    task = gen(rng)
    module = Structure([(0, 0)]).module
    ev = StructureEvaluator(module, 7, task.f_max, 48, "auto")
    arrays = ev.task_arrays(task)
    key = normalise(random_cells(rng, n))
    cap = ev.capability_of(key)
    got = ev.oracle.screened(cap.A, arrays.W, arrays.WD, cap.h_Wn, cap.slack, key)
    want = plain_screen(ev, key, arrays.W, arrays.WD)
    assert got[0].tobytes() == want[0].tobytes()
    assert got[1:] == want[1:]
    plain = StructureEvaluator(module, 7, task.f_max, 48, "daqp")
    n_sat, vec, tests = ev.evaluate(key, arrays, 0.0, {})
    n_sat_p, vec_p, tests_p = plain.evaluate(key, arrays, 0.0, {})
    assert (n_sat, tests, vec.tobytes()) == (n_sat_p, tests_p, vec_p.tobytes())


@pytest.mark.parametrize("cells", [[(0, 0)], [(0, 0), (1, 0)], [(0, 0), (0, 1), (0, 2)]])
def test_off_range_residuals_near_the_rule_match_the_plain_screen(cells):
    """Rank-deficient structures: residuals placed at factors of RESIDUAL_TOL (1 + |w|) around
    the oracle's off-range rule give the plain path's answers and counts."""
    module = Structure([(0, 0)]).module
    ev = StructureEvaluator(module, 7, 1.0, 48, "auto")
    key = normalise(cells)
    cap = ev.capability_of(key)
    z = ev.oracle.zonotope(cap.A, key)
    normal = np.linalg.svd(z.Q, full_matrices=True)[0][:, -1]  # orthogonal to range(A)
    inside = wrenches_at(z, 5, [0.2, 0.6, 0.95] * 3)
    rows = []
    for w in inside:
        for factor in (0.0, 0.5, 0.98, 0.999, 1.0, 1.001, 1.02, 2.0):
            bound = RESIDUAL_TOL * (1.0 + np.linalg.norm(w))
            rows.append(w + factor * bound * normal)
    W = np.array(rows)
    WD = W @ ev.features.D.T / ev.features.denom
    got = ev.oracle.screened(cap.A, W, WD, cap.h_Wn, cap.slack, key)
    want = plain_screen(ev, key, W, WD)
    assert got[0].tobytes() == want[0].tobytes() and got[1:] == want[1:]
    assert ev.oracle.fallback > 0  # residuals within 1 % of the rule go to the LP


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
