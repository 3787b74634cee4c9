"""The searches' bounds grant what the oracle's tolerance rule grants (a fifth review: each case
was certified wrong before): the off-range allowance ``RESIDUAL_TOL (f_max + |w|)`` in the force,
count and level bounds and the cached directions' test, the thrust band ``[-TOL/2, 1 + TOL/2]
f_max`` in the force bound, and f_max's scale everywhere. Each answer is checked against the
oracle on a concrete structure."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import modquad_gym as mq
from modquad_gym import proofcheck_shapes as pcs
from modquad_gym.dynamics import DynamicTask, LinearWrenches
from modquad_gym.dynamics.trajectory import Trajectory
from modquad_gym.geometry.inertia import inertia_vectors
from modquad_gym.geometry.module import STOCK_TYPES, ModuleType
from modquad_gym.geometry.polyominoes import level_chunks
from modquad_gym.oracle import TOL, feasible
from modquad_gym.oracle.tolerance import RESIDUAL_TOL
from modquad_gym.search import SEARCHES, SearchProblem, bound_levels, force_lower_bound
from modquad_gym.search.beyond import bound_beyond
from modquad_gym.search.checker import TaskChecker
from modquad_gym.search.dynamic import off_range_grant

FLAT0 = ModuleType.from_tilts((0, 0, 0, 0), name="flat0", c_tau=0.0)  # no yaw at all
FLAT0_HEAVY = ModuleType.from_tilts((0, 0, 0, 0), name="flat0h", c_tau=0.0, mass=0.5)


def one_module_suffices(problem: SearchProblem, module: ModuleType) -> None:
    """The oracle accepts one module, and every exact search says so, certified."""
    assert problem.decide(mq.Structure([(0, 0)], modules=[module])).all()
    for name in ("exhaustive", "anytime", "milp"):
        r = SEARCHES[name](problem)
        assert (r.n_modules, r.lower_bound, r.certified) == (1, 1, True), name


@pytest.mark.parametrize("f_max", [1.0, 1e3])
def test_the_count_bound_grants_the_off_range_allowance_at_any_f_max(f_max):
    """A force of 1e-10 f_max along x, off the reach of flat modules: within the oracle's
    allowance at every f_max (the count bound's slack was 1e-9 (1 + ...), not (f_max + ...))."""
    heavy = ModuleType.from_tilts((0, 0, 0, 0), name="flat2", mass=0.5)
    W = np.array([[1e-10, 0, 1e-3, 0, 0, 0]]) * f_max
    flat = STOCK_TYPES["flat"]
    one_module_suffices(SearchProblem(W, n_max=3, f_max=f_max, modules=[flat, heavy]), flat)


@pytest.mark.parametrize("typed", [True, False])
def test_the_level_bounds_grant_the_off_range_allowance(typed):
    """A yaw of 1e-10, which no flat module without drag exerts (the typed level bounds
    granted nothing)."""
    if typed:
        problem = SearchProblem(np.array([[0, 0, 1.0, 0, 0, 1e-10]]), n_max=3,
                                modules=[FLAT0, FLAT0_HEAVY])  # fmt: skip
    else:
        problem = SearchProblem(np.array([[0, 0, 0, 0, 0, 1e-10]]), n_max=3, module=FLAT0,
                                kind="external")  # fmt: skip
    one_module_suffices(problem, FLAT0)


def test_the_force_bound_grants_the_thrust_band():
    """Three T-modules with every rotor at (1 + 0.4 TOL) f_max, inside the oracle's band: the
    force bound's ceil(worst - TOL) asked for 4 from 3 modules on (n (1 + TOL / 2) reach)."""
    W = np.array([[0, 0, 3 * 4 * math.cos(math.pi / 4) * (1 + 0.4 * TOL), 0, 0, 0]])
    line = mq.Structure([(0, 0), (1, 0), (2, 0)])
    assert feasible(line.configuration_matrix(), W, 1.0, method="daqp").all()
    assert force_lower_bound(W, line.module, 1.0) == 3
    for name in ("exhaustive", "anytime", "milp"):
        assert SEARCHES[name](W, n_max=5).n_modules == 3, name


@pytest.mark.parametrize("f_max", [1e-20, 1e-13, 1e12])
def test_a_task_scaled_with_f_max_has_the_same_answer(f_max):
    """The force bound's 'no support' test compared an absolute 1e-12 with supports in units of
    f_max: below it every task was 'proved' impossible."""
    W = np.array([[0.3, 0.2, 5.0, 0.1, -0.1, 0.05]])
    plain = mq.exhaustive_search(W, n_max=5)
    scaled = mq.exhaustive_search(W * f_max, n_max=5, f_max=f_max)
    assert (scaled.n_modules, scaled.lower_bound) == (plain.n_modules, plain.lower_bound) == (3, 3)


def smallest_by_the_oracle(problem: SearchProblem, n_max: int) -> int:
    """The least module count of a structure the oracle accepts (every structure of up to
    ``n_max`` modules of the problem's palette), n_max + 1 when none."""
    palette = list(problem.palette)
    rotors = palette[0].n_rotors
    for n in range(1, n_max + 1):
        for _, cells, types in pcs.structures(n, len(palette), rotors):
            for c, t in zip(cells.tolist(), types.tolist()):
                s = mq.Structure([tuple(x) for x in c], modules=[palette[k] for k in t])
                if problem.decide(s).all():
                    return n
    return n_max + 1


@settings(max_examples=60, deadline=None)
@given(
    names=st.sampled_from([("t45",), ("flat",), ("t45", "flat"), ("t45", "t45m", "flat")]),
    size=st.integers(1, 3),
    seed=st.integers(0, 2**16),
    stretch=st.sampled_from([1 - 1e-7, 1.0, 1 + 3e-7, 1 + 2e-6]),
    off=st.sampled_from([0.0, 1e-11, 5e-10, 1e-8]),
    f_max=st.sampled_from([1e-6, 1.0, 1e4]),
    kind=st.sampled_from(["total", "external"]),
    fault=st.sampled_from([None, None, "rotor", "module"]),
)
def test_no_bound_exceeds_the_oracles_smallest_structure(names, size, seed, stretch, off, f_max,
                                                         kind, fault):  # fmt: skip
    """The exact bounds every search starts from (force, count, level; one type and palettes),
    and those an infeasible answer proves past a smaller n_max (modquad_gym.search.beyond),
    never exceed the least size of a structure the oracle accepts, for wrenches a random
    structure exerts at its thrust box's edge, stretched across the tolerance band, pushed off
    its range by up to 1e-8, at any f_max, with or without a failure to survive."""
    rng = np.random.default_rng(seed)
    palette = [STOCK_TYPES[n] for n in names]
    cells = [(0, 0)]
    while len(cells) < size:  # a random connected shape
        x, y = cells[rng.integers(len(cells))]
        step = [(x + 1, y), (x - 1, y), (x, y + 1), (x, y - 1)][rng.integers(4)]
        cells += [step] if step not in cells else []
    hidden = mq.Structure(
        cells, modules=[palette[k] for k in rng.integers(len(palette), size=size)]
    )
    A = hidden.configuration_matrix()
    u = np.where(rng.random((2, A.shape[1])) < 0.5, 1.0, rng.random((2, A.shape[1])))
    W = f_max * (u @ A.T) * stretch + off * f_max * rng.normal(size=(2, 6))
    if kind == "external":  # the same rotor wrenches: the weight of the hidden structure out
        W[:, 2] -= 9.81 * hidden.mass
    problem = SearchProblem(W, n_max=3, f_max=f_max, modules=palette, kind=kind, fault=fault)
    smallest = smallest_by_the_oracle(problem, 3)
    assert bound_levels(problem) <= smallest
    for n_max in range(1, smallest if smallest <= 3 else 1):  # levels to n_max ruled out
        below = SearchProblem(W, n_max=n_max, f_max=f_max, modules=palette, kind=kind, fault=fault)
        assert bound_beyond(below, n_max + 1) <= smallest


def flat_model(kind: str, f_max: float, x_off: float):
    """A one-wrench model a FLAT0 module meets with its rotors at 3/4 f_max, plus a force
    ``x_off`` along x that no flat module exerts (its support along x is 0): of kind total (no
    weight), external (its weight) or dynamic (its weight and an inertia term in roll: the
    searches group its structures by mass)."""
    per_mass = np.zeros((1, 6))
    per_inertia = np.zeros((1, 6, 6))
    base = np.array([[x_off, 0, 3 * f_max, 0, 0, 0]])
    if kind != "total":
        per_mass[0, 2] = 9.81
        base[0, 2] -= 9.81 * FLAT0.mass
    if kind == "dynamic":
        per_inertia[0, 3, 0] = 1e-3  # a roll torque per unit Jxx, which flat modules exert
    return LinearWrenches(base, per_mass, per_inertia)


@pytest.mark.parametrize("kind", ["total", "external", "dynamic"])
@pytest.mark.parametrize("f_max", [1.0, 1e3])
def test_a_cached_direction_grants_the_off_range_allowance(kind, f_max):
    """A separating direction the searches learnt along x does not rule out a flat module
    whose only x force is within the oracle's off-range grant (the cache test granted an
    absolute 1e-12, the oracle 1e-9 (f_max + |w|))."""
    one = mq.Structure([(0, 0)], modules=[FLAT0])
    size = np.linalg.norm(flat_model(kind, f_max, 0.0).at(one.mass, one.inertia), axis=1)[0]
    model = flat_model(kind, f_max, 0.8 * RESIDUAL_TOL * (f_max + size))
    W = model.at(one.mass, one.inertia if model.uses_inertia else None)
    assert feasible(one.configuration_matrix(), W, f_max).all()  # the oracle's verdict
    checker = TaskChecker(model, f_max, FLAT0)
    checker.adopt(np.eye(6)[[0, 2]])  # learnt directions: +x, +z
    assert checker.alive(np.zeros((1, 1, 2), dtype=np.int32))[0]
    assert checker.check(one)
    far = TaskChecker(flat_model(kind, f_max, 3 * RESIDUAL_TOL * (f_max + size)), f_max, FLAT0)
    far.adopt(np.eye(6)[[0]])
    assert not far.alive(np.zeros((1, 1, 2), dtype=np.int32))[0]  # beyond the grant: ruled out


@settings(max_examples=20, deadline=None)
@given(seed=st.integers(0, 2**31 - 1), n=st.integers(1, 4), f_max=st.sampled_from([1e-3, 1.0, 1e3]))
def test_the_grant_covers_every_structures_wrench(seed, n, f_max):
    """The cache's and the typed level bounds' off-range grant (one number per mass and module
    count) is at least the oracle's ``RESIDUAL_TOL (f_max + |w(S)|)`` for every wrench of every
    n-module structure S of that mass, its inertia terms included (they were left out)."""
    rng = np.random.default_rng(seed)
    k = 3
    per_inertia = np.zeros((k, 6, 6))
    per_inertia[:, 3:, :] = rng.normal(size=(k, 3, 6)) * 10.0 ** rng.uniform(-2, 3)
    per_mass = np.zeros((k, 6))
    per_mass[:, :3] = rng.normal(size=(k, 3)) * 10
    model = LinearWrenches(rng.normal(size=(k, 6)) * f_max, per_mass, per_inertia)
    palette = [FLAT0, FLAT0_HEAVY]
    for cells in level_chunks(n):
        types = rng.integers(0, 2, size=cells.shape[:2])
        masses, inertias = inertia_vectors(cells, types, palette)
        for mass, j in zip(masses, inertias):
            sizes = np.linalg.norm(model.at(mass, j), axis=1)
            grant = off_range_grant(model, palette, f_max, n, float(mass))
            assert grant >= RESIDUAL_TOL * (f_max + sizes.max()) * (1 - 1e-12)


@pytest.mark.parametrize("axis", [0, 5])  # x: the count bound's direction; yaw: a level's
def test_the_bounds_grant_counts_a_dynamic_tasks_inertia_terms(axis):
    """A roll acceleration whose torque (Jxx times 5 rad/s^2, about 2 N m) makes |w| larger
    than its base and weight, and a force along x or a yaw off a FLAT0 module's reach by
    between the grant without and with that torque: the oracle accepts one module, and the
    count and level bounds granted only the smaller (all three searches certified 2)."""
    big = ModuleType.from_tilts((0, 0, 0, 0), name="flat0big", c_tau=0.0, side=4.0)
    spin = np.zeros((2, 3))
    spin[:, 0] = 5.0
    motion = Trajectory(np.array([0.0, 1.0]), np.zeros((2, 3)), angular_velocity=np.zeros((2, 3)),
                        angular_acceleration=spin)  # fmt: skip
    one = mq.Structure([(0, 0)], modules=[big])
    w = DynamicTask(motion, f_max=2.0).rotor_wrenches(one)[0]
    without = RESIDUAL_TOL * (2.0 + np.linalg.norm(w - np.array([0, 0, 0, w[3], 0, 0])))
    exerted = np.zeros((2, 6))
    exerted[:, axis] = (without + RESIDUAL_TOL * (2.0 + np.linalg.norm(w))) / 2
    problem = SearchProblem(DynamicTask(motion, exerted=exerted, f_max=2.0), n_max=2, module=big)
    one_module_suffices(problem, big)


@pytest.mark.parametrize("scale", [1.0, 5e-14])
def test_a_dynamic_task_scaled_down_keeps_its_samples(scale):
    """A hover whose last sample asks 8 N more lift, every force and mass scaled by ``scale``:
    the same certified 3 modules at both scales (the samples were merged by rounding to 12
    decimals, so the scaled task lost its hard sample and three searches certified 1)."""
    t = STOCK_TYPES["t45"]
    module = ModuleType(t.positions, t.directions, t.spins, side=t.side, c_tau=t.c_tau,
                        name="t", mass=0.3 * scale)  # fmt: skip
    exerted = np.zeros((3, 6))
    exerted[2, 2] = 8.0 * scale
    hover = Trajectory(np.array([0.0, 1.0, 2.0]), np.zeros((3, 3)))
    task = DynamicTask(hover, exerted=exerted, f_max=2.0 * scale)
    problem = SearchProblem(task, n_max=4, module=module)
    for name in ("exhaustive", "anytime", "milp"):
        r = SEARCHES[name](problem)
        assert (r.n_modules, r.lower_bound, r.certified) == (3, 3, True), name
        W = task.rotor_wrenches(r.structure)
        assert feasible(r.structure.configuration_matrix(), W, task.f_max).all()


def test_types_that_weigh_differently_stay_two_at_any_scale():
    """Masses of 3e-14 and 1e-14 kg (a palette scaled down) are two types, not copies (the
    digest rounded the mass to 12 decimals: both were 0, and the lighter was dropped)."""
    heavy, light = (ModuleType.from_tilts((0, 0, 0, 0), name=n, mass=m) for n, m in
                    (("heavy", 3e-14), ("light", 1e-14)))  # fmt: skip
    assert heavy.digest != light.digest
    problem = SearchProblem(np.array([[0, 0, 1.0, 0, 0, 0]]), modules=[heavy, light])
    assert [m.name for m in problem.palette] == ["heavy", "light"]
    copy = ModuleType.from_tilts((0, 0, 0, 0), name="again", mass=3e-14)
    assert copy.digest == heavy.digest  # copies of one type are still one
