"""A keyword given beside a SearchProblem: taken where it says what the problem says, refused
(naming it) where it would change the problem, alike by a search function and by a solver's
``solve`` (docs/search.md)."""

from __future__ import annotations

import pytest

import modquad_gym as mq
from modquad_gym.geometry.module import palette
from modquad_gym.search import SEARCHES
from modquad_gym.search.problem import PROBLEM_FIELDS
from modquad_gym.solvers import make_solver
from modquad_gym.tasks import load_task

TASK = load_task("example:screwdriver")  # optimum 3 modules; 4 after any single rotor failure
PROBLEM = mq.SearchProblem(TASK, n_max=3, fault="rotor", fault_margin=0.05)
TYPED = mq.SearchProblem(TASK, n_max=2, modules="t45,flat")
SAME = {
    "n_max": PROBLEM.n_max,
    "f_max": PROBLEM.f_max,
    "module": mq.TModule(),
    "kind": PROBLEM.kind,
    "fault": PROBLEM.fault,
    "fault_margin": PROBLEM.fault_margin,
}
OTHER = {
    "n_max": PROBLEM.n_max + 1,
    "f_max": 2.0 * PROBLEM.f_max,
    "module": mq.TModule(eta=0.3),
    "kind": "external",
    "fault": "module",
    "fault_margin": 0.1,
}


def _answer(result: mq.SearchResult) -> tuple:
    return (result.structure, result.status, result.n_max, result.fault, result.lower_bound)


def test_the_cases_cover_every_field_of_a_problem():
    assert set(SAME) | {"modules"} == set(PROBLEM_FIELDS) == set(OTHER) | {"modules"}


@pytest.mark.parametrize("field", sorted(SAME))
def test_a_search_takes_a_keyword_the_problem_already_says(field):
    alone = mq.exhaustive_search(PROBLEM)
    assert _answer(mq.exhaustive_search(PROBLEM, **{field: SAME[field]})) == _answer(alone)


@pytest.mark.parametrize("field", sorted(OTHER))
@pytest.mark.parametrize("name", sorted(SEARCHES))
def test_every_search_refuses_a_keyword_that_would_change_the_problem(name, field):
    with pytest.raises(ValueError, match=rf"^{field}=.* given beside a SearchProblem"):
        SEARCHES[name](PROBLEM, **{field: OTHER[field]})


def test_a_palette_beside_a_problem_is_taken_only_when_it_is_the_problems():
    alone = _answer(mq.exhaustive_search(TYPED))
    assert _answer(mq.exhaustive_search(TYPED, modules="t45,flat")) == alone
    assert _answer(mq.exhaustive_search(TYPED, modules=palette("t45,flat"))) == alone
    for field, value in (("modules", "flat,t45"), ("modules", "t45"), ("module", mq.TModule())):
        with pytest.raises(ValueError, match=rf"^{field}=.* given beside a SearchProblem"):
            mq.exhaustive_search(TYPED, **{field: value})
    with pytest.raises(ValueError, match=r"^modules=.* given beside a SearchProblem"):
        mq.exhaustive_search(PROBLEM, modules="t45")  # one type, but the problem lists none


def test_a_solver_judges_a_problem_as_the_search_functions_do():
    """``make_solver`` takes n_max, modules, fault and fault_margin: the same values pass both
    doors and a different one is refused by both."""
    settings = {k: SAME[k] for k in ("n_max", "fault", "fault_margin")}
    by_search = mq.greedy_search(PROBLEM, time_limit=20.0, **settings)
    by_solver = make_solver("greedy", time_limit=20.0, **settings).solve(PROBLEM)
    assert _answer(by_search) == _answer(by_solver)
    for field in settings:
        other = {field: OTHER[field], "fault": OTHER["fault"] if field == "fault" else "rotor"}
        with pytest.raises(ValueError, match=rf"^the solver was made with {field}="):
            make_solver("greedy", **other).solve(PROBLEM)
        with pytest.raises(ValueError, match=rf"^{field}=.* given beside a SearchProblem"):
            mq.greedy_search(PROBLEM, **{field: OTHER[field]})
    typed = make_solver("exhaustive", n_max=2, modules="t45,flat").solve(TYPED)
    assert _answer(typed) == _answer(mq.exhaustive_search(TYPED, n_max=2, modules="t45,flat"))
    with pytest.raises(ValueError, match="^the solver was made with modules="):
        make_solver("exhaustive", modules="flat,t45").solve(TYPED)
