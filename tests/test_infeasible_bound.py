"""An infeasible answer states the strongest bound its search proved and the next step: a task
planted in 50 modules needs at least as many modules as its force bound says (47), whatever
n_max, so at n_max 7 ``lower_bound`` is that bound, not 8, and the words say "raise n_max to at
least 47" (on the command line "try --n-max 47 or more", in solve's line, in show's and
export's refusals and in validate's line), only within the method's reach."""

from __future__ import annotations

import numpy as np
import pytest
from test_hardening import run_main

import modquad_gym as mq
from modquad_gym.geometry.module import palette
from modquad_gym.policy.models import DEFAULT_MODEL
from modquad_gym.search import SEARCHES, force_lower_bound
from modquad_gym.search.beyond import bound_beyond
from modquad_gym.solvers import make_solver


@pytest.fixture(scope="module")
def big(tmp_path_factory) -> tuple[str, int]:
    """The README's 50-module planted task (its file) and its force bound."""
    path = tmp_path_factory.mktemp("big") / "big.json"
    mq.cli.main(["task", "generate", "--kind", "planted", "--n-modules", "50", "--seed", "3",
                 "--out", str(path)])  # fmt: skip
    task = mq.TaskRequirement.load(str(path))
    return str(path), force_lower_bound(task.wrenches, mq.TModule(), task.f_max)


@pytest.mark.parametrize("name", ["anytime", "exhaustive", "greedy", "beam", "milp"])
def test_the_lower_bound_is_the_force_bound_past_n_max(big, name):
    path, needed = big
    assert needed > 8  # the force bound proves more than "none of up to 7"
    r = SEARCHES[name](mq.TaskRequirement.load(path), n_max=7)
    assert (r.status, r.lower_bound, r.certified) == ("infeasible", needed, True)
    said = f"no structure of up to 7 modules satisfies the task (proved: it needs at least {needed}"
    assert r.message.startswith(said)
    if name == "exhaustive":  # beyond its reach of 16: no advice to raise n_max
        assert r.message.endswith("; exhaustive takes at most 16)")
    else:
        assert r.message.endswith(f"; raise n_max to at least {needed})")
    assert r.to_dict()["lower_bound"] == needed


@pytest.mark.skipif(not DEFAULT_MODEL.is_file(), reason="no shipped model")
def test_the_learned_solver_reports_the_same_bound(big):
    path, needed = big
    r = make_solver("ppo", n_max=7).solve(mq.TaskRequirement.load(path))
    assert (r.status, r.lower_bound) == ("infeasible", needed)


def test_the_command_line_names_the_bound_and_the_option(big, capsys, tmp_path):
    path, needed = big
    step = f"(proved: it needs at least {needed}; try --n-max {needed} or more)"
    code, out, _ = run_main(capsys, "solve", "--task", path, "--quiet")
    assert (
        code == 0
        and f"infeasible: no structure of up to 7 modules satisfies the task {step}" in out
    )
    for command, out_file in (("show", "s.png"), ("export", "s.urdf")):
        code, _, err = run_main(capsys, command, "--task", path, "--out", str(tmp_path / out_file),
                                "--quiet")  # fmt: skip
        assert code == 2 and f"for {path} {step}; nothing to" in err, command
        assert not (tmp_path / out_file).exists()
    code, out, _ = run_main(capsys, "validate", "--task", path, "--out", str(tmp_path / "v"),
                            "--quiet")  # fmt: skip
    assert code == 0 and f"no structure found for {path}; infeasible: " in out and step in out


def test_a_palette_gets_the_count_bound_and_a_force_nothing_exerts_says_so():
    """With several types the count bound, scanned level by level past n_max, raises the
    bound (each level it passes ruled out for every shape: tests/test_bounds_oracle_rule.py);
    where no number of modules exerts the forces, the bound stays n_max + 1 and the words say
    why; a bound beyond every search's reach gets no advice."""
    pal = palette("t45,flat")
    W = np.array([[3.0, 1.0, 60.0, 0.0, 0.0, 0.5]])
    r = SEARCHES["greedy"](W, n_max=7, modules=pal, kind="external")
    assert r.status == "infeasible" and r.lower_bound > 8
    assert r.message.endswith(f"raise n_max to at least {r.lower_bound})")
    exact = SEARCHES["exhaustive"](W, n_max=7, modules=pal, kind="external")
    assert exact.lower_bound == r.lower_bound > 16  # beyond the exhaustive search's reach
    assert exact.message.endswith("; exhaustive takes at most 16)")
    flat = palette("flat")[0]
    sideways = SEARCHES["anytime"]([[1.0, 0, 0, 0, 0, 0]], n_max=7, module=flat)
    assert (sideways.status, sideways.lower_bound) == ("infeasible", 8)
    assert sideways.message.endswith("(proved: no number of modules can exert the task's forces)")
    far = SEARCHES["anytime"]([[0, 0, 400.0, 0, 0, 0]], n_max=7)
    assert far.lower_bound > 128 and "raise n_max" not in far.message
    assert far.message.endswith(f"needs at least {far.lower_bound}; anytime takes at most 128)")


def heavy_problem(names: str = "t45,t45m,t30,t30m,flat", lift: float = 150.0) -> mq.SearchProblem:
    """An external task that five stock types (by default) cannot lift in 4 modules: the count
    bound's scan past n_max 4 runs through its whole work cap (review 22: a second at every
    time limit)."""
    task = mq.TaskRequirement(np.array([[0, 0, lift, 0, 0, 0]]), f_max=2.0, kind="external")
    return mq.SearchProblem(task, n_max=4, modules=palette(names))


@pytest.mark.parametrize("name", sorted(set(SEARCHES) - {"exhaustive"}))  # it has no limit
def test_an_infeasible_answer_keeps_the_time_limit(name):
    """The count bound's scan past n_max stops at the search's time limit (it took 1-1.9 s at a
    0.05 s limit), with the bound it proved by then: at least n_max + 1, at most the scan's."""
    problem = heavy_problem()
    r = SEARCHES[name](problem, time_limit=0.05)
    assert r.status == "infeasible" and r.seconds < 0.05 + 0.25, r.seconds
    assert problem.n_max + 1 <= r.lower_bound <= bound_beyond(problem, problem.n_max + 1)


@pytest.mark.skipif(not DEFAULT_MODEL.is_file(), reason="no shipped model")
def test_a_learned_answer_keeps_the_time_limit():
    problem = heavy_problem()
    solver = make_solver("ppo-guided", n_max=4, modules=problem.palette, time_limit=0.05)
    r = solver.solve(problem)
    assert r.status == "infeasible" and r.seconds < 0.05 + 0.25, r.seconds
    assert problem.n_max + 1 <= r.lower_bound <= bound_beyond(problem, problem.n_max + 1)


def test_the_scan_stops_when_its_time_is_up():
    problem = heavy_problem()
    n = problem.n_max + 1
    assert bound_beyond(problem, n, seconds=0.0) == n  # no time: the search's own bound
    assert bound_beyond(problem, n, seconds=None) > n  # the work cap alone proves more


def test_every_search_proves_the_same_bound():
    """One scan with one budget per answer: the anytime search scanned twice (from the bound,
    then again from where the first scan stopped) and proved more than the others."""
    problem = heavy_problem("t45,t45m,flat", lift=1e4)  # the scan stops at its work cap
    scan = bound_beyond(problem, problem.n_max + 1)
    assert scan > problem.n_max + 1
    for name, search in SEARCHES.items():
        r = search(problem)
        assert (r.status, r.lower_bound) == ("infeasible", scan), name
        if r.history:  # the progress shown ends at the bound reported
            assert r.history[-1].lower_bound == scan, name
