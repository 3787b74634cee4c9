"""Bit-identical replay: the environment reproduces episodes recorded before its refactoring."""

import numpy as np
import pytest
from env_replay import CONFIGS, DATA, play


@pytest.mark.parametrize("name", list(CONFIGS))
def test_replay_matches_the_recording(name):
    recorded = np.load(DATA)
    played = play(name)
    expected = sorted(k for k in recorded.files if k.startswith(f"{name}/"))
    assert sorted(played) == expected
    for key in expected:
        assert played[key].dtype == recorded[key].dtype, key
        assert np.array_equal(played[key], recorded[key]), key
