"""The compiled certificates and gamma (method ``"compiled"``; the decisions of ``"auto"``)
against HiGHS.

Wrenches are placed at chosen gauges gamma about the hover centre, down to within GUARD of the
threshold 1 + TOL on both sides (where no certificate may decide and the exact LP must), on
structures of every rank (one module: 4, straight lines: 5) and up to 64 modules (m = 256),
including the lattice's symmetric shapes, whose facets hold many columns (degenerate vertices).
"""

import numpy as np
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st

from modquad_gym.geometry.structure import Structure, normalise
from modquad_gym.oracle import TOL, WrenchOracle, Zonotope, decide_with, margin_with
from modquad_gym.oracle.compiled import gamma_compiled, verdicts
from modquad_gym.oracle.highs_lp import gamma_highs
from modquad_gym.oracle.tolerance import ACCEPT, BAND, GUARD, REJECT
from modquad_gym.tasks import random_cells

GAUGES = (0.0, 0.3, 0.9, 0.999, 1.0, 1.0 + TOL - 1e-6, 1.0 + TOL - 2 * BAND, 1.0 + TOL,
          1.0 + TOL + 2 * BAND, 1.0 + 2e-6, 1.001, 1.5, 30.0)  # fmt: skip
"""Gauges gamma at which test wrenches are placed (the threshold is 1 + TOL)."""


def structure(seed: int, n: int) -> np.ndarray:
    """Configuration matrix of a random connected structure of n modules."""
    key = normalise(random_cells(np.random.default_rng(seed), n))
    return Structure.from_trusted(key).configuration_matrix()


def wrenches_at(z: Zonotope, seed: int, gauges) -> np.ndarray:
    """Wrenches (rows) whose gauge about the hover centre is each of ``gauges`` (in random
    directions of range(A)), by scaling each direction by its exact (HiGHS) gamma."""
    rng = np.random.default_rng(seed)
    D = rng.standard_normal((len(gauges), z.rank))
    gamma = gamma_highs(z, D)
    R = D * (np.asarray(gauges) / gamma)[:, None]
    return z.f_max * (R + z.c) @ z.Q.T


def reference(z: Zonotope, W: np.ndarray) -> np.ndarray:
    return decide_with(z, W, "scipy")


@settings(max_examples=25, deadline=None)
@given(
    seed=st.integers(0, 2**20),
    n=st.integers(1, 7),
    f_max=st.sampled_from([1.0, 0.37, 2.0, 1e-6, 1e6]),
)
def test_compiled_decisions_equal_highs_near_the_boundary(seed, n, f_max):
    z = Zonotope(structure(seed, n), f_max)
    gauges = np.array(GAUGES * 3)
    W = wrenches_at(z, seed, gauges)
    got = decide_with(z, W, "compiled")
    clear = np.abs(gauges - (1.0 + TOL)) > BAND
    np.testing.assert_array_equal(got[clear], reference(z, W)[clear])
    # outside the band the answer is the tolerance rule itself
    np.testing.assert_array_equal(got[clear], gauges[clear] <= 1.0 + TOL)


def test_wrenches_within_guard_are_left_to_the_lp():
    z = Zonotope(structure(3, 5))
    W = wrenches_at(z, 0, [1.0 + TOL] * 8 + [0.5, 2.0])
    R, _ = z.reduce(W)
    v = verdicts(z, R)
    assert (v[:8] == -1).all() and v[8] == 1 and v[9] == 0
    assert ACCEPT == 1.0 + TOL - GUARD and REJECT == 1.0 + TOL + GUARD
    np.testing.assert_array_equal(decide_with(z, W, "compiled"), decide_with(z, W, "daqp"))


@pytest.mark.parametrize(
    "cells",
    [[(0, 0)], [(0, 0), (1, 0), (2, 0)], [(0, 0), (0, 1), (0, 2), (0, 3)],
     [(0, 0), (1, 0), (0, 1), (1, 1)]],
)  # fmt: skip
def test_rank_deficient_off_range_and_huge_wrenches(cells):
    A = Structure(cells).configuration_matrix()
    z = Zonotope(A)
    rng = np.random.default_rng(len(cells))
    n = len(cells)
    W = np.vstack([rng.normal(size=(20, 6)) + [0, 0, 2 * n, 0, 0, 0], [[0, 0, 1e120, 0, 0, 0]],
                   [[1e200, 0, 1e200, 0, 0, 1e200]], [[0, 0, n, 0, 0, 0]],
                   wrenches_at(z, n, GAUGES)])  # fmt: skip
    np.testing.assert_array_equal(decide_with(z, W, "compiled"), reference(z, W))


def test_remembered_directions_keep_answers_across_calls():
    """Directions remembered from one batch are certificates for the next batches."""
    A = structure(11, 6)
    z = Zonotope(A)
    for seed in range(6):
        W = wrenches_at(z, seed, np.linspace(0.2, 3.0, 40))
        np.testing.assert_array_equal(decide_with(z, W, "compiled"), reference(Zonotope(A), W))
    assert z.kernel[1][2][0] > 0  # directions were remembered


SHAPES = {
    "random 32": lambda: structure(32, 32),
    "random 64": lambda: structure(64, 64),
    "square 8x8": lambda: Structure([(i, j) for i in range(8) for j in range(8)]),
    "line of 64 (rank 5)": lambda: Structure([(i, 0) for i in range(64)]),
    "one module (rank 4)": lambda: Structure([(0, 0)]),
}


def matrix_of(name: str) -> np.ndarray:
    made = SHAPES[name]()
    return made if isinstance(made, np.ndarray) else made.configuration_matrix()


@pytest.mark.parametrize("name", list(SHAPES))
def test_large_and_degenerate_structures_near_the_boundary(name):
    """Up to m = 256: gauges on both sides of the threshold (5 GUARD away: certificates must
    decide them) and far from it; HiGHS agrees, and no wrench is left to the LP."""
    z = Zonotope(matrix_of(name))
    gauges = np.array([0.2, 0.5, 0.95, 0.999, 1.0 + TOL - 5 * GUARD, 1.0 + TOL + 5 * GUARD,
                       1.001, 1.05, 2.0, 40.0] * 3)  # fmt: skip
    W = wrenches_at(z, len(name), gauges)
    got = decide_with(z, W, "compiled")
    np.testing.assert_array_equal(got, gauges <= 1.0 + TOL)
    np.testing.assert_array_equal(got, reference(z, W))
    assert (verdicts(Zonotope(z.A), z.reduce(W)[0]) >= 0).all()


@pytest.mark.parametrize("name", ["random 64", "square 8x8", "line of 64 (rank 5)"])
def test_margins_within_1e9_of_zero_at_m_256(name):
    """Margins within 1e-9 of 0 on both sides, at the two edges of the tolerance band: at
    gamma = 1 -+ 1e-9 (margin 0, feasible) and at gamma = 1 + TOL -+ 1e-9 (inside GUARD: no
    certificate may claim them; the LP decides, as the plain DAQP method does)."""
    z = Zonotope(matrix_of(name))
    inner = wrenches_at(z, 7, [1.0 - 1e-9, 1.0 + 1e-9] * 3)
    np.testing.assert_array_equal(decide_with(z, inner, "compiled"), True)
    np.testing.assert_array_equal(margin_with(z, inner, "compiled"), 0.0)
    edge = wrenches_at(z, 8, [1.0 + TOL - 1e-9, 1.0 + TOL + 1e-9] * 3)
    assert (verdicts(z, z.reduce(edge)[0]) == -1).all()
    np.testing.assert_array_equal(decide_with(z, edge, "compiled"), decide_with(z, edge, "daqp"))
    m = margin_with(z, edge, "compiled")
    np.testing.assert_array_equal(m >= 0, decide_with(z, edge, "compiled"))
    assert np.abs(m).max() <= TOL + 2e-9


@settings(max_examples=20, deadline=None)
@given(seed=st.integers(0, 2**20), n=st.sampled_from([1, 2, 3, 5, 9, 16, 40, 64]))
@example(seed=141271, n=64)  # HiGHS 1.7e-9 (relative) above the walk's optimum
def test_compiled_gamma_equals_highs(seed, n):
    """The walk run to the optimum gives HiGHS's gamma, inside, outside and far outside the
    zonotope, within 1e-8: HiGHS solves to its own tolerances (a random example found it 1.7e-9
    off at 64 modules), the decisions' band is far wider."""
    z = Zonotope(structure(seed, n))
    rng = np.random.default_rng(seed)
    R = rng.standard_normal((12, z.rank)) * rng.uniform(0.01, 3.0, (12, 1)) * z.box
    np.testing.assert_allclose(gamma_compiled(z, R), gamma_highs(z, R), rtol=1e-8, atol=1e-8)
    assert gamma_compiled(z, np.zeros((1, z.rank)))[0] == 0.0


@settings(max_examples=15, deadline=None)
@given(
    seed=st.integers(0, 2**20),
    n=st.sampled_from([4, 16, 48, 64]),
    spread=st.sampled_from([1e-3, 0.05, 0.5]),
)
def test_boundary_heavy_batches_equal_highs(seed, n, spread):
    """Batches around the boundary (gauges 1 +- spread) on one zonotope, remembered directions
    carried from batch to batch: every decision clear of the band is HiGHS's."""
    z = Zonotope(structure(seed, n))
    rng = np.random.default_rng(seed)
    for batch in range(2):
        gauges = 1.0 + spread * rng.uniform(-1.0, 1.0, 16)
        W = wrenches_at(z, seed + batch, gauges)
        clear = np.abs(gauges - (1.0 + TOL)) > BAND
        got = decide_with(z, W, "compiled")
        np.testing.assert_array_equal(got[clear], (gauges <= 1.0 + TOL)[clear])


def test_screened_counts_undecided_wrenches_as_fallback():
    A = structure(3, 4)
    oracle = WrenchOracle()
    z = oracle.zonotope(A, "k")
    W = wrenches_at(z, 1, [0.5, 1.0 + TOL, 2.0])
    WD, h = np.zeros((3, 1)), np.zeros(1)
    per_wrench, tested, satisfied = oracle.screened(A, W, WD, h, 0.0, "k")
    on_threshold = int(decide_with(z, W[1:2], "daqp")[0])  # inside the band: the LP's call
    assert (tested, satisfied, oracle.fallback, oracle.calls) == (3, 1 + on_threshold, 1, 3)
    np.testing.assert_array_equal(per_wrench, 0.0)
    _, tested, satisfied = oracle.screened(A, W, WD, h, -1.0, "k")  # the screen rejects all
    assert (tested, satisfied) == (0, 0)


@pytest.mark.parametrize("value", ["3", "7,65", "", "x", "16,,64"])
def test_bench_oracle_refuses_bad_sizes_before_work(capsys, tmp_path, value):
    """`python -m benchmarks.oracle --modules` takes sizes 7..64: anything else is argparse's
    error (exit 2) naming the option, with nothing written."""
    from benchmarks.oracle import main

    with pytest.raises(SystemExit) as exc:
        main(["--modules", value, "--out", str(tmp_path / "r")])
    err = capsys.readouterr().err
    assert exc.value.code == 2 and "Traceback" not in err
    assert "--modules" in err.strip().splitlines()[-1]
    assert not (tmp_path / "r").exists()


def test_bench_oracle_writes_its_report_at_m_256(tmp_path):
    """One tiny run at 7 and 64 modules: the report has both goals' rows and every method's."""
    from benchmarks.oracle import run

    rows, goals = run(1, 4, 0, tmp_path, repeats=1, sizes=(7, 64))
    assert {r["rotors_m"] for r in rows} == {28, 256}
    assert any("m = 256" in g["goal"] for g in goals)
    assert {"auto", "compiled", "scipy"} <= {r["method"] for r in rows if r["rotors_m"] == 256}
    assert (tmp_path / "oracle_benchmark.md").exists()


@settings(max_examples=20, deadline=None)
@given(seed=st.integers(0, 2**20), n=st.sampled_from([1, 2, 3, 5, 9, 16, 40]))
def test_a_walk_from_any_vertex_gives_the_cold_walks_gamma(seed, n):
    """Warm starts (:func:`gamma_compiled_from`): from the optimal vertices of the rows
    themselves (with and without their column bounds), of other rows, from random tight sets
    and bounds (duplicates, indices off G, -1) and with no start, the walk gives the cold
    walk's gamma within round-off; past the cap both prove a bound above it. Every rank (one
    module 4, a line 5); rows inside, near and past the threshold and the cap."""
    from modquad_gym.oracle.compiled import gamma_compiled_from

    z = Zonotope(structure(seed, n))
    rng = np.random.default_rng(seed)
    R = z.reduce(wrenches_at(z, seed, (*GAUGES, 1.9, 2.5)))[0]
    cap = 2.0
    cold = gamma_compiled(z, R, cap)
    tights = np.full((len(R), max(z.rank - 1, 1)), -1, dtype=np.int64)
    signs = np.zeros((len(R), z.m), dtype=np.int8)
    gamma = gamma_compiled_from(z, R, cap, tights, signs)
    np.testing.assert_array_equal(gamma, cold)  # no start: the cold walk itself
    at_optimum = (tights >= 0).all(axis=1)
    assert at_optimum.sum() >= 8 and (cold[at_optimum] <= cap + 1e-9).all()
    assert np.abs(signs[at_optimum]).sum(axis=1).min() >= z.m - z.rank + 1
    junk = rng.integers(-2, z.m + 3, size=tights.shape)
    noise = rng.integers(-1, 2, size=signs.shape).astype(np.int8)
    starts = [(tights, signs), (tights, 0 * signs), (np.roll(tights, 1, axis=0), signs),
              (junk, noise)]  # fmt: skip
    for T, S in starts:
        got = gamma_compiled_from(z, R, cap, T.copy(), S.copy())
        inside = cold <= cap
        np.testing.assert_allclose(got[inside], cold[inside], rtol=1e-10, atol=1e-12)
        assert (got[~inside] > cap).all()


def assert_same_directions(got: np.ndarray, want: np.ndarray) -> None:
    """Rows equal up to round-off relative to each row's norm (a wrench at the centre has
    r . y = 1 with |y| ~ 1e13: its small entries are round-off)."""
    scale = np.linalg.norm(want, axis=1, keepdims=True)
    np.testing.assert_allclose(got / scale, want / scale, rtol=0, atol=1e-9)


def read_off(z: Zonotope, R: np.ndarray, tights, signs, cap: float):
    """(dirs, found) of :func:`~modquad_gym.oracle.vertices.vertex_directions`."""
    from modquad_gym.oracle import vertices

    dirs, found = np.zeros((len(R), z.rank)), np.zeros(len(R), dtype=bool)
    vertices.vertex_directions(z.G, R, tights, signs, cap, dirs, found)
    return dirs, found


@settings(max_examples=15, deadline=None)
@given(seed=st.integers(0, 2**20), n=st.sampled_from([2, 3, 5, 9, 16, 40]))
def test_a_unique_optimal_vertex_gives_the_cold_walks_direction(seed, n):
    """:func:`~modquad_gym.oracle.vertices.vertex_directions`: a walk's optimal vertex, reached
    from any start, read where it is gamma's unique optimum below the cap, gives the direction
    the walk from the dual-metric direction ends at (within round-off); rows past or near the
    cap, and rows without a vertex, are left to a walk."""
    from modquad_gym.oracle.compiled import gamma_compiled_from

    z = Zonotope(structure(seed, n))
    rng = np.random.default_rng(seed)
    R = z.reduce(wrenches_at(z, seed, (*GAUGES, 1.9, 2.0, 2.5)))[0]
    cap = 2.0
    cold_dirs = np.zeros((len(R), z.rank))
    cold = gamma_compiled(z, R, cap, cold_dirs)
    shape = (len(R), max(z.rank - 1, 1))
    junk = rng.integers(-1, z.m, size=shape)
    read = 0
    for start in (np.full(shape, -1), junk, np.roll(junk, 1, axis=0)):
        tights, signs = start.astype(np.int64), np.zeros((len(R), z.m), dtype=np.int8)
        gamma_compiled_from(z, R, cap, tights, signs)
        dirs, found = read_off(z, R, tights, signs, cap)
        assert_same_directions(dirs[found], cold_dirs[found])
        assert not found[(cold >= cap * (1 - 1e-9)) | (tights < 0).any(axis=1)].any()
        read += found.sum()
    assert read


def test_a_tie_between_optimal_vertices_is_left_to_the_walk():
    """On the 2 x 2 square, wrenches along the axes from the hover centre leave the zonotope
    through faces of several optimal vertices (the lattice's symmetry): no vertex is read
    there; the one read is the cold walk's."""
    from modquad_gym.oracle.compiled import gamma_compiled_from

    A = Structure([(0, 0), (1, 0), (0, 1), (1, 1)]).configuration_matrix()
    z = Zonotope(A)
    centre, reach = A.sum(axis=1) / 2.0, np.abs(A).sum(axis=1) / 2.0
    W = [centre + s * 0.5 * reach[i] * np.eye(6)[i] for i in range(6) for s in (1, -1)]
    R = z.reduce(np.vstack([*W, centre + 0.6 * np.eye(6)[0] + 0.6 * np.eye(6)[1]]))[0]
    cold_dirs = np.zeros((len(R), z.rank))
    gamma_compiled(z, R, 2.0, cold_dirs)
    tights = np.full((len(R), z.rank - 1), -1, dtype=np.int64)
    signs = np.zeros((len(R), z.m), dtype=np.int8)
    gamma_compiled_from(z, R, 2.0, tights, signs)
    dirs, found = read_off(z, R, tights, signs, 2.0)
    at_vertex = (tights >= 0).all(axis=1)
    assert at_vertex.sum() > found.sum() >= 1  # ties declined, a unique optimum read
    assert_same_directions(dirs[found], cold_dirs[found])


@settings(max_examples=40, deadline=None)
@given(seed=st.integers(0, 2**20), n=st.integers(2, 6), row=st.integers(1, 5))
def test_a_replaced_basis_row_updates_the_inverse_as_a_fresh_inversion(seed, n, row):
    """The walk's pivots update M^-1 by one rank-one step when one row of M changes
    (:func:`~modquad_gym.oracle.basis.replace_row`): the same inverse as Gauss-Jordan up to
    round-off, over chains of replacements (with and without the periodic fresh inversion);
    a replacement that makes M singular (a copy of another row) is refused, as the inversion
    refuses it."""
    from modquad_gym.oracle.basis import REFACTOR, invert, replace_row

    rng = np.random.default_rng(seed)
    q = min(row, n - 1)
    M = rng.standard_normal((n, n))
    Minv = np.zeros((n, n))
    assert invert(M, Minv, n)
    for step in range(2 * REFACTOR + 1):
        M[q] = rng.standard_normal(n)
        assert replace_row(M, Minv, n, q, step)
        np.testing.assert_allclose(Minv @ M, np.eye(n), atol=1e-9)
        want = np.zeros((n, n))
        assert invert(M, want, n)
        np.testing.assert_allclose(Minv, want, rtol=1e-8, atol=1e-10 * np.abs(want).max())
    M[q] = M[(q + 1) % n]
    assert not replace_row(M, Minv, n, q, 0)
