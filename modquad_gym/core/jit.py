"""The package's kernel decorator: numba's ``njit``, with the compile clock running.

Every kernel module imports ``njit`` from here, so that :mod:`.compile_clock` hears of every
compilation numba makes in this process (its ``numba:compile`` event, on a cache miss only)
before the first kernel compiles.
"""

from __future__ import annotations

from numba import njit
from numba.core import event

from modquad_gym.core import compile_clock

__all__ = ["njit"]


class _Clock(event.Listener):
    """Tells :mod:`.compile_clock` when numba starts and ends a compilation."""

    def on_start(self, event) -> None:
        compile_clock.started()

    def on_end(self, event) -> None:
        compile_clock.ended()


event.register("numba:compile", _Clock())
