"""Seconds this thread has spent compiling the package's kernels, which no search counts.

numba compiles a kernel on its first call when its on-disk cache is cold (a fresh install, or
after the package's compiled sources changed: :mod:`.kernel_caches`): tens of seconds once,
then milliseconds to load from the cache. That is not the search's work: a search's
``seconds`` leaves it out (its result says how long it took), and so does every deadline a
search holds, so that a cold cache changes no answer. A deadline is a time on the search
clock, :func:`now` (``time.perf_counter()`` less the compilation so far): a deadline set
``budget`` seconds ahead passes once the wall time since, less the compilation since, exceeds
the budget. :mod:`.jit`, the package's ``njit``, winds the clock before any kernel compiles;
this module imports no numba, so a search that compiles nothing never loads it.
"""

from __future__ import annotations

import threading
import time

_local = threading.local()  # each thread's clock: a search runs in one thread


def _clock() -> dict:
    if not hasattr(_local, "clock"):
        _local.clock = {"seconds": 0.0, "depth": 0, "since": 0.0}
    return _local.clock


def compile_seconds() -> float:
    """Seconds this thread has spent compiling the package's kernels so far (a nested
    compilation, a kernel compiling the kernels it calls, counts once; one in progress up to
    now). Another thread's compilation, or a user's own numba code, is not counted."""
    clock = _clock()
    running = time.perf_counter() - clock["since"] if clock["depth"] else 0.0
    return clock["seconds"] + running


def started() -> None:
    """A compilation started (numba's ``numba:compile`` event, sent on a cache miss only)."""
    clock = _clock()
    if clock["depth"] == 0:
        clock["since"] = time.perf_counter()
    clock["depth"] += 1


def ended() -> None:
    """A compilation ended."""
    clock = _clock()
    clock["depth"] -= 1
    if clock["depth"] == 0:
        clock["seconds"] += time.perf_counter() - clock["since"]


def now() -> float:
    """The search clock: :func:`time.perf_counter` less :func:`compile_seconds` (it stands
    still while a kernel compiles). Every search's deadlines and ``seconds`` run on it."""
    return time.perf_counter() - compile_seconds()


def from_perf_counter(t: float) -> float:
    """The :func:`time.perf_counter` time ``t`` (a caller's deadline) on the search clock: the
    compilation from now on moves it later."""
    return t - compile_seconds()


def to_perf_counter(at: float) -> float:
    """The :func:`time.perf_counter` time at which the search clock reaches ``at`` if nothing
    compiles meanwhile (for a door that takes a ``perf_counter`` deadline)."""
    return at + compile_seconds()
