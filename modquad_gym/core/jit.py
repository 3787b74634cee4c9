"""The package's kernel decorator: numba's ``njit``, with the compile clock running.

Every kernel module imports ``njit`` from here, so that the listener below is registered before
the first kernel compiles: it tells :mod:`.compile_clock` of each compilation of one of this
package's kernels (numba's ``numba:compile`` event, on a cache miss only).
"""

from __future__ import annotations

from numba import njit
from numba.core import event

from modquad_gym.core import compile_clock

__all__ = ["njit"]


class _Clock(event.Listener):
    """Tells :mod:`.compile_clock` when numba starts and ends compiling one of this package's
    kernels (a user's or an outside agent's own numba code is their time, not ours)."""

    def on_start(self, event) -> None:
        if _ours(event):
            compile_clock.started()

    def on_end(self, event) -> None:
        if _ours(event):
            compile_clock.ended()


def _ours(event) -> bool:
    """Is the dispatcher ``event`` compiles one of this package's kernels?"""
    dispatcher = (event.data or {}).get("dispatcher")
    module = getattr(getattr(dispatcher, "py_func", None), "__module__", None) or ""
    return module.startswith("modquad_gym.")


event.register("numba:compile", _Clock())
