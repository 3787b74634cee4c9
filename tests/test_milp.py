"""The MILP peer (issue 35): the same optimum as the exhaustive search, a relaxation bound that
never exceeds it, the window, the inertia terms, the CLI, and what it refuses."""

from __future__ import annotations

import json
import os
import sys
import time

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from scipy.optimize import Bounds

import modquad_gym as mq
import modquad_gym.dynamics as dy
from modquad_gym.cli import main
from modquad_gym.geometry.cells import free_neighbours, structure_levels
from modquad_gym.geometry.inertia import to_vector
from modquad_gym.geometry.module import palette
from modquad_gym.search import SEARCHES, SearchProblem, bound_levels, exhaustive_search, milp_worker
from modquad_gym.search import milp_program as milp_module
from modquad_gym.search.milp import milp_lower_bound, milp_search
from modquad_gym.search.milp_program import inertia_terms, window
from modquad_gym.tasks import PlantedTasks, TaskRequirement, generated_task, make_generator

SCREWDRIVER = TaskRequirement.load("examples/screwdriver.json")
T = palette("t45,t45m,flat")


def random_cells(n: int, rng: np.random.Generator) -> list[tuple[int, int]]:
    cells = [(0, 0)]
    while len(cells) < n:
        options = free_neighbours(cells)
        cells.append(options[int(rng.integers(len(options)))])
    return cells


def planted(cells, t, rng, modules=None, scale=1.0) -> np.ndarray:
    s = mq.Structure(cells, modules=modules) if modules else mq.Structure(cells)
    A = s.configuration_matrix()
    U = rng.uniform(0, 1, (t, A.shape[1]))
    on = rng.uniform(size=U.shape) < 0.8
    U[on] = rng.integers(0, 2, int(on.sum()))
    return scale * (A @ U.T).T


def assert_same_optimum(task, n_max, **kw):
    exact = exhaustive_search(task, n_max=n_max, **kw)
    r = milp_search(task, n_max=n_max, time_limit=120, **kw)
    assert exact.certified and r.certified
    assert r.n_modules == exact.n_modules and r.lower_bound == exact.lower_bound
    if r.structure is not None:  # verified again here, independently of the search
        W = SearchProblem.build(task, n_max, **kw).rotor_wrenches(r.structure)
        A = r.structure.configuration_matrix()
        assert mq.feasible(A, W, f_max=getattr(task, "f_max", 1.0), method="daqp").all()
    return r


# --------------------------------------------------------------------------- same optimum
@pytest.mark.parametrize("seed", [0, 1, 3, 4, 7])
def test_same_optimum_as_the_exhaustive_search_on_planted_tasks(seed):
    task = PlantedTasks(n_modules=(2, 7), n_wrenches=(4, 16))(np.random.default_rng(seed))
    assert_same_optimum(task, 8)


def test_same_optimum_on_the_screwdriver_and_an_eight_module_task():
    assert assert_same_optimum(SCREWDRIVER, 7).n_modules == 3
    task = PlantedTasks(n_modules=(8, 8), n_wrenches=(4, 10))(np.random.default_rng(2))
    assert assert_same_optimum(task, 8).n_modules == 8


def test_same_optimum_for_external_tasks_palettes_and_dynamic_tasks():
    rng = np.random.default_rng(4)
    cells = random_cells(4, rng)
    W = planted(cells, 8, rng)
    W[:, 2] -= mq.Structure(cells).mass * mq.GRAVITY  # the planted structure lifts itself
    assert_same_optimum(W, 6, kind="external")
    types = [T[0], T[2], T[1]]
    cells = random_cells(3, rng)
    assert_same_optimum(planted(cells, 6, rng, modules=types), 4, modules=T)
    heavy = [mq.TModule(), mq.TModule(eta=0.5, mass=0.45)]  # two mass classes
    W = planted(cells, 6, rng, modules=[heavy[0], heavy[1], heavy[1]])
    W[:, 2] -= (0.3 + 2 * 0.45) * mq.GRAVITY
    assert_same_optimum(W, 4, modules=heavy, kind="external")
    circle = dy.circle(speed=2.0, heading="tangent", rate=10)  # torques from the inertia
    assert SearchProblem.build(circle, 5).model.uses_inertia
    assert assert_same_optimum(circle, 5).n_modules == 3


def test_infeasible_up_to_n_max_is_certified():
    W = np.array([[0.0, 0.0, 3.0, 1.5, 0.0, 0.0]])
    exact = exhaustive_search(W, n_max=3)
    r = milp_search(W, n_max=3, time_limit=60)
    assert exact.structure is None and r.structure is None
    assert r.certified and r.lower_bound == 4


def test_an_oracle_rejection_is_never_an_answer(monkeypatch):
    """With rows widened far beyond the oracle's rule the program proposes structures the oracle
    rejects: each is cut off (or adds the wrenches it misses) and the search goes on to the
    exhaustive search's optimum."""
    monkeypatch.setattr(milp_module, "MARGIN", 0.05)
    task = PlantedTasks(n_modules=(4, 4), n_wrenches=(8, 8))(np.random.default_rng(1))
    exact = exhaustive_search(task, n_max=7)
    r = milp_search(task, n_max=7, time_limit=120)
    assert r.n_modules == exact.n_modules and r.certified
    assert r.evaluated > 1  # it was proposed something the oracle rejected


# --------------------------------------------------------------------------- the bound
@settings(
    max_examples=12, deadline=None, derandomize=True, suppress_health_check=[HealthCheck.too_slow]
)
@given(st.integers(0, 10**6))
def test_relaxation_bound_never_exceeds_the_certified_optimum(seed):
    rng = np.random.default_rng(seed)
    n = int(rng.integers(1, 5))
    W = planted(random_cells(n, rng), int(rng.integers(1, 8)), rng, scale=rng.choice([1.0, 1.3]))
    if rng.uniform() < 0.3:
        W[:, 3:] *= 2.5  # torque-heavy
    exact = exhaustive_search(W, n_max=5)
    optimum = exact.n_modules if exact.n_modules is not None else 6
    problem = SearchProblem.build(W, 5)
    assert milp_lower_bound(problem) <= optimum
    assert milp_lower_bound(problem, start=bound_levels(problem)) <= optimum


def test_the_relaxation_rules_out_levels_the_exact_bounds_leave():
    """A torque-heavy task: the relaxation proves more than the force and level bounds."""
    rng = np.random.default_rng(35)
    W = planted(random_cells(3, rng), 4, rng, scale=1.3)
    W[:, 3:] *= 2.5
    problem = SearchProblem.build(W, 6)
    relaxed = milp_lower_bound(problem, start=bound_levels(problem))
    assert bound_levels(problem) < relaxed
    exact = exhaustive_search(W, n_max=6)
    assert relaxed <= (exact.n_modules or 7)


# --------------------------------------------------------------------------- the formulation
def test_the_window_holds_a_translate_of_every_polyomino():
    for n in range(1, 8):
        inside = set(map(tuple, window(n).tolist()))
        assert len(inside) == n * (n + 1) // 2
        for key in list(structure_levels(n))[-1]:
            xs, ys = zip(*key, strict=True)
            moved = {(x - min(xs), y - min(ys)) for x, y in key}
            assert moved <= inside


def test_inertia_terms_give_the_structure_inertia():
    heavy = (mq.TModule(), mq.TModule(mass=0.5))
    cells = window(5)
    P = np.zeros((len(cells), 3))
    P[:, :2] = cells * heavy[0].side
    index = {tuple(c): i for i, c in enumerate(cells.tolist())}
    for shape, types in [([(0, 0), (1, 0), (1, 1), (2, 1)], [0, 1, 1, 0]), ([(0, 0)], [1])]:
        s = mq.Structure(shape, modules=[heavy[t] for t in types])
        lin, pairs, pair = inertia_terms(P, heavy, s.mass)
        z = np.zeros(len(cells) * 2)
        z[[2 * index[c] + t for c, t in zip(shape, types, strict=True)]] = 1
        j = z @ lin + (z[pairs[:, 0]] * z[pairs[:, 1]]) @ pair
        np.testing.assert_allclose(j, to_vector(s.inertia), atol=1e-12)


def test_a_time_limit_returns_the_proved_bound():
    task = PlantedTasks(n_modules=(24, 24), n_wrenches=(40, 40))(np.random.default_rng(0))
    r = milp_search(task, n_max=30, time_limit=1.5)
    assert r.seconds < 4.0
    assert r.lower_bound >= bound_levels(SearchProblem.build(task, 30))
    if r.structure is None:
        assert not r.certified


class Call:
    """Unpickled in the milp worker, it calls ``fn(*args)`` there: a stuck HiGHS (a sleep) or a
    crash (an exit), made to order."""

    def __init__(self, fn, *args):
        self.fn, self.args = fn, args

    def __reduce__(self):
        return self.fn, self.args


def test_the_worker_answers_is_killed_at_the_deadline_and_reports_a_crash():
    tiny = dict(c=np.array([1.0]), bounds=Bounds([1.0], [2.0]))
    status, x, _ = milp_worker.solve(tiny, 30)  # starts the worker
    assert status == 0 and list(x) == [1.0]
    t0 = time.perf_counter()
    assert milp_worker.solve({"c": Call(time.sleep, 60)}, 0.5) is None  # killed, not waited for
    assert time.perf_counter() - t0 < 0.5 + milp_worker.GRACE + 3.0
    assert milp_worker.solve(tiny, 30)[0] == 0  # a new worker
    with pytest.raises(milp_worker.WorkerError, match="ended with code 3"):
        milp_worker.solve({"c": Call(os._exit, 3)}, 30)
    assert milp_worker.solve(tiny, 30)[0] == 0


def test_a_short_time_limit_holds_where_highs_overruns_its_own():
    """HiGHS spent 22 s of a 0.87 s limit in its presolve on this task's level-52 program (1 M
    nonzeros), on a first call and on a second: the worker is killed at the deadline."""
    big = make_generator("planted-16-64")(np.random.default_rng(0))
    solver = mq.make_solver("milp", n_max=64, time_limit=1)
    for _ in range(2):
        t0 = time.perf_counter()
        r = solver.solve(big)
        assert time.perf_counter() - t0 < 10.0
        assert r.structure is None and not r.certified
        assert r.lower_bound >= bound_levels(SearchProblem.build(big, 64))


class SlowImport:
    """A finder that makes the import of one module slow (scipy's first import in a fresh
    process) and leaves finding it to the usual finders."""

    def __init__(self, name: str, seconds: float) -> None:
        self.name, self.seconds = name, seconds

    def find_spec(self, name, path=None, target=None):
        if name == self.name:
            time.sleep(self.seconds)
        return None


def test_the_programs_first_import_counts_against_the_limit(monkeypatch):
    """The relaxation bound imports the program's module (scipy.optimize) on first use: 0.2-0.4 s
    of a fresh process, which is the limit's own time, not time on top of it."""
    import modquad_gym.search as search_package

    name = "modquad_gym.search.milp_program"
    monkeypatch.delitem(sys.modules, name)
    monkeypatch.delattr(search_package, "milp_program")
    monkeypatch.setattr(sys, "meta_path", [SlowImport(name, 1.0), *sys.meta_path])
    problem = SearchProblem.build(generated_task("planted", 1, "total", None, 48), 64)
    start = bound_levels(problem)
    t0 = time.perf_counter()
    assert milp_lower_bound(problem, start=start, time_limit=0.8) == start  # nothing decided
    assert time.perf_counter() - t0 < 1.0 + 0.4  # the import took the whole limit


# --------------------------------------------------------------------------- interfaces
def test_cli_solve_json(capsys):
    assert SEARCHES["milp"] is milp_search
    args = ["solve", "--task", "example:screwdriver", "--method", "milp", "--json"]
    assert main(args) == 0
    line = json.loads(capsys.readouterr().out.strip().splitlines()[-1])
    assert line["method"] == "milp" and line["n_modules"] == 3 and line["certified"]
    assert line["lower_bound"] == 3 and line["feasible"]


def test_bad_options_are_refused_in_one_line(capsys):
    for kwargs, match, error in [
        (dict(beam_width=4), "no option 'beam_width'", TypeError),
        (dict(fault="rotor"), "fault='rotor'", ValueError),
        (dict(time_limit=0), "time_limit", ValueError),
        (dict(time_limit="soon"), "time_limit", ValueError),
    ]:
        with pytest.raises(error, match=match) as err:
            milp_search(SCREWDRIVER, n_max=5, **kwargs)
        assert "\n" not in str(err.value)
    with pytest.raises(ValueError, match="n_max=129"):
        milp_search(np.array([[0, 0, 3.0, 20.0, 0, 0]]), n_max=129)
    args = ["solve", "--task", "example:screwdriver", "--method", "milp", "--fault", "rotor"]
    assert main(args) == 2
    assert "method 'milp' cannot honour fault='rotor'" in capsys.readouterr().err
