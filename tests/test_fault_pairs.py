"""Two failures (issue 47): every test of the pair certificate cross-checked against HiGHS on the
failed matrix it speaks for, on random structures (rank-deficient lines and pairs of modules
included) and wrenches at the boundary of what a pair of failures leaves; a module and then a
rotor (``"rotor+module"``) against HiGHS on every failed matrix, through the bounds, the
searches, the env and the flight; the fault-aware cache and level bounds."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import modquad_gym as mq
from modquad_gym.geometry.polyominoes import PolyominoStream
from modquad_gym.oracle import TOL, Zonotope
from modquad_gym.oracle.fault_corrections import SINGULAR, pair_corrections, pair_lift
from modquad_gym.oracle.fault_kernels import PATHS
from modquad_gym.oracle.faults import FaultTolerance, failure_sets
from modquad_gym.tasks import PaperTasks

SHAPES = [
    [(0, 0), (1, 0)],  # rank 5: most pairs lower the rank
    [(0, 0), (1, 0), (2, 0)],  # a line, rank 5
    [(0, 0), (1, 0), (0, 1), (1, 1)],
    [(0, 0), (1, 0), (2, 0), (0, 1), (1, 1)],
    [(0, 0), (1, 0), (0, 1), (1, 1), (2, 0), (2, 1), (0, 2)],  # the benchmark's structure
]
SAMPLE = 6  # (wrench, pair) cases checked by HiGHS per test of the certificate and structure


def boundary_wrenches(A: np.ndarray, rng, t: int) -> np.ndarray:
    """Wrenches inside, on and just outside what a failed pair leaves: allocations with two
    rotors off (or in [0, 1] for the rest), scaled about 1."""
    m = A.shape[1]
    U = rng.uniform(0, 1, (t, m)) * rng.uniform(0.3, 1.0, (t, 1))
    U[: t // 2, :][np.arange(t // 2)[:, None], rng.integers(0, m, (t // 2, 2))] = 0.0
    U[: t // 4] = np.round(U[: t // 4])  # vertices
    scale = rng.choice([0.9, 0.99, 0.999, 1.0, 1.001, 1.01, 1.1], size=(t, 1))
    return (U @ A.T) * scale


def traced(structure: mq.Structure, W: np.ndarray):
    """(certificate per (wrench, pair), test that settled it, the pairs, the wrenches the intact
    structure exerts, the FaultTolerance)."""
    A = structure.configuration_matrix()
    z = Zonotope(A, 1.0)
    ft = FaultTolerance(A, 1.0, failure_sets(A.shape[1], "rotor2"), z)
    live = W[mq.feasible(A, W)]
    R, _ = z.reduce(live)
    trace = np.full((len(live), len(ft.failures)), -1, dtype=np.int8)
    cert = ft._certify(R, trace=trace)
    return cert, trace, ft.failures, live, ft


@settings(max_examples=6, deadline=None, derandomize=True,
          suppress_health_check=[HealthCheck.too_slow])  # fmt: skip
@given(shape=st.integers(0, len(SHAPES) - 1), seed=st.integers(0, 2**31 - 1))
def test_every_test_of_the_pair_certificate_agrees_with_highs(shape, seed):
    s = mq.Structure(SHAPES[shape])
    A = s.configuration_matrix()
    rng = np.random.default_rng(seed)
    cert, trace, failures, W, _ = traced(s, boundary_wrenches(A, rng, 40))
    for path in range(len(PATHS)):
        cases = np.argwhere(trace == path)
        for t, f in cases[rng.permutation(len(cases))[:SAMPLE]]:
            margin = mq.margin(np.delete(A, failures[f], axis=1), W[t : t + 1], method="scipy")[0]
            if cert[t, f] == 1:  # tolerated: gamma <= 1 + TOL
                assert margin >= -TOL - 1e-7, (PATHS[path], t, f, margin)
            else:  # not tolerated: gamma > 1 + TOL
                assert cert[t, f] == 0 and margin <= -TOL + 1e-7, (PATHS[path], t, f, margin)


def test_every_test_is_used_on_the_benchmark_structure():
    """On the benchmark's 7-module structure every accepting test settles some pairs, and
    together they leave none to the LP (the rate goal rests on it)."""
    s = mq.Structure(SHAPES[-1])
    A = s.configuration_matrix()
    rng = np.random.default_rng(0)
    W = (rng.uniform(0.3, 1.0, (200, 28)) * rng.uniform(0, 1, (200, 28))) @ A.T
    cert, trace, _, _, ft = traced(s, W)
    for path in ("quick", "through a single failure", "first correction", "pool", "active set"):
        assert ft.paths[PATHS.index(path)] > 0, path
    assert (cert == 1).mean() > 0.999
    assert np.array_equal(np.bincount(trace[trace >= 0], minlength=len(PATHS)), ft.paths)


@pytest.mark.parametrize("cells", [SHAPES[2], SHAPES[4]])
def test_the_pair_arrays_match_the_pair_corrections(cells):
    """The test through a single failure: the correction of j once i has failed is the pair's
    correction with i already off (least-norm corrections compose), so its largest rise and
    fall off i and j are those of the pair's j row of C_S."""
    A = mq.Structure(cells).configuration_matrix()
    z = Zonotope(A, 1.0)
    H = np.ascontiguousarray(z.V.T @ z.V)
    m = A.shape[1]
    pairs = np.array(failure_sets(m, "rotor2"), dtype=np.int64)
    C, errors, up, down = pair_corrections(H, z.G, pairs, SINGULAR)
    single, rise, fall = pair_lift(H, SINGULAR)
    assert np.isfinite(errors).all() and errors.max() < 1e-12
    for f, (i, j) in enumerate(pairs):
        for a, b, row in ((i, j, 2 * f + 1), (j, i, 2 * f)):
            off = np.delete(C[row], [i, j])
            assert rise[a, b] == pytest.approx(max(off.max(), 0.0), abs=1e-9)
            assert fall[a, b] == pytest.approx(max(-off.min(), 0.0), abs=1e-9)
    assert np.abs(single @ z.G.T).max() < 1e-9  # a single failure's correction keeps G x


@pytest.mark.parametrize("fault", ["rotor", "rotor2", "module", "rotor+module"])
def test_the_support_after_the_worst_failure_is_the_least_over_failures(fault):
    """The fault-aware cache test: what the compiled support leaves after the worst failure of
    the kind is the smallest support over that kind's failed matrices (so a direction beyond it
    separates the task from some failed structure)."""
    from modquad_gym.search import supports

    module = mq.TModule()
    D = np.random.default_rng(7).normal(size=(16, 6))
    b, alpha, beta = supports.direction_terms([module], D)
    for cells in SHAPES:
        A = mq.Structure(cells).configuration_matrix()
        n = len(cells)
        c = np.array([cells], dtype=np.int32)
        types = np.zeros((1, n), dtype=np.int8)
        cx, cy = np.empty(n), np.empty(n)
        supports._centres(c, types, 0, np.array([module.mass]), module.side, cx, cy)
        for p, d in enumerate(D):
            v = d @ A
            left = [np.maximum(np.delete(v, S), 0).sum() for S in failure_sets(len(v), fault)]
            lose = supports.LOSSES[fault]
            plus, total = supports._support(b, alpha, beta, p, types, 0, cx, cy, lose)
            assert plus == pytest.approx(min(left), abs=1e-9)
            assert total == pytest.approx(np.abs(v).sum(), abs=1e-9)


@pytest.mark.parametrize("fault", ["rotor", "rotor2", "module", "rotor+module"])
def test_the_fault_cache_changes_no_answer(fault, monkeypatch):
    """The exhaustive search with the fault-aware cache (directions learnt from failed decisions,
    supports after the worst failure) returns the same first structure in canonical order as
    with the plain cache of intact directions."""
    from modquad_gym.search import supports
    from modquad_gym.search.checker import TaskChecker

    task = PaperTasks(n_wrenches=10)(np.random.default_rng(3))
    fast = mq.exhaustive_search(task, n_max=8, fault=fault)
    monkeypatch.setattr(supports, "LOSSES", dict.fromkeys(supports.LOSSES, 0))
    monkeypatch.setattr(TaskChecker, "_learn_failure", lambda self, tolerance, W: None)
    plain = mq.exhaustive_search(task, n_max=8, fault=fault)
    assert fast.certified and plain.certified
    assert fast.structure.cells == plain.structure.cells
    assert fast.evaluated == plain.evaluated


@pytest.mark.parametrize("fault", ["rotor", "rotor2", "module", "rotor+module"])
def test_the_level_bounds_after_a_failure_are_the_level_maxima(fault):
    """The fault-aware level bound of n modules is the largest, over every structure of n
    modules, of its support after its own worst failure (so no tolerant structure of n modules
    exceeds it), checked by enumerating the levels to 4 modules."""
    from modquad_gym.search.bounds import compute_level_bounds, level_directions

    D = level_directions()
    for n in (1, 2, 3, 4):
        plus, total = np.zeros(len(D)), np.zeros(len(D))
        for cells in [c for chunk in PolyominoStream(n, 1 << 12) for c in chunk.tolist()]:
            V = D @ mq.Structure([tuple(c) for c in cells]).configuration_matrix()
            left = [np.maximum(np.delete(V, S, axis=1), 0).sum(axis=1)
                    for S in failure_sets(V.shape[1], fault)]  # fmt: skip
            plus = np.maximum(plus, np.min(left, axis=0))
            total = np.maximum(total, np.abs(V).sum(axis=1))
        bounds = compute_level_bounds(mq.TModule(), n, fault)
        assert np.allclose(bounds[0], plus, atol=1e-9) and np.allclose(bounds[1], total, atol=1e-9)


@pytest.mark.parametrize("cells", [[(0, 0)], [(0, 0), (1, 0), (2, 0)], SHAPES[2]])
def test_rotor_and_module_agrees_with_highs_on_every_failed_matrix(cells):
    s = mq.Structure(cells)
    A = s.configuration_matrix()
    rng = np.random.default_rng(len(cells))
    U = rng.uniform(0.2, 1.0, (10, A.shape[1]))
    U[:5, rng.integers(0, A.shape[1], 5)] = 0.0
    W = (U @ A.T) * rng.choice([0.1, 0.2, 0.3, 0.6], size=(10, 1))
    W[:3] = [[0, 0, fz, 0, 0, 0] for fz in (1.0, 2.0, 3.0)]  # hovers: a square keeps 2, not 3
    failures = failure_sets(A.shape[1], "rotor+module")
    assert len(failures) == (1 if len(cells) == 1 else len(cells) * 4 * (len(cells) - 1))
    ref = np.min([mq.margin(np.delete(A, S, axis=1), W, method="scipy") if len(S) < A.shape[1]
                  else np.where(np.linalg.norm(W, axis=1) == 0, 0.0, -np.inf)
                  for S in failures], axis=0)  # fmt: skip
    clear = np.abs(ref) > 1e-6
    for method in ("auto", "daqp"):
        ok = mq.tolerates(s, W, fault="rotor+module", method=method)
        assert np.array_equal(ok[clear], ref[clear] >= 0)
    if cells == SHAPES[2]:
        assert ok.any() and not ok.all()  # both answers occur
    margin = mq.fault_margin(s, W, fault="rotor+module")
    assert np.array_equal(margin >= 0, ok)


def test_rotor_and_module_through_the_searches_the_env_and_the_flight():
    """The force bound stays below the certified minimum, which is at least the module
    failure's; the default search finds it too; the answer holds on every failed matrix
    (HiGHS); the env takes the fault; the answer is flown through its worst failure."""
    import gymnasium as gym

    from modquad_gym.search.bounds import force_lower_bound
    from modquad_gym.sim.fault_flight import fly_with_failure
    from modquad_gym.tasks import load_task

    task = load_task("example:screwdriver")
    both = mq.exhaustive_search(task, n_max=9, fault="rotor+module")
    module = mq.exhaustive_search(task, n_max=9, fault="module")
    assert both.certified and module.n_modules <= both.n_modules
    assert force_lower_bound(task.wrenches, mq.TModule(), task.f_max, "rotor+module") <= (
        both.n_modules
    )
    assert mq.anytime_search(task, n_max=9, fault="rotor+module", time_limit=20).n_modules == (
        both.n_modules
    )
    A = both.structure.configuration_matrix()
    W = task.rotor_wrenches(both.structure)
    for S in failure_sets(A.shape[1], "rotor+module"):
        assert (mq.margin(np.delete(A, S, axis=1), W, method="scipy") > -1e-6).all()
    env = gym.make("ModQuadAssembly-v0", task="example:screwdriver", fault="rotor+module",
                   n_max=6)  # fmt: skip
    env.reset(seed=0)
    env.step(int(np.flatnonzero(env.unwrapped.action_masks())[0]))
    f = fly_with_failure(both.structure, task, "rotor+module", seconds=1.1, failure="worst")
    assert len(f.failure.columns) == 5 and f.worst.tolerates
    assert f.max_position_error_m < 0.05
