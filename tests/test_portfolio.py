"""The anytime search's incumbent producers (issue 35, item 1): in this process after the local
moves, or as Ray tasks beside them (``modquad solve --workers N``), one incumbent and one bound;
a caller's producer (the learned designer's guided search) joins through ``producers=``."""

from __future__ import annotations

import sys
import time

import numpy as np
import pytest

import modquad_gym.search.anytime as anytime
from benchmarks.scale_suites import draw
from modquad_gym.core.distributed import Engine, Failed
from modquad_gym.core.flight import launch
from modquad_gym.geometry.structure import Structure
from modquad_gym.search import SearchProblem, anytime_search, verified
from modquad_gym.search.result import SearchResult
from modquad_gym.tasks import TaskRequirement
from tests.test_scale_suites import hidden_structure

ray = pytest.importorskip("ray")


def planted_answer(problem, time_limit, seed):
    """A caller's producer: the structure the validation draw was planted in."""
    task = draw("torque", 32, 0, validation=True)
    s = hidden_structure(task)
    assert verified(s, task)
    return SearchResult(
        structure=s,
        n_modules=s.n_modules,
        evaluated=1,
        oracle_calls=7,
        seconds=0.0,
        certified=False,
        method="planted",
        n_max=problem.n_max,
    )


def test_a_task_the_quick_exact_levels_decide_never_starts_ray():
    task = TaskRequirement([[0, 0, 6, 0, 0, 0], [0.3, 0, 4, 0.1, -0.05, 0]])
    with Engine(2) as engine:
        r = anytime_search(task, n_max=8, time_limit=20, engine=engine)
    assert r.certified and r.structure is not None and not ray.is_initialized()


def test_a_callers_producer_feeds_the_incumbent_in_this_process(monkeypatch):
    """Serial: producers run after the local moves (switched off here); the smaller verified
    structure is the answer, their work is counted and the history names them."""
    task = draw("torque", 32, 0, validation=True)
    monkeypatch.setattr(anytime.ExactLevels, "fits", lambda self, n: False)
    monkeypatch.setattr(anytime.Incumbents, "first", lambda self, lower: False)
    none = anytime_search(task, n_max=40, time_limit=4, producers=())
    assert none.structure is None
    r = anytime_search(task, n_max=40, time_limit=4, producers=(planted_answer,))
    assert r.n_modules == 32 and r.history[-1].source == "planted"
    assert r.evaluated >= none.evaluated + 1 and r.lower_bound <= 32
    one = Structure([(0, 0)])  # a lift only 34 or more modules exert: the 32 planted cannot
    lift = (
        33.5
        * np.clip(one.configuration_matrix()[2], 0, None).sum()
        * TaskRequirement([[0] * 6]).f_max
    )
    wrong = anytime_search(
        [[0, 0, lift, 0, 0, 0]], n_max=40, time_limit=4, producers=(planted_answer,)
    )
    assert wrong.structure is None  # a producer's answer is decided before it is taken


@pytest.fixture(scope="module")
def local_ray():
    """One embedded Ray (2 CPUs) for the tests below; this module's functions travel by value."""
    ray.cloudpickle.register_pickle_by_value(sys.modules[__name__])
    from modquad_gym.core.ray_session import shutdown, start_local

    options = {"include_dashboard": False, "log_to_driver": False, "logging_level": "ERROR"}
    session = start_local(ray, 2, options)
    yield
    shutdown(ray, session)  # its session folder too


def slow_square(x):
    if x < 0:
        raise ValueError(f"negative item {x}")
    time.sleep(0.05 if x < 100 else 60)
    return x * x


def test_a_flight_runs_in_the_background_and_reports_failures(local_ray):
    with Engine(2) as engine, launch(engine, slow_square, [3, -1, 4, 1000], in_flight=1) as flight:
        got: dict = {}
        deadline = time.time() + 60
        while len(got) < 3 and time.time() < deadline:
            got.update(flight.ready(timeout=1.0))
        assert got[0] == 9 and got[2] == 16
        assert isinstance(got[1], Failed) and "negative item -1" in got[1].error
        assert not flight.done  # the slow one is still running: closing cancels it
    with pytest.raises(RuntimeError, match="needs an engine with Ray"):
        launch(Engine(1), slow_square, [1], in_flight=1)


def test_producers_on_workers_feed_the_incumbent_while_the_search_runs(local_ray, monkeypatch):
    """With workers the producers start beside the exact levels; here this process finds
    nothing by itself (moves off), so the answer is a producer's, verified, with the proved
    bound; a caller's producer travels to the workers too."""
    task = draw("torque", 32, 0, validation=True)  # the exact levels stop short of its optimum
    monkeypatch.setattr(anytime.Incumbents, "first", lambda self, lower: False)
    with Engine(2) as engine:
        r = anytime_search(task, n_max=40, time_limit=12, engine=engine)
        if r.structure is None:  # a loaded machine: the producers need longer than 12 s
            r = anytime_search(task, n_max=40, time_limit=60, engine=engine)
        assert verified(r.structure, task) and r.lower_bound <= r.n_modules
        assert {e.source for e in r.history} & {"beam", "genetic", "greedy"}
        t0 = time.perf_counter()
        mine = anytime_search(task, n_max=40, time_limit=8, engine=engine,
                              producers=(planted_answer,))  # fmt: skip
    assert mine.n_modules <= 32 and "planted" in {e.source for e in mine.history}
    assert time.perf_counter() - t0 < 8 + 10  # its limit, and room for the workers' start


def test_the_policy_joins_the_producers_when_its_extra_is_installed():
    pytest.importorskip("sb3_contrib")
    from modquad_gym.policy.guided import guided_producer, producers_with_policy

    assert guided_producer in producers_with_policy()
    task = TaskRequirement([[0, 0, 6, 0, 0, 0], [0.3, 0, 4, 0.1, -0.05, 0]])
    r = guided_producer(SearchProblem.build(task, n_max=6), time_limit=10)
    assert verified(r.structure, task)
    assert guided_producer(SearchProblem.build(task, n_max=6, fault="rotor"), 10) is None


def test_rays_start_is_not_the_searchs_time(local_ray, monkeypatch):
    """Ray's start (made 2 s slow here) stops the search's clock: the search still gets its
    whole time limit of work, returns the one-process answer within that limit, and says how
    long the start took. A lift only 20 modules exert, beyond the exact levels' reach: they
    decide nothing, so the search starts Ray; the first compact shape meets the bound."""
    one = Structure([(0, 0)])
    lift = 19.5 * np.clip(one.configuration_matrix()[2], 0, None).sum()
    task = TaskRequirement([[0, 0, lift, 0, 0, 0]])
    here = anytime_search(task, n_max=24, time_limit=1.5)
    assert here.certified and here.n_modules == 20
    start, started = Engine.start, []

    def slow_start(engine):  # idempotent as Ray's: slow only the first time
        if not started:
            time.sleep(2.0)
            started.append(engine)
        start(engine)

    monkeypatch.setattr(Engine, "start", slow_start)
    t0 = time.perf_counter()
    r = anytime_search(task, n_max=24, time_limit=1.5, engine=Engine(2))
    wall = time.perf_counter() - t0
    assert r.structure.cells == here.structure.cells and r.certified
    assert r.seconds <= 1.5 + 0.5 and 2.0 <= r.ray_start_seconds < wall
    assert "Ray's start took 2." in r.message and "not counted in the time limit" in r.message
    assert r.to_dict()["ray_start_seconds"] == round(r.ray_start_seconds, 3)
