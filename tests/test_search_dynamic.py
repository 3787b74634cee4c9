"""Searches on dynamic tasks (wrenches that depend on the structure's mass and inertia): the
certified minimum checked by an independent LP (scipy's HiGHS) against Newton-Euler wrenches,
lower bounds that never exceed the optimum, and the cache's soundness with inertia terms."""

import numpy as np
import pytest
import scipy.sparse as sp
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.optimize import linprog

import modquad_gym as mq
from modquad_gym import dynamics as dy
from modquad_gym.geometry.inertia import inertia_vectors, to_vector
from modquad_gym.geometry.module import palette
from modquad_gym.geometry.structure import structure_levels
from modquad_gym.search import SEARCHES, SearchProblem, bound_levels, exhaustive_search
from modquad_gym.search.dynamic import DynamicValues, inertia_box

T45_FLAT = palette("t45,flat")


def lp_feasible(s: mq.Structure, task: dy.DynamicTask) -> bool:
    """Independent check: one HiGHS LP over every sample (block-diagonal A u_i = w_i,
    0 <= u <= f_max), with w_i from Newton-Euler (required_wrenches) plus the exerted ones."""
    W = mq.required_wrenches(s, task.trajectory, task.payload)
    if task.exerted is not None:
        W = W + task.exerted
    W = np.unique(np.round(W, 12), axis=0)
    A, k = s.configuration_matrix(), len(W)
    Aeq = sp.block_diag([sp.csr_matrix(A)] * k, format="csr")
    res = linprog(
        np.zeros(A.shape[1] * k), A_eq=Aeq, b_eq=W.ravel(), bounds=(0, task.f_max), method="highs"
    )
    assert res.status in (0, 2), res.message
    return res.status == 0


def structures(n_max: int, modules=None):
    """Every structure of up to n_max modules (every type assignment with ``modules``)."""
    import itertools

    for level in structure_levels(n_max):
        for key in level:
            if modules is None:
                yield mq.Structure(list(key))
                continue
            for types in itertools.product(modules, repeat=len(key)):
                yield mq.Structure(list(key), modules=list(types))


def random_task(seed: int) -> dy.DynamicTask:
    """A small dynamic task: a random motion, speed, payload (mass and offset) and f_max,
    sampled at 10 Hz (closed-form derivatives)."""
    rng = np.random.default_rng(seed)
    payload = None
    if rng.uniform() < 0.6:
        offset = tuple(rng.uniform(-0.2, 0.2, 3))
        payload = dy.Payload(float(rng.uniform(0.0, 1.0)), offset)
    common = dict(f_max=float(rng.choice([2.0, 2.5])), payload=payload, rate=10.0)
    kind = rng.choice(["hover", "line", "circle", "figure_eight", "push"])
    speed = float(rng.uniform(0.5, 2.5))
    if kind == "hover":
        return dy.hover(**common)
    if kind == "line":
        return dy.line(1.0, max_acceleration=speed, **common)
    if kind == "circle":
        heading = str(rng.choice(["fixed", "tangent"]))
        radius = float(rng.uniform(0.5, 1.5))
        return dy.circle(radius=radius, speed=speed, heading=heading, **common)
    if kind == "figure_eight":
        return dy.figure_eight(size=1.0, speed=speed, **common)
    return dy.push(distance=1.0, speed=0.5, force=float(rng.uniform(0.5, 4.0)), **common)


# --------------------------------------------------------------------------- the problem value
def test_dynamic_problem_and_rotor_wrenches():
    task = dy.circle(speed=1.5, heading="tangent", payload=dy.Payload(0.2, (0.1, 0.0, -0.1)))
    p = SearchProblem.build(task, n_max=5)
    assert p.kind == "dynamic" and not p.shape_only and p.model is not None
    s = mq.Structure([(0, 0), (1, 0), (1, 1)])
    direct = mq.required_wrenches(s, task.trajectory, task.payload)
    got = p.rotor_wrenches(s)
    assert np.abs(got[:, None, :] - direct[None]).max(axis=2).min(axis=1).max() < 1e-12
    assert len(got) < len(direct)  # the hover holds are kept once
    with pytest.raises(ValueError, match="inertia"):
        p.rotor_wrenches(s.mass)  # the yawing circle needs the inertia
    with pytest.raises(ValueError, match="kind"):
        SearchProblem.build(task, kind="external")
    assert SearchProblem.build(task, f_max=3.0).f_max == 3.0


def test_a_payload_no_structure_can_lift_is_refused_before_work():
    with pytest.raises(ValueError, match=r"^payload\.mass: 1000 kg is more than any") as info:
        exhaustive_search(dy.hover(payload=1000.0), n_max=8)
    assert "\n" not in str(info.value)


# --------------------------------------------------------------------------- certified minimum
@pytest.mark.parametrize(
    "task, optimum",
    [
        (dy.hover(payload=dy.Payload(1.8, (0.1, 0.0, -0.1)), rate=10), 8),
        (dy.circle(speed=2.0, heading="tangent", rate=10), 3),
        (dy.figure_eight(payload=0.6, rate=10), 4),
        (dy.push(force=4.0, rate=10), None),
    ],
)
def test_certified_minimum_agrees_with_an_independent_lp(task, optimum):
    """The exhaustive search's structure is LP-feasible and every structure with fewer modules
    is LP-infeasible (brute force, up to 8 modules)."""
    r = exhaustive_search(task, n_max=8)
    assert r.certified
    if optimum is not None:
        assert r.n_modules == optimum
    assert lp_feasible(r.structure, task)
    for s in structures(r.n_modules - 1):
        assert not lp_feasible(s, task), s.cells


@settings(max_examples=15, deadline=None)
@given(st.integers(0, 10**6), st.booleans())
def test_no_lower_bound_exceeds_the_certified_optimum_of_dynamic_tasks(seed, mixed):
    """On 15 small dynamic tasks per run (one type up to 5 modules, two types up to 3): the
    exhaustive optimum is confirmed by brute force with the independent LP, and no search's
    lower bound (nor bound_levels) exceeds it (where no structure of up to n_max works, the
    exhaustive search's bound: checked in tests/test_bounds_oracle_rule.py)."""
    task = random_task(seed)
    modules, n_max = (T45_FLAT, 3) if mixed else (None, 5)
    try:
        exact = exhaustive_search(task, n_max=n_max, modules=modules)
    except ValueError as exc:  # a payload beyond 64 modules: refused before work
        assert str(exc).startswith(("payload.mass", "exerted", "f_max"))
        return
    optimum = exact.lower_bound  # where none of up to n_max works: the strongest bound proved
    assert exact.certified and exact.n_modules in (None, optimum) and optimum >= 1
    for s in structures(min(optimum, n_max), modules):
        if s.n_modules < optimum:
            assert not lp_feasible(s, task), s.cells
    if exact.structure is not None:
        assert lp_feasible(exact.structure, task)
    assert bound_levels(SearchProblem.build(task, n_max, modules=modules)) <= optimum
    for name, search in SEARCHES.items():
        r = search(task, n_max=n_max, modules=modules)
        assert r.lower_bound <= optimum, name
        if r.structure is not None:
            assert r.n_modules >= optimum and lp_feasible(r.structure, task), name


# --------------------------------------------------------------------------- soundness pieces
def test_inertia_box_holds_every_structure():
    for n in range(1, 7):
        for level in [list(structure_levels(n))[-1]]:
            cells = np.array([list(k) for k in level])
            for types in (np.zeros(cells.shape[:2], dtype=int), (cells[..., 0] % 2)):
                masses, j = inertia_vectors(cells, types, T45_FLAT)
                for M in np.unique(masses):
                    lo, hi = inertia_box(T45_FLAT, n, M)
                    sel = j[masses == M]
                    assert np.all(sel >= lo - 1e-12) and np.all(sel <= hi + 1e-12)


def test_dynamic_values_are_lower_bounds_of_the_true_values():
    task = dy.circle(speed=2.0, heading="tangent", payload=dy.Payload(0.3, (0.1, 0.1, 0.0)))
    values = DynamicValues(task.wrench_model, [mq.TModule()])
    D = np.random.default_rng(0).normal(size=(40, 6))
    for key in list(structure_levels(4))[-1]:
        s = mq.Structure(list(key))
        true = (D @ task.rotor_wrenches(s).T).max(axis=1)
        assert np.all(values.values(D, s.mass, 4) <= true + 1e-9)
        np.testing.assert_allclose(
            values.wrenches(s.mass, to_vector(s.inertia)),
            values.model.at(s.mass, s.inertia),
        )
