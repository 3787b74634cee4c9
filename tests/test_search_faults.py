"""Fault-tolerant searches (issue 37): every search takes ``fault=``, the exhaustive answer is
the certified minimum tolerant structure (checked by enumerating every smaller structure), and
no lower bound exceeds it."""

from __future__ import annotations

import json

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import modquad_gym as mq
from modquad_gym import cli
from modquad_gym.geometry.module import palette
from modquad_gym.geometry.polyominoes import PolyominoStream
from modquad_gym.search import SearchProblem, beam_search, bound_levels, genetic_search
from modquad_gym.tasks import TaskRequirement

SCREWDRIVER = TaskRequirement.load("examples/screwdriver.json")


def structures(n: int):
    for chunk in PolyominoStream(n, 1 << 12):
        for cells in chunk.tolist():
            yield mq.Structure([tuple(c) for c in cells])


def planted_task(n: int, seed: int, scale: float = 0.5) -> np.ndarray:
    """Wrenches a random n-module structure exerts at ``scale`` of random allocations."""
    rng = np.random.default_rng(seed)
    shapes = list(structures(n))
    s = shapes[rng.integers(len(shapes))]
    A = s.configuration_matrix()
    return scale * (rng.uniform(0, 1, (3, A.shape[1])) @ A.T)


def assert_minimum_tolerant(W, f_max, fault, result):
    """The answer tolerates the task (by an LP per failure), and no structure of fewer modules
    does (every one enumerated)."""
    s = result.structure
    assert s is not None and result.certified and result.lower_bound == s.n_modules
    assert mq.tolerates(s, W, f_max, fault=fault, method="daqp").all()
    for n in range(1, s.n_modules):
        for smaller in structures(n):
            assert not mq.tolerates(smaller, W, f_max, fault=fault, method="daqp").all(), smaller


@pytest.mark.parametrize("fault, expected", [("rotor", 4), ("module", 5)])
def test_screwdriver_certified_minimum_tolerant(fault, expected):
    r = mq.exhaustive_search(SCREWDRIVER, n_max=7, fault=fault)
    assert r.n_modules == expected and r.fault == fault
    assert r.to_dict()["fault"] == fault
    assert_minimum_tolerant(SCREWDRIVER.wrenches, SCREWDRIVER.f_max, fault, r)
    g = genetic_search(SCREWDRIVER, n_max=7, fault=fault, time_limit=2.0)
    assert g.structure is None or g.n_modules >= expected
    assert g.structure is None or mq.tolerates(g.structure, SCREWDRIVER.wrenches, fault=fault).all()


@settings(max_examples=6, deadline=None, derandomize=True,
          suppress_health_check=[HealthCheck.too_slow])  # fmt: skip
@given(n=st.integers(1, 3), seed=st.integers(0, 10_000), fault=st.sampled_from(["rotor", "module"]))
def test_exhaustive_is_the_minimum_and_bounds_never_exceed_it(n, seed, fault):
    W = planted_task(n, seed)
    r = mq.exhaustive_search(W, n_max=6, fault=fault)
    if r.structure is None:  # nothing of up to 6 modules tolerates it: every level refuted
        assert r.lower_bound == 7
        return
    assert_minimum_tolerant(W, 1.0, fault, r)
    problem = SearchProblem.build(W, 6, fault=fault)
    assert bound_levels(problem) <= r.n_modules
    intact = mq.exhaustive_search(W, n_max=6)
    assert intact.n_modules <= r.n_modules  # a tolerant structure is feasible
    for search in (mq.anytime_search, mq.greedy_search, mq.centrosymmetric_search,
                   beam_search, mq.random_search):  # fmt: skip
        q = search(W, n_max=6, fault=fault)
        assert q.lower_bound <= r.n_modules
        if q.structure is not None:
            assert q.n_modules >= r.n_modules
            assert mq.tolerates(q.structure, W, fault=fault, method="daqp").all()


def test_fault_force_bounds_are_sound_and_stronger():
    """Lift near a multiple of one module's: the fault bounds add what a failure takes."""
    lift = np.array([[0, 0, 3.2, 0, 0, 0]])
    n0 = mq.search.force_lower_bound(lift, mq.TModule())
    nr = mq.search.force_lower_bound(lift, mq.TModule(), fault="rotor")
    nm = mq.search.force_lower_bound(lift, mq.TModule(), fault="module")
    assert n0 <= nr <= nm and nm == n0 + 1
    for fault, bound in (("rotor", nr), ("module", nm)):
        r = mq.exhaustive_search(lift, n_max=8, fault=fault)
        assert r.certified and bound <= r.n_modules


def test_typed_external_and_dynamic_tasks_take_a_fault():
    mixed = palette("t45,t30")
    W = planted_task(2, 3, 0.4)
    r = mq.exhaustive_search(W, n_max=5, modules=mixed, fault="rotor")
    assert r.structure is not None and r.certified
    assert mq.tolerates(r.structure, W, fault="rotor", method="daqp").all()
    ext = TaskRequirement(np.array([[0.0, 0, 1.0, 0, 0, 0]]), f_max=2.0, kind="external")
    r = mq.exhaustive_search(ext, n_max=6, fault="module")
    W = ext.rotor_wrenches(r.structure)  # the failed module's weight is still carried
    assert mq.tolerates(r.structure, W, 2.0, fault="module", method="daqp").all()
    intact = mq.exhaustive_search(ext, n_max=6)
    assert r.n_modules > intact.n_modules
    circle = mq.dynamics.circle(radius=1.0, speed=1.0, payload=0.1)
    d = mq.exhaustive_search(circle, n_max=8, fault="rotor")
    W = circle.rotor_wrenches(d.structure)
    assert d.certified and mq.tolerates(d.structure, W, circle.f_max, fault="rotor").all()
    assert d.n_modules >= mq.exhaustive_search(circle, n_max=8).n_modules


def test_no_tolerant_structure_is_an_answer_not_an_error():
    heavy = np.array([[0, 0, 6.5, 0, 0, 0]])  # 3 modules lift it, 3 less a module cannot
    r = mq.exhaustive_search(heavy, n_max=3, fault="module")
    assert r.structure is None and r.certified and r.lower_bound == 4


def test_bad_fault_is_refused():
    with pytest.raises(ValueError, match="fault must be one of"):
        mq.exhaustive_search(SCREWDRIVER, n_max=4, fault="propeller")


def test_cli_fault_json_and_refusals(capsys):
    code = cli.main(["solve", "--task", "examples/screwdriver.json", "--fault", "rotor",
                     "--json"])  # fmt: skip
    out = json.loads(capsys.readouterr().out)
    assert code == 0 and out["fault"] == "rotor" and out["n_modules"] == 4
    assert out["certified"] and out["worst_fault_margin"] >= 0
    code = cli.main(["solve", "--task", "examples/screwdriver.json", "--fault", "rotor",
                     "--method", "milp"])  # fmt: skip
    err = capsys.readouterr().err
    assert code == 2 and err.count("\n") == 1 and "fault='rotor'" in err and "milp" in err
    code = cli.main(["solve", "--task", "example:screwdriver", "--n-max", "2", "--fault",
                     "module", "--json"])  # fmt: skip
    out = json.loads(capsys.readouterr().out)
    assert code == 0 and out["cells"] is None and out["worst_fault_margin"] is None
