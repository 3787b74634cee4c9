"""The compiled walk's gamma on matrices a last-bit change away from a lattice structure, against
the independent HiGHS reference on the raw A (:func:`test_oracle_reference.gamma_reference`).

A stock structure's facets hold many rotors at once (degenerate vertices); perturbing A's
entries independently by 1e-14 .. 5e-14 (another CPU's libm or BLAS could) splits them by
round-off, so that a column can lie along the walk's edge to working accuracy. The walk's gamma,
cold (``"compiled"``) or warm-started at another zonotope's optimal vertices (the exact
lookahead), must equal the reference within its documented accuracy
(:data:`~modquad_gym.oracle.kernels.GAP`) wherever the walk answers, and within the band
(:data:`~modquad_gym.oracle.tolerance.BAND`) where the exact LP answers for it; a wrench's
answer must not depend on the batch it comes in.
"""

from __future__ import annotations

import numpy as np
import pytest
from test_oracle_numerics import known_gammas
from test_oracle_reference import gamma_reference

import modquad_gym as mq
from modquad_gym.oracle import Zonotope, gamma_with, kernels, margin
from modquad_gym.oracle.backends import gamma_capped_from
from modquad_gym.oracle.tolerance import BAND
from modquad_gym.tasks import PlantedTasks

ACCURACY = kernels.GAP
"""The walk's gamma is certified to this relative accuracy where it answers."""
CAP = 2.0  # the exact lookahead's clip

# fmt: off
REVIEWED_A = np.array([
    [0.49999999999997496, -0.49999999999997496, -0.5000000000000249, 0.5000000000000249,
     0.49999999999997496, -0.49999999999997496, -0.5000000000000249, 0.5000000000000249,
     0.49999999999997496, -0.49999999999997496, -0.5000000000000249, 0.5000000000000249,
     0.49999999999997496, -0.49999999999997496, -0.5000000000000249, 0.5000000000000249],
    [-0.49999999999997496, -0.49999999999997496, 0.5000000000000249, 0.49999999999997496,
     -0.49999999999997496, -0.49999999999997496, 0.5000000000000249, 0.49999999999997496,
     -0.49999999999997496, -0.49999999999997496, 0.5000000000000249, 0.49999999999997496,
     -0.49999999999997496, -0.49999999999997496, 0.5000000000000249, 0.49999999999997496],
    [0.707106781186583, 0.707106781186583, 0.7071067811865124, 0.707106781186583,
     0.707106781186583, 0.707106781186583, 0.7071067811865124, 0.707106781186583,
     0.707106781186583, 0.707106781186583, 0.7071067811865124, 0.707106781186583,
     0.707106781186583, 0.707106781186583, 0.7071067811865124, 0.707106781186583],
    [0.07571067811865856, 0.07571067811865098, -0.07571067811865098, -0.07571067811865856,
     -0.20713203435597466, -0.20713203435595398, -0.35855339059328417, -0.3585533905932918,
     0.07571067811865856, 0.07571067811865098, -0.07571067811865098, -0.07571067811865856,
     0.3585533905932918, 0.35855339059325597, 0.20713203435598224, 0.20713203435597466],
    [0.13642135623731638, 0.2878427124746047, 0.2878427124746335, 0.13642135623732396,
     -0.14642135623731686, 0.004999999999999741, 0.005000000000000254, -0.14642135623730929,
     -0.14642135623731686, 0.004999999999999741, 0.005000000000000254, -0.14642135623730929,
     -0.14642135623731686, 0.004999999999999741, 0.005000000000000254, -0.14642135623730929],
    [0.057071067811862636, 0.24292893218812237, -0.24292893218812237, -0.057071067811862636,
     0.057071067811862636, -0.15707106781187757, -0.24292893218814232, 0.3429289321881373,
     -0.14292893218812736, 0.04292893218813237, -0.04292893218813237, 0.14292893218812736,
     -0.3429289321881174, 0.24292893218814232, 0.15707106781187757, -0.05707106781188259],
])
REVIEWED_W = np.array([
    [0.4483639224642979, 0.19009496934344688, 5.239103641390898,
     0.3739181695049424, 0.08832923062297451, 0.10211573191336572],
    [-2.4950000000000743, -1.4969999999997254, 7.773931952365012,
     0.5089547973369478, 0.44836554057449696, -0.42792922297125335],
])
# fmt: on
"""A (within 4e-14 of the T-shape [(0, 1), (1, 0), (1, 1), (1, 2)]'s) and two planted
wrenches, written with repr: the walk once measured the second at gamma 1.00035 (true 0.998)
when batched with the first."""


def walked(z: Zonotope, W: np.ndarray) -> np.ndarray:
    """The compiled walk's gammas alone (nan where it gives up and the LP would answer)."""
    R, off = z.reduce(W)
    assert not off.any()
    G, P, k = kernels.walk_view(z)
    out = np.empty(len(W))
    R = np.ascontiguousarray(R * k)
    kernels.gamma_rows(G, P, kernels.prepare(G, P), R, np.inf, out, np.empty((0, z.rank)))
    return out


def assert_within(gamma: np.ndarray, ref: np.ndarray, tol: float, what) -> None:
    err = np.abs(gamma - ref) / np.maximum(1.0, ref)
    assert err.max(initial=0.0) <= tol, (what, err.max(), gamma[np.argmax(err)])


def test_the_reviewed_matrix_batched_and_alone():
    """Each wrench's gamma is the reference's to the walk's accuracy, batched or alone, cold,
    warm-started and as the public margin; the walk answers every row itself."""
    A, W = REVIEWED_A, REVIEWED_W
    T = mq.Structure([(0, 1), (1, 0), (1, 1), (1, 2)]).configuration_matrix()
    assert 0 < np.abs(A - T).max() <= 4e-14
    ref = np.array([gamma_reference(A, w, 1.0) for w in W])
    z = Zonotope(A)
    start = gamma_capped_from(Zonotope(T), W, CAP)[1]  # the unperturbed structure's optima
    for rows in ([0, 1], [1], [0]):
        what = f"rows {rows}"
        got = walked(z, W[rows])
        assert np.isfinite(got).all(), what
        assert_within(got, ref[rows], ACCURACY, what)
        assert_within(gamma_with(z, W[rows], "compiled"), ref[rows], ACCURACY, what)
        assert_within(1.0 - margin(A, W[rows], method="compiled"), ref[rows], ACCURACY, what)
        warm = gamma_capped_from(z, W[rows], CAP, (start[0][rows], start[1][rows]))[0]
        assert_within(warm, ref[rows], ACCURACY, what)


def perturbed_module(rng) -> mq.ModuleType:
    """A T-module whose columns and directions are each multiplied by 1 +- U(1e-14, 5e-14)."""
    module = mq.TModule()
    for name in ("columns", "directions"):
        a = getattr(module, name)
        a = a * (1.0 + rng.uniform(1e-14, 5e-14, a.shape) * rng.choice([-1.0, 1.0], a.shape))
        a.setflags(write=False)
        object.__setattr__(module, name, a)  # the stored data, as another machine computes it
    return module


def test_perturbed_lattice_structures_against_the_reference():
    """Seeded sweep: planted structures of 3 and 4 modules (the lattice's most degenerate
    facets), their wrenches on faces and vertices, the module data perturbed entry by entry;
    cold and warm-started (at the unperturbed structure's optima) gammas against the
    reference."""
    planted = PlantedTasks(n_modules=(3, 4), n_wrenches=(8, 8), boundary_fraction=1.0,
                           p_extreme=1.0)  # fmt: skip
    walks = answered = 0
    for seed in range(SWEEP):
        rng = np.random.default_rng(seed)
        task = planted(rng)
        cells = [tuple(c) for c in task.meta["planted_cells"]]
        A = mq.Structure(cells, module=perturbed_module(rng)).configuration_matrix()
        W, z = task.wrenches, Zonotope(A)
        ref = np.array([gamma_reference(A, w, 1.0) for w in W])
        cold = walked(z, W)
        done = np.isfinite(cold)
        assert_within(cold[done], ref[done], ACCURACY, seed)
        assert_within(gamma_with(z, W, "compiled"), ref, BAND, seed)
        start = gamma_capped_from(Zonotope(mq.Structure(cells).configuration_matrix()), W, CAP)
        warm, (tights, _) = gamma_capped_from(z, W, CAP, start[1])
        optimum = tights[:, 0] >= 0  # the walk's own answer (else the LP's, or past the cap)
        assert_within(warm[optimum], ref[optimum], ACCURACY, seed)
        assert_within(warm[ref <= CAP], ref[ref <= CAP], BAND, seed)
        walks += 2 * len(W)
        answered += np.count_nonzero(done) + np.count_nonzero(optimum)
    assert answered >= 0.95 * walks, answered / walks


@pytest.mark.parametrize(
    "cells", [[(0, 0)], [(0, 0), (1, 0), (2, 0)], [(0, 0), (1, 0), (0, 1), (1, 1)]]
)
def test_the_walk_reaches_the_optimum_on_degenerate_facets(cells):
    """Wrenches of known gamma on one module (rank 4), a line (rank 5) and a 2 x 2 (their
    facets hold many rotors; directions rounded to integers for every third): the walk
    answers every one itself (no LP), within 2e-13 (``results/oracle_accuracy.md``; 2x
    headroom here for other CPUs' round-off)."""
    A = mq.Structure(cells).configuration_matrix()
    W, s = known_gammas(A, np.random.default_rng(0), 60)
    got = walked(Zonotope(A), W)
    assert np.isfinite(got).all(), np.count_nonzero(np.isnan(got))
    assert np.abs(got - s).max() <= 4e-13


SWEEP = 150
"""Structures in the sweep (8 wrenches each)."""
