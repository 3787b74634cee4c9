"""Peak memory a benchmark reports is the run's own, not the size of the process that started it."""

import sys

import numpy as np
import pytest

from benchmarks.measure import fresh, measured, own_peak_mb


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="VmHWM is Linux's")
def test_a_fresh_run_reports_its_own_peak_not_its_big_parents():
    ballast = np.ones(400 * 2**20 // 8)  # this process now holds 400 MB more than its run
    assert own_peak_mb() > 400
    _, _, child_peak = fresh(measured, len, ())
    assert child_peak < own_peak_mb() - 300  # ru_maxrss read the parent's size here
    assert child_peak > 10  # a Python process with numpy, measured at all
    del ballast


def test_the_peak_grows_with_what_the_run_holds():
    _, _, before = measured(len, ())
    _, _, after = measured(lambda: np.ones(200 * 2**20 // 8).sum())
    assert after >= before
    assert after >= 200  # the array was resident at the peak


def compiled_before_and_after_warm_up() -> tuple[bool, bool]:
    """In a fresh process: whether the compiled polyomino kernel holds a loaded signature before
    and after :func:`warm_search`."""
    from benchmarks.measure import warm_search
    from modquad_gym.geometry import polyominoes

    def loaded() -> bool:
        return polyominoes._compiled.cache_info().currsize > 0 and bool(
            polyominoes._compiled().signatures
        )

    before = loaded()
    warm_search()
    return before, loaded()


def test_the_warm_up_loads_the_compiled_enumeration_a_timed_search_uses():
    # a timed run after a warm-up of one level only paid ~0.4 s of kernel loading (0.42 s for a
    # search that decided one structure, 0.008 s once loaded)
    assert fresh(compiled_before_and_after_warm_up) == (False, True)
