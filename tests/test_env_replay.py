"""Replay: the environment reproduces episodes recorded before its refactoring.

Discrete outcomes (actions' validity, masks, occupancy counts, success, module counts, oracle
calls) must match exactly on any machine. Floating-point fields are compared within a tolerance:
the recording was made on one CPU, and another computes the same seeded task draws, margins and
rewards differently in the last bits (~1e-14; after the cast to float32 an observation may move
by one float32 step, ~6e-8 relative). Bit-for-bit equality holds only between two runs on one
machine (``test_replay_is_bit_identical_on_one_machine``).
"""

import numpy as np
import pytest
from env_replay import CONFIGS, DATA, play

RTOL = {np.dtype(np.float32): 1e-5, np.dtype(np.float64): 1e-9}
ATOL = {np.dtype(np.float32): 1e-6, np.dtype(np.float64): 1e-9}
"""Tolerances by dtype: a few float32 steps, and far below any reward term's scale in float64."""


@pytest.mark.parametrize("name", list(CONFIGS))
def test_replay_matches_the_recording(name):
    recorded = np.load(DATA)
    played = play(name)
    expected = sorted(k for k in recorded.files if k.startswith(f"{name}/"))
    assert sorted(played) == expected
    for key in expected:
        got, want = played[key], recorded[key]
        assert got.dtype == want.dtype and got.shape == want.shape, key
        if want.dtype.kind == "f":
            np.testing.assert_allclose(
                got, want, rtol=RTOL[want.dtype], atol=ATOL[want.dtype], err_msg=key
            )
        else:
            assert np.array_equal(got, want), key


def test_replay_is_bit_identical_on_one_machine():
    name = "mixed_modules_lookahead"
    first, second = play(name, steps=40), play(name, steps=40)
    for key in first:
        assert first[key].tobytes() == second[key].tobytes(), key
