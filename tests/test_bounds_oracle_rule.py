"""The searches' bounds grant what the oracle's tolerance rule grants (a fifth review: each case
was certified wrong before): the off-range allowance ``RESIDUAL_TOL (f_max + |w|)`` in the force,
count and level bounds, the thrust band ``[-TOL/2, 1 + TOL/2] f_max`` in the force bound, and
f_max's scale everywhere. Each answer is checked against the oracle on a concrete structure."""

from __future__ import annotations

import math

import numpy as np
import pytest

import modquad_gym as mq
from modquad_gym.geometry.module import STOCK_TYPES, ModuleType
from modquad_gym.oracle import TOL, feasible
from modquad_gym.search import SEARCHES, SearchProblem, force_lower_bound

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
