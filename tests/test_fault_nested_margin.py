"""With ``rotor2`` and ``rotor+module`` a required margin holds after each smaller failure the
combined one contains too (failures come one at a time), checked against an independent
brute force: the columns removed by hand and gamma by scipy's linprog (HiGHS)."""

import itertools

import numpy as np
import pytest
from scipy.optimize import linprog

import modquad_gym as mq
from modquad_gym.oracle.failures import failure_sets, module_failures

BAND = 1e-6  # outside the LPs' shared round-off band


def gamma_margin(A, w, f_max=1.0):
    """1 - gamma of w for the matrix A by linprog: min s, A u = w, |u - f/2| <= s f/2."""
    m = A.shape[1]
    if m == 0:
        return 0.0 if np.linalg.norm(w) <= 1e-9 * f_max else -np.inf
    half = 0.5 * f_max
    c = np.zeros(m + 1)
    c[-1] = 1.0
    eye = np.eye(m)
    A_ub = np.block([[eye, -half * np.ones((m, 1))], [-eye, -half * np.ones((m, 1))]])
    b_ub = np.concatenate([half * np.ones(m), -half * np.ones(m)])
    A_eq = np.hstack([A, np.zeros((6, 1))])
    bounds = [(None, None)] * m + [(0, None)]
    r = linprog(c, A_ub, b_ub, A_eq, w, bounds=bounds, method="highs")
    return 1.0 - r.x[-1] if r.status == 0 else -np.inf


def brute_margin(A, W, sets, f_max=1.0):
    """The worst margin per wrench over the column sets ``sets``."""
    out = np.full(len(W), np.inf)
    for S in sets:
        keep = np.setdiff1d(np.arange(A.shape[1]), S)
        out = np.minimum(out, [gamma_margin(A[:, keep], w, f_max) for w in W])
    return out


def brute_sets(m, fault, per=4):
    """The failures, enumerated here: (combined sets, smaller failures they contain)."""
    rotors = [(k,) for k in range(m)]
    if fault == "rotor2":
        return list(itertools.combinations(range(m), 2)), rotors
    modules = [tuple(range(i, i + per)) for i in range(0, m, per)]
    if len(modules) == 1:
        return modules, []
    both = [M + (k,) for M in modules for k in range(m) if k not in M]
    return both, modules + rotors


def test_four_vertical_rotors_keep_the_margin_after_one_failure():
    A = np.zeros((6, 4))
    A[2] = 1.0  # four identical vertical rotors, given as a matrix
    W = np.array([[0, 0, 1.0, 0, 0, 0]])
    single = mq.fault_margin(A, W, 1.0, fault="rotor")[0]  # three rotors left: 2/3
    assert single == pytest.approx(brute_margin(A, W, [(0,)])[0], abs=BAND)
    pairs = brute_margin(A, W, brute_sets(4, "rotor2")[0])[0]  # two rotors left: 1
    assert single < 0.8 < pairs
    assert not mq.tolerates(A, W, 1.0, fault="rotor2", fault_margin=0.8)[0]
    assert mq.fault_margin(A, W, 1.0, fault="rotor2")[0] == pytest.approx(single, abs=BAND)
    assert mq.tolerates(A, W, 1.0, fault="rotor2", fault_margin=0.6)[0]


def random_matrix(rng, modules, vertical=False):
    """A (6, 4 modules) matrix of thrust directions near vertical at random points, or of
    vertical rotors of random strength on the COM (where a smaller failure can leave less
    margin than a combined one)."""
    m = 4 * modules
    if vertical:
        A = np.zeros((6, m))
        A[2] = rng.uniform(0.5, 1.5, m)
        return A
    d = np.vstack([rng.normal(0, 0.4, (2, m)), np.ones((1, m))])
    d /= np.linalg.norm(d, axis=0)
    p = rng.normal(0, 0.3, (3, m))
    return np.vstack([d, np.cross(p.T, d.T).T])


def random_cells(rng, n):
    cells = {(0, 0)}
    while len(cells) < n:
        i, j = sorted(cells)[rng.integers(len(cells))]
        di, dj = [(1, 0), (-1, 0), (0, 1), (0, -1)][rng.integers(4)]
        cells.add((i + di, j + dj))
    return sorted(cells)


@pytest.mark.parametrize("fault", ["rotor2", "rotor+module"])
def test_margins_and_decisions_agree_with_a_brute_force(fault):
    rng = np.random.default_rng(19)
    cases = [random_matrix(rng, 2, vertical=k < 2) for k in range(5)]
    cases += [mq.Structure(random_cells(rng, n)) for n in (1, 2, 3)]
    nested_matters = 0
    for case in cases:
        A = case if isinstance(case, np.ndarray) else case.configuration_matrix()
        U = rng.uniform(0.2, 0.8, size=(6, A.shape[1]))
        U[:3] *= 0.3  # light wrenches: fewer rotors bring the centre nearer them
        W = U @ A.T
        combined, smaller = brute_sets(A.shape[1], fault)
        ref = np.minimum(brute_margin(A, W, combined), brute_margin(A, W, smaller))
        nested_matters += int((ref < brute_margin(A, W, combined) - BAND).sum())
        got = mq.fault_margin(case, W, 1.0, fault=fault)
        finite = np.isfinite(ref)
        assert np.allclose(got[finite], ref[finite], atol=BAND)
        assert (got[~finite] < 0).all()
        mu = float(np.clip(np.median(ref[finite]) if finite.any() else 0.1, 0.01, 0.9))
        clear = np.abs(ref - mu) > BAND
        for method in ("auto", "daqp"):
            ok = mq.tolerates(case, W, 1.0, fault=fault, fault_margin=mu, method=method)
            assert (ok[clear] == (ref[clear] >= mu)).all()
    assert nested_matters  # some wrench keeps less after a smaller failure than after both


def test_without_a_margin_the_failure_sets_are_unchanged():
    for fault in ("rotor", "module"):
        assert len(failure_sets(8, fault, nested=True)) == len(failure_sets(8, fault))
    assert len(failure_sets(8, "rotor2", nested=True)) == 8 + 28
    assert len(module_failures(np.array([0, 4, 8]), "rotor+module", nested=True)) == 2 + 8 + 8
    assert len(module_failures(np.array([0, 4]), "rotor+module", nested=True)) == 1


def test_the_search_checker_asks_the_margin_after_the_single_failure_too():
    A = np.zeros((6, 4))
    A[2] = 1.0
    w = np.array([[0, 0, 1.0, 0, 0, 0]])
    single = brute_margin(A, w, [(0,)])[0]  # the pairs leave more (the first test)
    for mu, expected in ((single + 0.05, False), (single - 0.05, True)):
        problem = mq.SearchProblem(w, n_max=2, fault="rotor2", fault_margin=mu)
        assert problem.checker().tolerance(A).decide(w).all() == expected
