"""One door per concept: every method answers the same through ``modquad solve --json``,
``make_solver(...).solve(...)`` and ``mq.<name>_search(problem)``; every field of a
:class:`SearchProblem` is honoured by every search; an option a method does not take, or a fault
it cannot honour, is refused with the same words in Python and on the command line; a method
registered once appears in the CLI, ``make_solver`` and ``modquad score``."""

from __future__ import annotations

import json

import numpy as np
import pytest

import modquad_gym as mq
from modquad_gym.cli import main
from modquad_gym.geometry.module import palette
from modquad_gym.methods import REGISTRY, Method, options, register, unregister
from modquad_gym.search import SEARCHES
from modquad_gym.solvers import MethodSolver, make_solver
from modquad_gym.tasks import load_task

TASK = "example:screwdriver"  # optimum 3 modules; 4 after any single rotor failure

CASES = [
    ("exhaustive", dict(n_max=5)),
    ("exhaustive", dict(n_max=2)),  # proved infeasible within the budget
    ("exhaustive", dict(n_max=6, fault="rotor")),
    ("exhaustive", dict(n_max=4, modules="t45,flat")),
    ("anytime", dict(n_max=6, time_limit=20.0, seed=1)),
    ("anytime", dict(n_max=6, time_limit=20.0, fault="module")),
    ("greedy", dict(n_max=6, time_limit=20.0, fault="rotor")),
    ("beam", dict(n_max=6, time_limit=20.0, modules="t45,flat")),
    ("beam", dict(n_max=6, time_limit=20.0, modules="t45,flat", prune=True)),
    ("genetic", dict(n_max=5, time_limit=20.0, seed=3)),
    ("random", dict(n_max=6, time_limit=20.0, seed=2)),
    ("random", dict(n_max=8, time_limit=20.0, seed=2, prune=True)),  # the post-pass
    ("centrosymmetric", dict(n_max=7, time_limit=20.0)),
    ("milp", dict(n_max=5, time_limit=60.0)),
    ("anytime", dict(n_max=7, time_limit=20.0, fault="rotor2")),
    ("exhaustive", dict(n_max=7, fault="rotor+module")),
    ("ppo", dict(n_max=7, time_limit=60.0)),
    ("ppo", dict(n_max=7, time_limit=60.0, top_k=2)),  # the shortlist, an --option in the CLI
    ("ppo-guided", dict(n_max=7, time_limit=60.0)),
    ("ppo", dict(n_max=7, time_limit=60.0, prune=True)),
    ("ppo", dict(n_max=7, time_limit=60.0, fallback=1.0, top_k=None)),  # greedy's dockings
    ("ppo-guided", dict(n_max=7, time_limit=60.0, fallback=0.5)),
    ("ppo-guided", dict(n_max=7, time_limit=60.0, budget=8)),
    ("ppo", dict(n_max=7, time_limit=60.0, extra_fallbacks=1.0)),  # and greedy's dockings
    ("ppo", dict(n_max=7, time_limit=60.0, fault="rotor")),  # zero-shot: designs for it
    ("ppo-guided", dict(n_max=7, time_limit=60.0, fault="module")),
    ("ppo", dict(n_max=7, time_limit=60.0, modules="t45,t45m,flat", fault="rotor")),
]
FLAGS = {"n_max", "fault", "modules", "time_limit", "seed"}
"""Options with a flag of their own; the others go through ``--option KEY=VALUE``."""


def _answer(record: dict) -> tuple:
    return (record["cells"], record.get("modules"), record["status"], record["lower_bound"])


def _cli(method: str, options: dict, capsys) -> dict:
    argv = ["solve", "--task", TASK, "--method", method, "--json", "--quiet"]
    for key, value in options.items():
        flag = key in FLAGS
        argv += (
            [f"--{key.replace('_', '-')}", str(value)] if flag else ["--option", f"{key}={value}"]
        )
    capsys.readouterr()
    assert main(argv) == 0
    return json.loads(capsys.readouterr().out)


@pytest.mark.parametrize(("method", "options"), CASES, ids=[f"{m}-{i}" for i, (m, _) in
                                                             enumerate(CASES)])  # fmt: skip
def test_the_cli_make_solver_and_the_search_give_one_answer(method, options, capsys):
    task = load_task(TASK)
    given = dict(options)
    types = palette(given.pop("modules")) if "modules" in given else None
    n_max, fault = given.pop("n_max"), given.pop("fault", None)
    python = make_solver(method, n_max, modules=types, fault=fault, **given).solve(task)
    doors = [_cli(method, options, capsys), python.to_dict()]
    if method in SEARCHES:
        problem = mq.SearchProblem(task, n_max, modules=types, fault=fault)
        doors.append(SEARCHES[method](problem, **given).to_dict())
    assert len({json.dumps(_answer(d)) for d in doors}) == 1, [_answer(d) for d in doors]
    assert python.fault == fault and python.n_max == n_max
    if python.structure is not None:
        assert python.n_modules <= n_max


@pytest.mark.parametrize("name", list(SEARCHES))
def test_every_search_honours_the_problem_it_is_given(name):
    task = load_task(TASK)
    small = mq.SearchProblem(task, n_max=2)  # the optimum needs 3
    r = SEARCHES[name](small, time_limit=20.0) if name != "exhaustive" else SEARCHES[name](small)
    assert r.structure is None and r.n_max == 2
    if name in ("exhaustive", "anytime", "milp"):
        assert r.status == "infeasible"
    with pytest.raises(ValueError, match="given beside a SearchProblem"):
        SEARCHES[name](small, n_max=5)
    if name == "milp":
        return
    tolerant = mq.SearchProblem(task, n_max=6, fault="rotor")
    r = (
        SEARCHES[name](tolerant, time_limit=20.0)
        if name != "exhaustive"
        else SEARCHES[name](tolerant)
    )
    assert r.fault == "rotor"
    if r.structure is not None:
        W = task.rotor_wrenches(r.structure)
        assert mq.tolerates(r.structure, W, task.f_max, fault="rotor").all()
        assert r.n_modules >= 4  # the intact optimum (3) does not survive every rotor failure


def test_unknown_and_unhonourable_options_are_refused_alike(capsys):
    with pytest.raises(TypeError) as err:
        make_solver("greedy", time_limt=5)
    typo = str(err.value)
    assert "'time_limt'" in typo and "time_limit" in typo
    assert main(["solve", "--task", TASK, "--method", "greedy", "--option", "time_limt=5"]) == 2
    said = typo.partition("; it takes:")[0]  # the list: as each door spells the options
    assert f"{said}; it takes: --option prune=..., --time-limit" in capsys.readouterr().err
    for method in ("exhaustive", "anytime", "ppo", "ppo-guided"):
        with pytest.raises(TypeError, match="bogus_option"):
            make_solver(method, bogus_option=1)
    with pytest.raises(ValueError) as err:
        make_solver("milp", fault="rotor")
    refusal = str(err.value)
    assert main(["solve", "--task", TASK, "--method", "milp", "--fault", "rotor"]) == 2
    assert capsys.readouterr().err.strip() == f"modquad: error: {refusal}"
    milp = make_solver("milp")
    with pytest.raises(ValueError, match="cannot honour fault='rotor'"):
        milp.solve(mq.SearchProblem(load_task(TASK), fault="rotor"))
    with pytest.raises(TypeError, match="has no option 'model'"):
        make_solver("greedy", model="x.zip")
    assert main(["solve", "--task", TASK, "--method", "exhaustive", "--seed", "3"]) == 2
    assert "does not take it" in capsys.readouterr().err


def test_a_result_says_its_status():
    task = load_task(TASK)
    assert mq.exhaustive_search(task, n_max=5).status == "optimal"
    r = mq.exhaustive_search(task, n_max=2)
    assert r.status == mq.Status.INFEASIBLE and "no structure of up to 2" in r.message
    g = mq.greedy_search(task, n_max=2)
    assert g.status in ("no answer", "infeasible") and g.to_dict()["status"] == str(g.status)
    fake = mq.search.SearchResult(mq.Structure([(0, 0), (1, 0), (2, 0)]), 3, 1, 1, 0.0, False,
                                  "x", 7, lower_bound=2)  # fmt: skip
    assert fake.status == "feasible" and not fake.certified


class _Line(MethodSolver):
    """The toy method's solver: the shortest horizontal line that does the task."""

    def solve(self, task):
        problem = self.problem(task)
        for n in range(1, problem.n_max + 1):
            s = mq.Structure([(i, 0) for i in range(n)])
            if problem.decide(s).all():
                return mq.search.SearchResult(s, n, n, n * len(problem.wrenches), 0.0, False,
                                              self.name, problem.n_max)  # fmt: skip
        return mq.search.SearchResult(None, None, problem.n_max, 0, 0.0, False, self.name,
                                      problem.n_max)  # fmt: skip


def test_a_method_registered_once_is_in_every_door(capsys, tmp_path):
    toy = Method(
        "toy-line",
        "the shortest horizontal line that does the task",
        options("toy-line", reach=(int, 0, "unused: shows an option in the table", None)),
        _Line,
        timed=False,
    )
    register(toy)  # the one registration line
    try:
        r = make_solver("toy-line", n_max=5).solve(load_task(TASK))
        assert r.n_modules == 3 and REGISTRY["toy-line"] is toy
        assert main(["solve", "--task", TASK, "--method", "toy-line", "--json"]) == 0
        assert json.loads(capsys.readouterr().out)["cells"] == [[0, 0], [1, 0], [2, 0]]
        assert main(["solve", "--task", TASK, "--method", "toy-line", "--option", "reach=2"]) == 0
        with pytest.raises(TypeError, match="it takes: reach"):
            make_solver("toy-line", time_limit=1)
        out = tmp_path / "score"
        argv = ["score", "--methods", "toy-line", "greedy", "--limit", "2", "--no-progress",
                "--out", str(out)]  # fmt: skip
        assert main(argv) == 0
        assert "toy-line" in (out / "benchmark.csv").read_text()
        assert "`toy-line`" in mq.methods.table()
    finally:
        unregister("toy-line")
    with pytest.raises(SystemExit) as exit_:
        main(["solve", "--task", TASK, "--method", "toy-line"])
    assert exit_.value.code == 2 and "unknown method 'toy-line'" in capsys.readouterr().err


def test_the_options_dataclasses_match_the_searches():
    import inspect

    for name, search in SEARCHES.items():
        keywords = [
            p.name
            for p in inspect.signature(search.solve).parameters.values()
            if p.kind is p.KEYWORD_ONLY
        ] + (["prune"] if search.prunes else [])
        assert list(REGISTRY[name].options.names()) == keywords
    with pytest.raises(ValueError):
        REGISTRY["beam"].settings(beam_width=0)
    with pytest.raises(ValueError):
        REGISTRY["genetic"].settings(mutation_rate=1.5)
    assert REGISTRY["beam"].options.parse("beam", "beam_width=8") == ("beam_width", 8)
    with pytest.raises(ValueError, match="seed takes no none"):  # None is only its default
        REGISTRY["anytime"].options.parse("anytime", "seed=none")


def test_the_evaluator_decides_the_problem_with_its_fault():
    from modquad_gym.solvers import Evaluator

    task = load_task(TASK)
    problem = mq.SearchProblem(task, n_max=6, fault="rotor")
    ev = Evaluator(problem)
    best = mq.exhaustive_search(task, n_max=5).structure  # intact optimum: fails a rotor
    assert (
        not ev.evaluate(best)
        and mq.feasible(best.configuration_matrix(), task.rotor_wrenches(best), task.f_max).all()
    )
    tolerant = mq.exhaustive_search(problem).structure
    assert ev.evaluate(tolerant) and np.all(problem.decide(tolerant))


def test_an_option_that_contradicts_the_variant_name_is_refused_alike(capsys):
    for method, option, value in (("ppo-k8", "samples", 2), ("ppo-guided-nodive", "dive", True),
                                  ("ppo-guided-b16", "budget", 32)):  # fmt: skip
        with pytest.raises(ValueError) as err:
            make_solver(method, **{option: value})
        refusal = str(err.value)
        assert f"method {method!r} sets {option}=" in refusal
        argv = ["solve", "--task", TASK, "--method", method, "--option", f"{option}={value}"]
        assert main(argv) == 2
        assert capsys.readouterr().err.strip() == f"modquad: error: {refusal}"
    assert make_solver("ppo-k8", samples=8).name == "ppo-k8"  # saying it again is no clash
