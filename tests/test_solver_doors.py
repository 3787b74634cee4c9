"""The solver doors after reviews 2 and 3 (/tmp/review2_findings.md items 2, 7-10;
/tmp/review3_findings.md items 8, 9, 12, 16, 19): ``make_solver`` checks what it is made with
and refuses a problem that says otherwise; every option has one check, the same from the search
functions, ``make_solver`` and ``--option``; an option is given once; a Python-only option is
named as such on the command line; ``--workers`` a single task cannot use, ``--certificate`` on
the ``--export`` file and a learned variant that sets a thing twice are refused."""

from __future__ import annotations

import dataclasses
import json
import re

import numpy as np
import pytest
from test_hardening import assert_one_line_error, assert_rejected, run_main

import modquad_gym as mq
from modquad_gym.geometry.module import palette
from modquad_gym.search import SEARCHES

TASK = mq.TaskRequirement([[0, 0, 3, 0, 0, 0], [0.5, 0, 3, 0, 0, 0]])
SCREWDRIVER = "example:screwdriver"


def _no_work(monkeypatch) -> None:
    def boom(*args, **kwargs):
        raise AssertionError("a task was read before the options were checked")

    monkeypatch.setattr("modquad_gym.cli.common.load_task", boom)


# ------------------------------------------------ review 2 #2: the solver and its problem
@pytest.mark.parametrize(
    ("made", "problem", "words"),
    [
        (dict(n_max=3, fault="rotor"), dict(n_max=5), "made with n_max=3"),
        (dict(fault="rotor"), dict(n_max=5), "made with fault='rotor'"),
        (dict(n_max=5, fault="rotor", fault_margin=0.1), dict(n_max=5, fault="rotor"),
         "made with fault_margin=0.1"),
        (dict(modules=palette("t45,flat")), dict(n_max=5, modules=palette("t45")),
         "made with modules=[t45, flat], the SearchProblem it was given says modules=[t45]"),
    ],
)  # fmt: skip
def test_a_problem_that_contradicts_the_solver_is_refused(made, problem, words):
    solver = mq.make_solver("greedy", time_limit=5, **made)
    with pytest.raises(ValueError, match="the SearchProblem it was given says") as err:
        solver.solve(mq.SearchProblem(TASK, **problem))
    assert words in str(err.value)


def test_a_problem_that_agrees_with_the_solver_or_a_solver_without_settings_is_used():
    problem = mq.SearchProblem(TASK, n_max=5, fault="rotor")
    for made in (dict(), dict(n_max=5), dict(n_max=5, fault="rotor")):
        r = mq.make_solver("greedy", time_limit=60, **made).solve(problem)
        assert r.n_max == 5 and r.fault == "rotor"
        assert mq.tolerates(r.structure, TASK.wrenches, fault="rotor").all()


@pytest.mark.parametrize(
    ("kwargs", "error", "words"),
    [
        (dict(n_max=-1), ValueError, "n_max must be >= 1, got -1"),
        (dict(n_max="5"), ValueError, "n_max must be an integer, got '5'"),
        (dict(fault="bogus"), ValueError, "fault must be one of"),
        (dict(modules=5), ValueError, "modules must be a list of ModuleType"),
        (dict(modules="t45,t45"), ValueError, "modules: a type is listed twice"),
        (dict(tier="bogus"), TypeError, "tier='bogus': method 'greedy' does not take it"),
    ],
)
def test_make_solver_checks_what_it_is_made_with(kwargs, error, words):
    with pytest.raises(error, match="^" + re.escape(words)):
        mq.make_solver("greedy", **kwargs)


def test_make_solver_names_its_arguments():
    with pytest.raises(TypeError, match="method must be a method name"):
        mq.make_solver(None)
    with pytest.raises(ValueError, match="^n_max must be an integer, got '5'"):
        mq.make_solver("ppo", n_max="5")
    with pytest.raises(ValueError, match="^model must be the path of a PPO model"):
        mq.make_solver("ppo", n_max=5, model=5)
    with pytest.raises(ValueError, match="^n_max=200 is beyond what the ppo method"):
        mq.make_solver("ppo", n_max=200)
    with pytest.raises(TypeError, match="'x.y:Z' is an outside agent"):
        mq.make_solver("x.y:Z", model="a.zip")


def test_a_model_file_from_python_is_named_model(tmp_path):
    pytest.importorskip("sb3_contrib")
    bad = tmp_path / "x.json"
    bad.write_text("{}")
    with pytest.raises(ValueError, match=f"^model {bad}: not a MaskablePPO model"):
        mq.make_solver("ppo", model=str(bad))


# ----------------------------------------------- review 2 #7: one check per option
OPTION_CASES = [
    ("random", dict(restarts=0), "restarts must be >= 1, got 0"),
    ("random", dict(restarts=2.7), "restarts must be an integer, got 2.7"),
    ("random", dict(restarts="3"), "restarts must be an integer, got '3'"),
    ("greedy", dict(time_limit="2"), "time_limit must be a real number, got '2'"),
    ("greedy", dict(time_limit=True), "time_limit must be a real number, got True"),
    ("random", dict(seed=2**64), "seed must be <= 9223372036854775807"),
    ("genetic", dict(seed=2**70), "seed must be <= 9223372036854775807"),
    ("centrosymmetric", dict(block_seed=1), "block_seed must be True or False, got 1"),
    ("exhaustive", dict(progress="yes"), "progress must be True or False, got 'yes'"),
    ("anytime", dict(seed=-1), "seed must be >= 0, got -1"),
    ("anytime", dict(engine="x"), "engine must be an Engine"),
    ("exhaustive", dict(engine="x"), "engine must be an Engine"),
    ("anytime", dict(producers=5), "producers must be a sequence of producers"),
    ("genetic", dict(penalty=float("nan")), "penalty must be finite, got nan"),
    ("genetic", dict(population=10**6), "population must be <= 10000"),
    ("beam", dict(beam_width=10**6), "beam_width must be <= 4096"),
]


@pytest.mark.parametrize(("method", "option", "words"), OPTION_CASES)
def test_an_option_is_refused_alike_by_the_search_and_make_solver(method, option, words):
    with pytest.raises(ValueError) as search:
        SEARCHES[method](TASK, n_max=4, **option)
    with pytest.raises(ValueError) as made:
        mq.make_solver(method, n_max=4, **option)
    assert str(search.value) == str(made.value) and str(made.value).startswith(words)


@pytest.mark.parametrize(
    ("method", "text", "words"),
    [
        ("random", "restarts=0", "--option restarts=0: restarts must be >= 1, got 0"),
        ("genetic", "penalty=nan", "--option penalty=nan: penalty must be finite, got nan"),
        ("genetic", "population=1000000", "--option population=1000000: population must be <="),
        ("beam", "beam_width=5000", "--option beam_width=5000: beam_width must be <= 4096"),
    ],
)
def test_the_command_line_names_the_option_with_the_same_check(capsys, monkeypatch, method,
                                                                text, words):  # fmt: skip
    _no_work(monkeypatch)
    argv = ["solve", "--task", SCREWDRIVER, "--method", method, "--option", text]
    assert_one_line_error(*run_main(capsys, *argv)[::2], words)


# -------------------------------- review 2 #9, review 3 #8: an option is given once
@pytest.mark.parametrize(
    ("method", "extra", "words"),
    [
        ("random", ["--seed", "6", "--option", "seed=5"], "seed is given twice (--seed 6 too)"),
        ("random", ["--option", "seed=6", "--option", "seed=5"],
         "seed is given twice (--option seed=6 too)"),
        ("greedy", ["--time-limit", "2", "--option", "time_limit=3"],
         "time_limit is given twice (--time-limit 2.0 too)"),
        ("beam", ["--option", "beam_width=4", "--option", "beam_width=8"],
         "beam_width is given twice"),
    ],
)  # fmt: skip
def test_two_values_for_one_option_are_refused(capsys, monkeypatch, method, extra, words):
    _no_work(monkeypatch)
    argv = ["solve", "--task", SCREWDRIVER, "--method", method, *extra]
    assert_one_line_error(*run_main(capsys, *argv)[::2], words)


def test_an_option_alone_still_sets_it(capsys):
    argv = ["solve", "--task", SCREWDRIVER, "--method", "random", "--n-max", "5", "--json",
            "--quiet", "--option", "seed=5"]  # fmt: skip
    code, out, err = run_main(capsys, *argv)
    assert code == 0, err
    same = mq.make_solver("random", n_max=5, seed=5).solve(mq.tasks.load_task(SCREWDRIVER))
    assert json.loads(out)["cells"] == [list(c) for c in same.structure.cells]


@pytest.mark.parametrize(
    ("method", "kwargs", "words"),
    [
        ("random", dict(seed=6, guided={"seed": 5}), "guided= gives ppo-guided's options"),
        ("ppo-guided", dict(budget=6, guided={"budget": 5}),
         "budget is given twice (guided={'budget': 5} and budget=6)"),
    ],
)  # fmt: skip
def test_make_solver_refuses_an_option_given_twice(method, kwargs, words):
    with pytest.raises((TypeError, ValueError)) as err:
        mq.make_solver(method, **kwargs)
    assert str(err.value).startswith(words)


# ------------------------------- review 2 #10, review 3 #19: Python-only options
@pytest.mark.parametrize(
    ("method", "text", "words"),
    [
        ("greedy", "start=[[0,0]]", "start of method 'greedy' is an object"),
        ("anytime", "engine=x", "Python only (make_solver('anytime', engine=...))"),
        ("ppo", "model=x", "give model of method 'ppo' with --model"),
        ("ppo", "model", "give model of method 'ppo' with --model"),
        ("exhaustive", "start", "start of method 'exhaustive' is an object"),
    ],
)
def test_a_python_only_option_is_named_so(capsys, monkeypatch, method, text, words):
    _no_work(monkeypatch)
    argv = ["solve", "--task", SCREWDRIVER, "--method", method, "--option", text]
    err = run_main(capsys, *argv)[2]
    assert_one_line_error(2, err, f"--option {text}: ", words)
    assert "has no option" not in err


def test_a_learned_budget_beyond_the_grid_names_n_max(capsys, monkeypatch):
    _no_work(monkeypatch)
    argv = ["solve", "--task", SCREWDRIVER, "--method", "ppo", "--n-max", "200"]
    assert_one_line_error(*run_main(capsys, *argv)[::2], "--n-max 200: method 'ppo'")


# ------------------------------------------- review 3 #9, #12, #16: the solve command
@pytest.mark.parametrize("method", ["greedy", "milp", "beam", "genetic", "random",
                                    "centrosymmetric", "ppo"])  # fmt: skip
@pytest.mark.parametrize("option", [["--workers", "2"], ["--ray-address", "auto"]])
def test_workers_a_single_task_cannot_use_are_refused(capsys, monkeypatch, method, option):
    monkeypatch.setattr("modquad_gym.cli.solve.cached_solver", pytest.fail)
    argv = ["solve", "--task", SCREWDRIVER, "--method", method, *option]
    assert_one_line_error(*run_main(capsys, *argv)[::2], f"{option[0]} {option[1]}",
                          f"method {method!r} solves one task in this process")  # fmt: skip


def test_one_worker_for_a_single_task_is_fine(capsys):
    argv = ["solve", "--task", SCREWDRIVER, "--method", "greedy", "--workers", "1", "--quiet"]
    assert run_main(capsys, *argv)[0] == 0


def test_the_certificate_on_the_export_file_is_refused_before_the_search(capsys, monkeypatch,
                                                                          tmp_path):  # fmt: skip
    _no_work(monkeypatch)
    out = tmp_path / "c.json"
    argv = ["solve", "--task", SCREWDRIVER, "--method", "exhaustive", "--certificate", str(out),
            "--export", str(out), "--force"]  # fmt: skip
    assert_one_line_error(*run_main(capsys, *argv)[::2], "name the same file")
    assert not out.exists()


@pytest.mark.parametrize("method", ["ppo-guided-b5-b6", "ppo-guided-w2-w3",
                                    "ppo-guided-nodive-nodive"])  # fmt: skip
def test_a_guided_variant_that_sets_a_thing_twice_is_refused(capsys, method):
    with pytest.raises(ValueError, match="twice"):
        mq.make_solver(method)
    code, _, err = run_main(capsys, "solve", "--task", SCREWDRIVER, "--method", method)
    assert_rejected(code, err, method, "twice")


def test_the_option_checks_are_the_entry_points_own():
    """The options dataclasses read their checks from the search entry points: one check."""
    from modquad_gym.methods import REGISTRY

    for name, search in SEARCHES.items():
        for f in dataclasses.fields(REGISTRY[name].options):
            assert f.metadata["check"] is search.option_specs[f.name][1], (name, f.name)
    assert np.isclose(SEARCHES["greedy"].option_specs["time_limit"][1](2, "time_limit"), 2.0)
