"""Seconds this process has spent compiling kernels: what a search's ``seconds`` leaves out.

numba compiles a kernel on its first call when its on-disk cache is cold (a fresh install, or
after the package's compiled sources changed: :mod:`.kernel_caches`): tens of seconds once,
then milliseconds to load from the cache. That is not the search's work, so a search's
``seconds`` leaves it out and its result says how long it took. :mod:`.jit`, the package's
``njit``, winds the clock before any kernel compiles; this module imports no numba, so a
search that compiles nothing never loads it.
"""

from __future__ import annotations

import time

_clock = {"seconds": 0.0, "depth": 0, "since": 0.0}


def compile_seconds() -> float:
    """Seconds this process has spent compiling kernels so far (a nested compilation, a kernel
    compiling the kernels it calls, counts once; one in progress up to now)."""
    running = time.perf_counter() - _clock["since"] if _clock["depth"] else 0.0
    return _clock["seconds"] + running


def started() -> None:
    """A compilation started (numba's ``numba:compile`` event, sent on a cache miss only)."""
    if _clock["depth"] == 0:
        _clock["since"] = time.perf_counter()
    _clock["depth"] += 1


def ended() -> None:
    """A compilation ended."""
    _clock["depth"] -= 1
    if _clock["depth"] == 0:
        _clock["seconds"] += time.perf_counter() - _clock["since"]
