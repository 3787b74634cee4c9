"""Every structure of n modules, streamed in chunks: the fixed polyominoes (OEIS A001168).

Redelmeier's algorithm (D. H. Redelmeier, "Counting polyominoes: yet another attack", Discrete
Math. 36, 1981) grows each polyomino from its lowest-leftmost cell (the origin; cells lie in
y > 0 or y = 0, x >= 0) and visits every fixed polyomino exactly once, with no set of seen shapes:
memory is a few arrays of O(n) plus the chunk being filled. The depth-first search is compiled
with numba for levels beyond :data:`PLAIN_UP_TO` cells (a pure-Python run is about 100x slower;
level 14 holds 7.2 M polyominoes) and runs as plain Python up to it (at most 760 polyominoes,
a few milliseconds: a small search pays no compilation); it is resumable, so a level is produced
chunk by chunk and never held whole. Both runs are the same function: the same order.

Canonical order: the order of that depth-first search, with the untried cells kept in the order
they were reached and the neighbours of a cell reached in the order +x, +y, -x, -y. It is fixed
by n alone, so chunk ``k`` of size ``c`` is the same whatever the caller does with the others:
searches split a level into chunk ranges and still agree on "the first feasible structure".
Each polyomino comes as an (n, 2) array of integer cells, origin first, in the order it was built.
"""

from __future__ import annotations

from collections.abc import Iterator
from functools import cache

import numpy as np

from modquad_gym.core.validation import check_int

A001168 = (1, 2, 6, 19, 63, 216, 760, 2725, 9910, 36446, 135268, 505861, 1903890, 7204874)
"""Numbers of fixed polyominoes of 1..14 cells (OEIS A001168): the size of each search level."""

DEFAULT_CHUNK = 16384

PLAIN_UP_TO = 7
"""Levels of at most this many cells are enumerated in plain Python (no numba)."""

__all__ = ["A001168", "DEFAULT_CHUNK", "PolyominoStream", "count", "level_chunks"]


def _advance(n, width, untried, n_untried, pos, path, xy, added, n_added, reached, state, out):
    """Continue the depth-first search from ``state`` until ``out`` is full or the level ends;
    returns how many polyominoes were written to ``out``. ``xy`` holds the (x, y) of each cell
    of ``path``, decoded once when the cell is placed. Compiled by :func:`_compiled`."""
    d = state[0]
    k = 0
    cap = out.shape[0]
    offsets = (1, width, -1, -width)
    while k < cap:
        if pos[d] >= n_untried[d]:
            if d == 0:
                state[1] = 1
                break
            d -= 1
            for j in range(n_added[d]):
                reached[added[d, j]] = 0
            n_added[d] = 0
            pos[d] += 1
            continue
        c = untried[d, pos[d]]
        path[d] = c
        xy[d, 0] = c % width - (n + 1)
        xy[d, 1] = c // width - 1
        if d + 1 == n:
            for i in range(n):
                out[k, i, 0] = xy[i, 0]
                out[k, i, 1] = xy[i, 1]
            k += 1
            pos[d] += 1
            continue
        m = 0
        for off in offsets:
            nb = c + off
            if reached[nb] == 0:
                reached[nb] = 1
                added[d, m] = nb
                m += 1
        n_added[d] = m
        size = 0
        for j in range(pos[d] + 1, n_untried[d]):
            untried[d + 1, size] = untried[d, j]
            size += 1
        for j in range(m):
            untried[d + 1, size] = added[d, j]
            size += 1
        n_untried[d + 1] = size
        pos[d + 1] = 0
        d += 1
    state[0] = d
    return k


@cache
def _compiled():
    """:func:`_advance` compiled by numba (cached on disk, like every kernel)."""
    from modquad_gym.core.jit import njit

    return njit(cache=True)(_advance)


class PolyominoStream:
    """The fixed polyominoes of ``n`` cells in canonical order, as chunks of (L, n, 2) int32
    arrays. ``skip(k)`` passes over whole chunks without returning them."""

    def __init__(self, n: int, chunk: int = DEFAULT_CHUNK) -> None:
        self.n = check_int(n, "n", low=1, high=len(A001168) + 6)
        self.chunk = check_int(chunk, "chunk", low=1)
        width = 2 * self.n + 3  # x in -(n+1)..n+1, y in -1..n+1: a guard ring around reach
        height = self.n + 3
        self._width = width
        self._reached = np.zeros(width * height, dtype=np.uint8)
        self._reached[:width] = 1  # y = -1
        self._reached[width : width + self.n + 1] = 1  # y = 0, x < 0
        self._reached[width::width] = 1  # guard columns
        self._reached[2 * width - 1 :: width] = 1
        self._reached[-width:] = 1  # guard row
        origin = width + self.n + 1
        self._reached[origin] = 1
        size = 4 * self.n + 4
        self._untried = np.zeros((self.n, size), dtype=np.int64)
        self._untried[0, 0] = origin
        self._n_untried = np.zeros(self.n, dtype=np.int64)
        self._n_untried[0] = 1
        self._pos = np.zeros(self.n, dtype=np.int64)
        self._path = np.zeros(self.n, dtype=np.int64)
        self._xy = np.zeros((self.n, 2), dtype=np.int32)
        self._added = np.zeros((self.n, 4), dtype=np.int64)
        self._n_added = np.zeros(self.n, dtype=np.int64)
        self._state = np.zeros(2, dtype=np.int64)  # depth, done
        self._buffer = np.empty((self.chunk, self.n, 2), dtype=np.int32)

    def _fill(self) -> int:
        if self._state[1]:
            return 0
        advance = _advance if self.n <= PLAIN_UP_TO else _compiled()
        return int(
            advance(
                self.n,
                self._width,
                self._untried,
                self._n_untried,
                self._pos,
                self._path,
                self._xy,
                self._added,
                self._n_added,
                self._reached,
                self._state,
                self._buffer,
            )
        )

    _STATE = ("_reached", "_untried", "_n_untried", "_pos", "_path", "_xy", "_added",
              "_n_added", "_state")  # fmt: skip

    def snapshot(self) -> tuple[np.ndarray, ...]:
        """The enumeration's whole state between two chunks (a few KB): a stream of the same n
        and chunk size given it by :meth:`restore` goes on from here, so a level can be cut into
        ranges enumerated in other processes without passing over the chunks before them."""
        return tuple(getattr(self, name).copy() for name in self._STATE)

    def restore(self, snapshot: tuple[np.ndarray, ...]) -> None:
        """Continue from a :meth:`snapshot` of a stream of the same n and chunk size."""
        for name, value in zip(self._STATE, snapshot, strict=True):
            current = getattr(self, name)
            if value.shape != current.shape or value.dtype != current.dtype:
                raise ValueError(f"snapshot of another stream (n != {self.n})")
            current[...] = value

    def skip(self, chunks: int) -> None:
        """Pass over the next ``chunks`` chunks (enumerated, not returned)."""
        for _ in range(chunks):
            if not self._fill():
                return

    def __iter__(self) -> Iterator[np.ndarray]:
        while True:
            k = self._fill()
            if not k:
                return
            yield self._buffer[:k].copy()


def level_chunks(
    n: int, chunk: int = DEFAULT_CHUNK, start: int = 0, stop: int | None = None
) -> Iterator[np.ndarray]:
    """Chunks ``start`` (inclusive) to ``stop`` (exclusive) of level ``n`` in canonical order."""
    stream = PolyominoStream(n, chunk)
    stream.skip(start)
    for index, block in enumerate(stream, start=start):
        if stop is not None and index >= stop:
            return
        yield block


def count(n: int) -> int:
    """Number of fixed polyominoes of ``n`` cells, by enumeration."""
    return sum(len(block) for block in PolyominoStream(n, 1 << 16))
