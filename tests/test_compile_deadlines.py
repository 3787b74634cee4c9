"""A kernel compiling on a cold cache changes no search's answer: every deadline a search holds
runs on the search clock (``compile_clock.now``: ``perf_counter`` less the compilation so far),
so a compilation longer than the time limit neither stops the search nor cuts a fault decision.

The compilation is simulated: the search's first exact decision "compiles" for :data:`COMPILE`
seconds (it sleeps with the compile clock running, as numba's compile event winds it), longer
than the time limit :data:`LIMIT`, on a task the searches answer in milliseconds once warm."""

from __future__ import annotations

import ast
import time
from pathlib import Path

import numpy as np
import pytest

import modquad_gym as mq
from modquad_gym.core import compile_clock
from modquad_gym.envs.assembly.evaluator import StructureEvaluator
from modquad_gym.oracle import fault_kernels, faults
from modquad_gym.oracle.faults import FaultTolerance, failure_sets
from modquad_gym.search.checker import TaskChecker

COMPILE = 1.2
LIMIT = 1.0
PACKAGE = Path(__file__).resolve().parents[1] / "modquad_gym"


def _compiling_first(original, left: list):
    """``original`` whose first call (across every wrapper sharing ``left``) compiles first."""

    def call(*args, **kwargs):
        if left:
            left.pop()
            compile_clock.started()
            try:
                time.sleep(COMPILE)
            finally:
                compile_clock.ended()
        return original(*args, **kwargs)

    return call


@pytest.fixture
def slow_compile(monkeypatch):
    """``slow_compile()``: from now on, the next search's first exact decision (a search's
    checker or the environment's evaluator; with ``in_fault``, its first fault certificate)
    compiles for :data:`COMPILE` seconds; the list it returns empties once it did."""

    def arm(in_fault: bool = False) -> list:
        left = [1]
        if in_fault:
            monkeypatch.setattr(faults, "decide_with", _compiling_first(faults.decide_with, left))
            return left
        monkeypatch.setattr(TaskChecker, "decide", _compiling_first(TaskChecker.decide, left))
        evaluate = _compiling_first(StructureEvaluator.evaluate, left)
        monkeypatch.setattr(StructureEvaluator, "evaluate", evaluate)
        return left

    return arm


def _outcome(r) -> tuple:
    cells = None if r.structure is None else sorted(map(tuple, r.structure.cells))
    return r.status, r.n_modules, cells, r.lower_bound, r.evaluated


@pytest.mark.parametrize(
    "method, task, fault",
    [("greedy", "planted_seed1", None), ("beam", "planted_seed1", None),
     ("genetic", "planted_seed1", None), ("milp", "planted_seed1", None),
     ("ppo", "planted_seed1", None), ("ppo-guided", "planted_seed1", None),
     ("anytime", "planted_seed1", None),
     ("beam", "screwdriver", "rotor"), ("anytime", "screwdriver", "rotor")],
)  # fmt: skip
def test_a_compilation_longer_than_the_limit_changes_no_answer(method, task, fault, slow_compile):
    """With a fault the compilation happens inside a fault decision, which the search's
    deadline interrupts."""
    task = mq.TaskRequirement.load(mq.tasks.example_path(task))
    solver = mq.make_solver(method, n_max=7, time_limit=LIMIT, fault=fault)
    warm = solver.solve(task)
    assert warm.structure is not None
    left = slow_compile(in_fault=fault is not None)
    t0 = time.perf_counter()
    cold = solver.solve(task)
    wall = time.perf_counter() - t0
    assert not left and cold.compile_seconds >= COMPILE  # the compilation happened
    assert _outcome(cold) == _outcome(warm)
    assert wall - cold.compile_seconds <= LIMIT
    assert cold.seconds <= LIMIT


def test_the_search_clock_stands_still_while_a_kernel_compiles():
    before, compiled = compile_clock.now(), compile_clock.compile_seconds()
    compile_clock.started()
    time.sleep(0.3)
    assert compile_clock.now() - before < 0.1  # also while it is in progress
    compile_clock.ended()
    assert compile_clock.now() - before < 0.1
    assert compile_clock.compile_seconds() - compiled >= 0.3


def test_a_fault_decision_moves_its_deadline_by_what_compiles_during_it(monkeypatch):
    """``tolerates(deadline=)`` takes a perf_counter time: a kernel compiling during the call
    moves it later by as long, so the decision still answers (it was interrupted)."""
    s = mq.Structure([(0, 0), (1, 0), (0, 1), (1, 1), (2, 0), (2, 1)])
    A = s.configuration_matrix()
    W = np.random.default_rng(1).uniform(-0.5, 0.5, (12, 6)) * 0.2 + [0, 0, 6, 0, 0, 0]
    failures = failure_sets(A.shape[1], "rotor")
    full = FaultTolerance(A, 1.0, failures).decide(W, "auto")
    monkeypatch.setattr(faults, "CHUNK_PAIRS", 2 * len(failures))  # two wrenches a chunk
    certify = _compiling_first(fault_kernels.certify_rows, [1])
    monkeypatch.setattr(fault_kernels, "certify_rows", certify)
    got = mq.tolerates(s, W, fault="rotor", deadline=time.perf_counter() + 0.5)
    assert np.array_equal(got, full)
    with pytest.raises(faults.DecisionInterruptedError):  # a deadline past is still past
        mq.tolerates(s, W, fault="rotor", deadline=time.perf_counter() - 0.1)


ALLOWED_PERF_COUNTER = {
    "search/progress.py",  # how often the progress line is redrawn
    "search/portfolio.py",  # how often the producers' results are polled
    "search/milp_worker.py",  # the HiGHS worker process's own limit (nothing compiles there)
}


def test_no_search_reads_the_wall_clock_for_a_deadline():
    """Searches and the learned solvers time themselves on the search clock; ``perf_counter``
    is read only where no deadline is (a new deadline on it would count compilation again)."""
    found = []
    for folder in ("search", "policy", "oracle"):
        for path in sorted((PACKAGE / folder).glob("*.py")):
            name = f"{folder}/{path.name}"
            tree = ast.parse(path.read_text())
            uses = [n for n in ast.walk(tree) if isinstance(n, ast.Attribute)
                    and n.attr == "perf_counter"]  # fmt: skip
            if uses and name not in ALLOWED_PERF_COUNTER:
                found.append(name)
    assert not found
