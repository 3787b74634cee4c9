"""Fault-aware searches keep their time limit on a large task (issue 47): a generated planted
task whose answer has about 48 modules, searched with a rotor and a module fault."""

import time

import numpy as np
import pytest

import modquad_gym as mq
from modquad_gym.tasks import PlantedTasks


@pytest.fixture(scope="module")
def task48():
    task = PlantedTasks(n_modules=48)(np.random.default_rng(1))
    # compile (or load from numba's cache) every kernel the searches use, outside the clocks:
    # on a clean checkout the first use compiles for seconds
    mq.anytime_search(task, n_max=64, time_limit=1.0, fault="module")
    return task


def within(seconds: float, limit: float) -> bool:
    """The issue's rule: within the limit, give or take 10 % or 1 s (the larger)."""
    return seconds <= limit + max(0.1 * limit, 1.0)


@pytest.mark.parametrize(("fault", "limit"), [("rotor", 5.0), ("module", 10.0)])
def test_anytime_keeps_its_limit_with_a_fault(task48, fault, limit):
    t0 = time.perf_counter()
    r = mq.anytime_search(task48, n_max=64, time_limit=limit, fault=fault)
    wall = time.perf_counter() - t0
    assert within(wall, limit), f"{fault}: {wall:.1f} s for a {limit:g} s limit"
    assert r.structure is not None  # its best structure (re-verified by finish) and its bound
    assert 40 <= r.lower_bound <= r.n_modules
    W = task48.rotor_wrenches(r.structure)
    assert mq.tolerates(r.structure, W, task48.f_max, fault=fault, method="compiled").all()


def test_genetic_stops_while_scoring_its_first_population(task48):
    # each 48-module candidate takes ~0.5 s to score with a rotor fault: the first population
    # alone (24) used to run 11 s past a 5 s limit
    t0 = time.perf_counter()
    r = mq.genetic_search(task48, n_max=64, time_limit=1.0, fault="rotor")
    assert within(time.perf_counter() - t0, 1.0)
    assert r.lower_bound >= 40


def test_validate_estimate_counts_every_design():
    """validate --fault searches and flies the tolerant design and the intact minimum, and with
    a margin the design without it too: its estimate says so (it said two searches for three)."""
    import argparse

    from modquad_gym.cli.validate_fault import fault_seconds, search_seconds_text

    task = mq.TaskRequirement.load(mq.tasks.example_path("screwdriver"))
    plain = argparse.Namespace(fault="rotor", fault_margin=None, detection_delay=None,
                               time_limit=10.0)  # fmt: skip
    delayed = argparse.Namespace(**{**vars(plain), "detection_delay": 0.05})
    assert search_seconds_text(plain) == ", plus two searches of at most 10 s each"
    assert search_seconds_text(delayed) == ", plus three searches of at most 10 s each"
    assert fault_seconds(delayed, task) == pytest.approx(1.5 * fault_seconds(plain, task))
    assert fault_seconds(argparse.Namespace(**{**vars(plain), "fault": None}), task) == 0.0
