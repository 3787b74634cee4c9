"""The exact lookahead's warm starts from a sibling (:func:`~modquad_gym.envs.assembly.exact.
from_sibling`, a compiled loop) against a plain NumPy renumbering of the same vertices."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from modquad_gym.envs.assembly.exact import Lineage, from_sibling


def plain(start: tuple, line: Lineage, walked: list, r: int) -> tuple:
    """The reference: rows whose sibling vertex holds none of the sibling's own module columns
    take it, its columns mapped back to the parent's (np.delete) and on to this child's
    (np.insert, the new module's bounds 0); the other rows keep ``start``."""
    cell, at = line.cell, line.at
    _, a0, T0, S0 = min(walked, key=lambda w: abs(w[0][0] - cell[0]) + abs(w[0][1] - cell[1]))
    ok = (T0 >= 0).all(axis=1) & ~((T0 >= a0) & (T0 < a0 + r)).any(axis=1)
    if T0.shape != start[0].shape or not ok.any():
        return start
    parent = T0[ok] - r * (T0[ok] >= a0)
    tights, signs = start[0].copy(), start[1].copy()
    tights[ok] = parent + r * (parent >= at)
    signs[ok] = np.insert(np.delete(S0[ok], np.s_[a0 : a0 + r], axis=1), [at] * r, 0, axis=1)
    return tights, signs


@settings(max_examples=300, deadline=None)
@given(seed=st.integers(0, 2**32 - 1))
def test_sibling_starts_equal_the_plain_renumbering(seed):
    """Random vertices (some rows without one: -1; some holding the sibling's own module),
    several siblings at random cells and module positions, every rank, some of another rank
    than the child; the start is returned as it was where no row can be taken, and never
    modified in place."""
    rng = np.random.default_rng(seed)
    r, n = 4, int(rng.integers(1, 8))
    m, t, rank = r * (n + 1), int(rng.integers(1, 10)), int(rng.integers(2, 7))
    start = (rng.integers(-1, m, (t, rank - 1)), rng.integers(-1, 2, (t, m)).astype(np.int8))
    kept = (start[0].copy(), start[1].copy())
    walked = [
        (
            tuple(int(v) for v in rng.integers(0, 5, 2)),
            r * int(rng.integers(0, n + 1)),
            rng.integers(-1 if rng.random() < 0.3 else 0, m, (t, rank - (rng.random() < 0.2))),
            rng.integers(-1, 2, (t, m)).astype(np.int8),
        )
        for _ in range(int(rng.integers(1, 4)))
    ]
    line = Lineage(
        start, None, tuple(int(v) for v in rng.integers(0, 5, 2)), r * int(rng.integers(0, n + 1))
    )
    want, got = plain(start, line, walked, r), from_sibling(start, line, walked, r)
    np.testing.assert_array_equal(got[0], want[0])
    np.testing.assert_array_equal(got[1], want[1])
    np.testing.assert_array_equal(start[0], kept[0])
    np.testing.assert_array_equal(start[1], kept[1])
