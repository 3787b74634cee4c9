"""The Python door under hostile input (review 22): ``start=`` keeps the task's proved bound, the
second-tier public functions refuse bad arguments by name with the shared checks, the count
options have caps and stop at the proved bound, and one f_max range holds in every door."""

from __future__ import annotations

import json
import re
import time

import gymnasium as gym
import numpy as np
import pytest
from test_hardening import assert_one_line_error, run_main

import modquad_gym as mq
from modquad_gym.oracle import decide_with, margin_with
from modquad_gym.search import bound_levels, force_lower_bound, level_bounds, verified
from modquad_gym.search.problem import SearchProblem

LIGHT = np.array([[0.0, 0.0, 2.0, 0.0, 0.0, 0.0]])  # one module suffices
ROLL = np.array([[0.0, 0.0, 5.0, 0.8, 0.0, 0.0]])  # three modules in a column, and only those


# ------------------------------------------------------------------------------ start=
@pytest.mark.parametrize("door", ["exhaustive", "make_solver", "greedy"])
def test_a_start_larger_than_n_max_is_refused(door):
    """It searched nothing and said 'no structure of up to 3 modules satisfies the task
    (proved)' (greedy returned the 5-module start itself, beyond n_max)."""
    task, start = mq.TaskRequirement(LIGHT), [(i, 0) for i in range(5)]
    with pytest.raises(ValueError, match=r"^start has 5 cells, more than n_max=3$"):
        if door == "exhaustive":
            mq.exhaustive_search(task, n_max=3, start=start)
        elif door == "make_solver":
            mq.make_solver("exhaustive", n_max=3, start=start).solve(task)
        else:
            mq.greedy_search(task, n_max=3, start=start)


BAD_STARTS = [
    ([(i, 0) for i in range(4)], r"^start has 4 cells, more than n_max=2$"),
    ([(0, 0), (5, 5)], r"^start: cells are not face-connected .*cell #2 \(5, 5\)"),
    ("junk", r"^start: cell #1 \('j',\) is not a pair \(x, y\)$"),
]


@pytest.mark.parametrize(("start", "words"), BAD_STARTS)
@pytest.mark.parametrize("search", ["exhaustive", "greedy"])
def test_a_bad_start_is_refused_before_the_bounds_answer(search, start, words):
    """Five modules at the fewest: greedy's bounds answered 'infeasible' at n_max 2 and never
    looked at start (review 22), where the exhaustive search refused it."""
    heavy = np.tile([0.0, 0.0, 12.0, 0.0, 0.0, 0.0], (2, 1))
    assert bound_levels(SearchProblem(heavy, n_max=2)) > 2
    with pytest.raises(ValueError, match=words):
        getattr(mq, f"{search}_search")(heavy, n_max=2, start=start)


@pytest.mark.parametrize(("start", "words"), BAD_STARTS)
@pytest.mark.parametrize("method", ["exhaustive", "greedy"])
def test_make_solver_refuses_a_bad_start_when_made(method, start, words):
    """As its other options: refused by make_solver, not at the first solve."""
    with pytest.raises(ValueError, match=words):
        mq.make_solver(method, n_max=2, start=start)


def test_make_solver_checks_start_against_what_it_is_given():
    """Without n_max, the budget is the problem's: a 9-cell start is refused at solve, in the
    same words, for a task (n_max 7), and taken for a problem of n_max 10; with modules, a
    Structure of another type is refused when the solver is made."""
    start = [(i, 0) for i in range(9)]
    solver = mq.make_solver("greedy", start=start)
    with pytest.raises(ValueError, match=r"^start has 9 cells, more than n_max=7$"):
        solver.solve(LIGHT)
    assert solver.solve(SearchProblem(LIGHT, n_max=10)).n_modules == 9
    other = mq.Structure([(0, 0)], module=mq.TModule(eta=0.3))
    words = r"^start: module type '.*' is not among the searched types$"
    with pytest.raises(ValueError, match=words):
        mq.make_solver("exhaustive", n_max=3, modules=[mq.TModule(), mq.TModule(eta=0.5)],
                       start=other)  # fmt: skip


def test_the_minimum_containing_start_is_not_the_tasks_certified_minimum():
    """It said 'optimal', '2 modules (certified minimum)' and lower_bound 2 where 1 suffices."""
    task = mq.TaskRequirement(LIGHT)
    assert mq.exhaustive_search(task, n_max=3).n_modules == 1
    r = mq.exhaustive_search(task, n_max=3, start=[(0, 0), (1, 0)])
    assert (r.n_modules, r.lower_bound, r.certified, r.status) == (2, 1, False, "feasible")
    assert "the minimum among structures containing start" in r.message
    assert r.scope == "containing start" and r.to_dict()["scope"] == "containing start"
    assert r.skipped_levels == []  # level 1 holds no structure containing start: not ruled out


def test_a_start_no_completion_of_satisfies_is_no_proof_for_the_task():
    """A column of three satisfies ROLL; a row of two cannot be completed within 3 modules. It
    said 'infeasible', '... (proved)', certified, lower_bound 4."""
    task = mq.TaskRequirement(ROLL)
    r = mq.exhaustive_search(task, n_max=3, start=[(0, 0), (1, 0)])
    assert r.structure is None and r.status == "no answer" and not r.certified
    assert r.lower_bound == bound_levels(SearchProblem(task, n_max=3)) == 3
    assert r.message.startswith("no structure containing start of up to 3 modules satisfies")
    column = mq.exhaustive_search(task, n_max=3, start=[(0, 0), (0, 1)])
    assert (column.status, column.n_modules, column.certified) == ("optimal", 3, True)
    below = mq.exhaustive_search(task, n_max=2, start=[(0, 0)])  # the bounds prove it
    assert below.status == "infeasible" and below.lower_bound == 3 and below.proof


def test_a_typed_search_from_start_keeps_the_tasks_bound():
    task = mq.TaskRequirement(LIGHT)
    palette = [mq.TModule(), mq.TModule(eta=0.5)]
    r = mq.exhaustive_search(task, n_max=3, modules=palette, start=[(0, 0), (1, 0)])
    assert (r.n_modules, r.lower_bound, r.status) == (2, 1, "feasible")
    assert 1 not in r.skipped_levels


# --------------------------------------------------- second-tier functions: refusals by name
W9 = np.array([[0.0, 0.0, 9.0, 0.0, 0.0, 0.0]])


@pytest.mark.parametrize(
    "kwargs, words",
    [
        ({"fault": "Module"}, "fault must be one of"),
        ({"fault": 42}, "fault must be one of"),
        ({"f_max": float("nan")}, "f_max must be finite"),
        ({"f_max": True}, "f_max must be a real number"),
        ({"f_max": -1}, "f_max must be positive"),
        ({"f_max": "1"}, "f_max must be a real number"),
        ({"f_max": None}, "f_max must be a real number"),
        ({"f_max": 1 + 0j}, "f_max must be a real number"),
        ({"W": np.zeros((1, 5)) + 9}, "wrenches must have shape (t, 6)"),
        ({"module": None}, "module must be a ModuleType, got None"),
    ],
)
def test_force_lower_bound_refuses_by_name(kwargs, words):
    """'Module' was the no-fault bound (4, where the module fault needs 5), NaN f_max gave 1."""
    args = {"W": W9, "module": mq.TModule(), **kwargs}
    with pytest.raises(ValueError, match="^" + re.escape(words)):
        force_lower_bound(**args)
    assert force_lower_bound(W9, mq.TModule(), fault="module") == 5


@pytest.mark.parametrize(
    "args, kwargs, words",
    [
        ((3,), {"fault": "x"}, "fault must be one of"),
        (("3",), {}, "n must be an integer, got '3'"),
        ((None,), {}, "n must be an integer, got None"),
        (([3],), {}, "n must be an integer, got [3]"),
        ((0,), {}, "n must be >= 1"),
    ],
)
def test_level_bounds_refuses_by_name(args, kwargs, words):
    with pytest.raises(ValueError) as err:
        level_bounds(mq.TModule(), *args, **kwargs)
    assert str(err.value).startswith(words)
    assert level_bounds(mq.TModule(), 3).shape[0] == 2


def _zonotope():
    return mq.Zonotope(mq.Structure([(0, 0)]).configuration_matrix())


@pytest.mark.parametrize(
    "call, words",
    [
        (lambda z: decide_with(z, LIGHT, "bogus"), "unknown method 'bogus'; choose one of auto"),
        (lambda z: margin_with(z, LIGHT, None), "unknown method None"),
        (lambda z: decide_with(z, LIGHT, ["auto"]), "unknown method ['auto']"),
        (lambda z: decide_with(z, np.zeros((1, 5)), "auto"), "wrenches must have shape"),
        (lambda z: decide_with(z.A, LIGHT, "auto"), "z must be a Zonotope"),
        (lambda z: z.decide_certified(np.full((1, 6), np.nan)), "wrench row 1 is not finite"),
    ],
)
def test_the_oracle_doors_refuse_by_name(call, words):
    """They were KeyError, numpy's matmul error, AttributeError, and array([False]) for NaN."""
    with pytest.raises(ValueError) as err:
        call(_zonotope())
    assert str(err.value).startswith(words)
    z = _zonotope()
    assert decide_with(z, LIGHT, "daqp").all() and z.decide_certified(LIGHT).all()
    assert margin_with(z, LIGHT) == pytest.approx(mq.margin(z.A, LIGHT))


def test_verified_takes_a_wrench_array_and_refuses_the_rest_by_name():
    """A (t, 6) array was `AttributeError: ... no attribute 'rotor_wrenches'`."""
    s = mq.Structure([(0, 0)])
    assert verified(s, LIGHT) and verified(s, mq.TaskRequirement(LIGHT))
    assert not verified(s, LIGHT * 10) and not verified(None, LIGHT)
    with pytest.raises(ValueError, match=r"^task: wrenches must have shape"):
        verified(s, np.zeros((1, 5)))
    with pytest.raises(ValueError, match=r"^structure must be a Structure or None, got list"):
        verified([(0, 0)], LIGHT)


@pytest.mark.parametrize(
    "n_max, words",
    [
        (0, "n_max must be >= 1, got 0"),
        (-5, "n_max must be >= 1"),
        (True, "n_max must be an integer, got True"),
        (None, "n_max must be an integer, got None"),
        (2.0, "n_max must be an integer, got 2.0"),
        ("3", "n_max must be an integer, got '3'"),
        (10**30, "n_max must be <= 16"),
    ],
)
def test_structure_levels_checks_n_max_at_the_call(n_max, words):
    """0 and -5 gave nothing, True one level, the rest a TypeError; 10**30 ran on."""
    with pytest.raises(ValueError) as err:
        mq.structure_levels(n_max)  # refused before the first level is asked for
    assert str(err.value).startswith(words)
    assert [len(level) for level in mq.structure_levels(3)] == [1, 2, 6]


@pytest.mark.parametrize("n_max", [float("nan"), float("inf"), "3", True, 0])
def test_make_generator_checks_n_max(n_max):
    """NaN and inf were ignored, '3' a TypeError, True refused as 'n_modules'."""
    from modquad_gym.tasks import make_generator

    with pytest.raises(ValueError, match=r"^n_max must be"):
        make_generator("planted", n_max=n_max)
    assert make_generator("planted", n_max=3).n_modules == (2, 3)


@pytest.mark.parametrize("spec", [None, 3, ["a:b"]])
def test_load_solver_refuses_a_spec_that_is_no_text(spec):
    from modquad_gym.solvers import load_solver

    with pytest.raises(ValueError, match=r"^spec must be package.module:Name \(a str\)"):
        load_solver(spec)


@pytest.mark.parametrize("spec", ["mq_agents", "os:system", "no_such_module_here:Agent"])
def test_load_solver_speaks_python_in_python(spec):
    """Its messages said `--solver '...'` from Python too."""
    from modquad_gym.solvers import load_solver

    with pytest.raises(ValueError) as err:
        load_solver(spec)
    assert str(err.value).startswith(f"solver {spec!r}: ") and "--" not in str(err.value)


def test_score_names_the_option_an_outside_agent_came_by(tmp_path, capsys):
    code, _, err = run_main(capsys, "score", "--methods", "greedy", "os:system", "--out",
                            str(tmp_path / "rep"))  # fmt: skip
    assert_one_line_error(code, err, "--methods 'os:system': os is a standard-library module")


@pytest.mark.parametrize("direction", [(0, 0, 0), (np.nan, 0, 1), (0, 1), None, (0, 0, np.inf)])
def test_rotor_quaternion_refuses_a_direction_it_cannot_turn_to(direction):
    """Zero and NaN gave a NaN quaternion (a RuntimeWarning), a 2-vector an IndexError."""
    from modquad_gym.sim.export import rotor_quaternion

    with pytest.raises(ValueError, match=r"^direction must be 3 finite numbers, not all zero"):
        rotor_quaternion(direction)
    assert np.allclose(rotor_quaternion((1e200, 0, 1e200)), rotor_quaternion((1, 0, 1)))


@pytest.mark.parametrize(
    "deadline, words",
    [(True, "a real number, got True"), (float("nan"), "finite"), ("x", "a real number")],
)
def test_tolerates_checks_its_deadline(deadline, words):
    """True was taken as perf_counter() = 1 s (interrupted at once), NaN as never, 'x' a
    TypeError."""
    s4 = mq.Structure([(0, 0), (1, 0), (0, 1), (1, 1)])
    with pytest.raises(ValueError, match=f"^deadline must be {words}"):
        mq.tolerates(s4, LIGHT, deadline=deadline)
    assert mq.tolerates(s4, LIGHT, deadline=time.perf_counter() + 60).all()


# ------------------------------------------------- restarts and samples: a cap, a stop at the bound
@pytest.mark.parametrize("door", ["search", "make_solver"])
def test_restarts_has_a_cap(door):
    from modquad_gym.search.baselines import MAX_RESTARTS

    with pytest.raises(ValueError, match=rf"^restarts must be <= {MAX_RESTARTS}, got 10{{30}}$"):
        if door == "search":
            mq.random_search(LIGHT, n_max=3, restarts=10**30)
        else:
            mq.make_solver("random", restarts=10**30)


def test_restarts_has_a_cap_on_the_command_line(tmp_path, capsys):
    path = tmp_path / "light.json"
    path.write_text(json.dumps({"wrenches": LIGHT.tolist()}))
    code, _, err = run_main(capsys, "solve", "--task", str(path), "--method", "random",
                            "--option", f"restarts={10**30}", "--time-limit", "3")  # fmt: skip
    assert_one_line_error(code, err, f"--option restarts={10**30}: restarts must be <= 1000000")


def test_random_search_stops_at_the_proved_bound(monkeypatch):
    """restarts=10**6 on a 1-module task ran every restart (1.6 s; 10**30 the whole limit)."""
    from modquad_gym.search import baselines

    starts = []
    trusted = baselines.Structure.from_trusted
    monkeypatch.setattr(baselines.Structure, "from_trusted",
                        lambda *a, **k: starts.append(1) or trusted(*a, **k))  # fmt: skip
    r = mq.random_search(mq.TaskRequirement(LIGHT), n_max=3, restarts=10**6, time_limit=30)
    assert r.status == "optimal" and r.n_modules == r.lower_bound == 1
    assert len(starts) == 1 and r.seconds < 3  # one restart, well before the limit


@pytest.mark.parametrize("name", ["random", "beam", "genetic"])
def test_a_search_computes_the_proved_bound_once(monkeypatch, name):
    """random, beam and genetic took bound_levels before their loop (random's early stop, the
    others' start) and heuristic_result took it again: about 20 % of random's time on a palette
    (review 22); the one call is passed on."""
    from modquad_gym.geometry.module import palette
    from modquad_gym.search import SEARCHES, baselines, beam, genetic, heuristic

    calls = []
    counted = lambda p: calls.append(1) or bound_levels(p)  # noqa: E731
    for module in (baselines, beam, genetic, heuristic):
        monkeypatch.setattr(module, "bound_levels", counted)
    pal = palette("t45,t45m,flat")
    r = SEARCHES[name](ROLL, n_max=4, modules=pal, time_limit=5)
    assert len(calls) == 1 and r.lower_bound == bound_levels(SearchProblem(ROLL, 4, modules=pal))


@pytest.mark.parametrize("door", ["make_solver", "variant"])
def test_samples_has_a_cap(door):
    from modquad_gym.policy.models import MAX_SAMPLES

    with pytest.raises(ValueError, match=rf"samples must be <= {MAX_SAMPLES}"):
        if door == "make_solver":
            mq.make_solver("ppo", samples=MAX_SAMPLES + 1)
        else:
            mq.make_solver(f"ppo-k{MAX_SAMPLES + 1}")


def test_samples_has_a_cap_on_the_command_line(tmp_path, capsys):
    path = tmp_path / "light.json"
    path.write_text(json.dumps({"wrenches": LIGHT.tolist()}))
    code, _, err = run_main(capsys, "solve", "--task", str(path), "--method", "ppo",
                            "--option", "samples=1001")  # fmt: skip
    assert_one_line_error(code, err, "--option samples=1001: samples must be <= 1000")


def test_ppo_samples_stop_at_the_proved_bound(monkeypatch):
    """Its deterministic pass meets the bound (3 modules): the sampled rollouts ran on to the
    time limit (10 s for samples=10**30 in the review)."""
    from modquad_gym.policy.policy import Policy

    rollouts = []
    rollout = Policy.rollout
    monkeypatch.setattr(Policy, "rollout", lambda *a, **k: rollouts.append(1) or rollout(*a, **k))
    r = mq.make_solver("ppo", n_max=5, samples=50, time_limit=60).solve(mq.TaskRequirement(ROLL))
    assert (r.status, r.n_modules, r.lower_bound) == ("optimal", 3, 3)
    assert rollouts == []


# ------------------------------------------------------------------ one f_max range everywhere
HUGE = 1e30
SAID = "f_max = 1e+30 is outside 1e-300..1e12 (check the units)"


@pytest.mark.parametrize(
    "door",
    [
        lambda: mq.feasible(mq.Structure([(0, 0)]).configuration_matrix(), LIGHT, f_max=HUGE),
        lambda: mq.margin(mq.Structure([(0, 0)]).configuration_matrix(), LIGHT, f_max=HUGE),
        lambda: mq.SearchProblem(LIGHT, f_max=HUGE),
        lambda: mq.exhaustive_search(LIGHT, n_max=2, f_max=HUGE),
        lambda: mq.TaskRequirement(LIGHT, f_max=HUGE),
        lambda: gym.make("ModQuadAssembly-v0", f_max=HUGE),
    ],
)
def test_f_max_beyond_1e12_is_refused_by_every_python_door(door):
    """The environment refused it ('f_max must be <= 1e+12'); the rest took it."""
    with pytest.raises(ValueError, match="^" + re.escape(SAID)):
        door()
    assert mq.TaskRequirement(LIGHT, f_max=1e12).f_max == 1e12


def test_f_max_beyond_1e12_in_a_task_file_is_refused(tmp_path, capsys):
    path = tmp_path / "strong.json"
    path.write_text(json.dumps({"wrenches": LIGHT.tolist(), "f_max": HUGE}))
    code, _, err = run_main(capsys, "solve", "--task", str(path), "--method", "greedy")
    assert_one_line_error(code, err, str(path), SAID)


def test_the_environment_keeps_its_own_floor_below_the_shared_range():
    with pytest.raises(ValueError, match=r"^f_max must be >= 1e-09, got 1e-10$"):
        gym.make("ModQuadAssembly-v0", f_max=1e-10)


def test_a_module_mass_has_a_cap():
    """TModule(mass=1e30) was taken (1e308 failed later, as an inertia overflow)."""
    from modquad_gym.geometry.module import MAX_MASS

    for mass in (1e30, 1e308):
        said = f"mass must be <= {MAX_MASS:g}, got {mass:g}"
        with pytest.raises(ValueError, match="^" + re.escape(said)):
            mq.TModule(mass=mass)
    assert mq.TModule(mass=MAX_MASS).mass == MAX_MASS
