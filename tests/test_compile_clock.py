"""A search's ``seconds`` leave out the kernels numba compiles during it (once, on a cold
cache: tens of seconds for the learned solver's first run): its result says how long that took.
Every kernel of the package compiles through ``modquad_gym.core.jit``, whose clock hears each
compilation numba makes."""

from __future__ import annotations

import ast
import time
from pathlib import Path

import numpy as np

from modquad_gym.core.compile_clock import compile_seconds, now
from modquad_gym.core.jit import njit
from modquad_gym.policy.policy import search_result
from modquad_gym.search.problem import SearchProblem
from modquad_gym.search.result import SearchRun

PACKAGE = Path(__file__).resolve().parents[1] / "modquad_gym"


def _compile_a_new_kernel() -> None:
    """Compile a kernel no cache holds (a new function object: numba compiles it now), named
    as one of the package's (the clock counts only those)."""

    def kernel(x):
        total = 0.0
        for i in range(x.shape[0]):
            total += np.sin(x[i]) * i
        return total

    kernel.__module__ = "modquad_gym.core.jit"
    njit(cache=False)(kernel)(np.arange(3.0))


def test_a_compilation_during_a_search_is_left_out_of_its_seconds():
    began = time.perf_counter()
    run = SearchRun("greedy", SearchProblem.build([[0, 0, 1, 0, 0, 0]], n_max=3))
    _compile_a_new_kernel()
    result = run.finish(None, 1)
    wall = time.perf_counter() - began
    assert result.compile_seconds > 0
    assert result.seconds < result.compile_seconds  # the rest is a few microseconds here
    assert abs(result.seconds + result.compile_seconds - wall) < 0.05
    assert "compiling kernels once (cached for later runs) took" in result.message
    assert result.to_dict()["compile_seconds"] == round(result.compile_seconds, 3)


def test_the_learned_solvers_record_leaves_it_out_too():
    problem = SearchProblem.build([[0, 0, 1, 0, 0, 0]], n_max=3)
    t0, compiled = now(), compile_seconds()  # the search clock: compilation left out
    _compile_a_new_kernel()
    result = search_result("ppo", problem, None, 0, 0, t0, compiled=compiled)
    assert 0 < result.seconds < result.compile_seconds
    warm = SearchRun("greedy", problem).finish(None, 1)  # nothing compiled: nothing said
    assert warm.compile_seconds == 0 and "compiling" not in warm.message


def test_every_kernel_module_takes_njit_from_the_clocked_decorator():
    """``from numba import njit`` elsewhere in the package would compile unseen by the clock."""
    direct = []
    for path in PACKAGE.rglob("*.py"):
        if path.name == "jit.py" and path.parent.name == "core":
            continue
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.ImportFrom) and node.module == "numba":
                direct += [f"{path.relative_to(PACKAGE)}: {a.name}" for a in node.names]
            if isinstance(node, ast.Import) and any(a.name == "numba" for a in node.names):
                direct.append(f"{path.relative_to(PACKAGE)}: import numba")
    assert not direct


def test_a_users_own_numba_code_is_not_the_packages_compilation():
    import numba
    from numba.core import event

    import modquad_gym.core.jit  # noqa: F401 (the listener)
    from modquad_gym.core.compile_clock import compile_seconds

    before = compile_seconds()

    @numba.njit
    def users_own(x):
        return x * 2.0 + 1.0

    assert users_own(2.0) == 5.0  # compiled here, outside the package
    event.start_event("numba:compile")  # any code opening the event itself
    time.sleep(0.2)
    event.end_event("numba:compile")
    assert compile_seconds() - before < 0.01


def test_another_threads_compilation_is_not_this_threads():
    import threading

    from modquad_gym.core import compile_clock

    before = compile_clock.compile_seconds()

    def compiles():
        compile_clock.started()
        time.sleep(0.3)
        compile_clock.ended()

    t = threading.Thread(target=compiles)
    t.start()
    t.join()
    assert compile_clock.compile_seconds() - before < 0.01
