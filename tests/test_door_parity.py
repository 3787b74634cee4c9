"""One door: the Python API and the ``modquad`` command line give the same answers and refuse the
same inputs in the same words (each door spelling the option its own way)."""

from __future__ import annotations

import pytest

import modquad_gym as mq
from modquad_gym.tasks import load_task

PAPER = "example:paper_seed0"


# ------------------------------------------------------------------ seed=None is the default
@pytest.mark.parametrize(
    "method, options",
    [
        ("random", {"restarts": 4}),
        ("beam", {}),
        ("genetic", {"generations": 20}),
    ],
)
def test_seed_none_is_seed_zero_in_every_door(method, options):
    """seed=None drew fresh entropy in the search functions and meant seed 0 in make_solver."""
    task = load_task(PAPER)
    search = getattr(mq, f"{method}_search")
    answers = [search(task, seed=None, time_limit=20, **options) for _ in range(2)]
    answers.append(mq.make_solver(method, seed=None, time_limit=20, **options).solve(task))
    answers.append(search(task, seed=0, time_limit=20, **options))
    got = {(r.structure.cells, r.evaluated) for r in answers}
    assert len(got) == 1, got


def test_seed_none_of_the_anytime_search_is_seed_zero():
    task = load_task("example:screwdriver")
    a = mq.anytime_search(task, seed=None, time_limit=20)
    b = mq.make_solver("anytime", seed=None, time_limit=20).solve(task)
    assert a.structure.cells == b.structure.cells and a.certified and b.certified


@pytest.mark.parametrize("door", ["search", "make_solver"])
def test_restarts_none_is_refused_naming_it(door):
    """It was `TypeError: 'NoneType' object cannot be interpreted as an integer`."""
    task = load_task(PAPER)
    with pytest.raises(ValueError, match=r"^restarts must be an integer, got None$"):
        if door == "search":
            mq.random_search(task, restarts=None)
        else:
            mq.make_solver("random", restarts=None).solve(task)
