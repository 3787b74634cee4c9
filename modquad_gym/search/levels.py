"""Levels of the exhaustive searches: how many structures level n holds, its progress bar, the
answer of a level-by-level search and the whole minimal level (:class:`Optima`).

Shared by the one-type search (:mod:`.exhaustive`) and the typed one (:mod:`.typed`).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from modquad_gym.geometry.polyominoes import A001168
from modquad_gym.geometry.structure import Key


@dataclass
class LevelAnswer:
    """What a level-by-level search found.

    Attributes:
        n: the first level holding a feasible structure, or None (none up to n_max).
        found: its feasible structures in the search's order (keys for the one-type search,
            (cells, types) pairs for the typed one); only the first when asked for one.
        skipped: levels ruled out as a whole by exact bounds.
        proof: how infeasibility was proven without searching, when it was ("" otherwise).
    """

    n: int | None
    found: list[Any] = field(default_factory=list)
    skipped: list[int] = field(default_factory=list)
    proof: str = ""


def level_size(n: int) -> int | None:
    """Connected structures of n modules up to translation (fixed polyominoes), or None past
    the counts :data:`~modquad_gym.geometry.polyominoes.A001168` holds."""
    return A001168[n - 1] if n <= len(A001168) else None


BAR_DELAY = 0.5
"""Seconds a level's bar waits before it is drawn: a level decided sooner shows none."""


def level_progress(enabled: bool, n: int):
    """A tqdm bar over level n's structures on stderr, or None when not ``enabled``."""
    if not enabled:
        return None
    from tqdm.auto import tqdm

    return tqdm(total=level_size(n), desc=f"level {n}", unit=" structures", leave=False,
                delay=BAR_DELAY)  # fmt: skip


class ChunkBar:
    """Moves a level's ``bar`` (None: nothing) while one chunk of ``size`` structures is
    decided, structure by structure, not only at its end (a chunk of slow structures can take
    a minute); :meth:`close` brings it to the chunk's end."""

    def __init__(self, bar, size: int) -> None:
        self.bar, self.size = bar, size
        self.start = 0  # where the slice being decided starts in the chunk
        self.shown = 0  # structures of the chunk counted on the bar

    def seen(self, k: int) -> None:
        """The first ``k`` structures of the slice from :attr:`start` are decided."""
        if self.bar is not None and self.start + k > self.shown:
            self.bar.update(self.start + k - self.shown)
            self.shown = self.start + k

    def close(self) -> None:
        self.start = 0
        self.seen(self.size)


@dataclass
class Optima:
    """Every minimum-module structure of a task (:func:`~.exhaustive.optimal_level`).

    Attributes:
        n_modules: the certified minimum, or None when no structure up to n_max works.
        keys: every feasible structure of ``n_modules`` modules (cells up to translation), in
            canonical order (the first ``max_keys`` of them when that is given).
        evaluated, oracle_calls, seconds: the work it took, as in :class:`~.result.SearchResult`.
        proof: how infeasibility was proven without searching, when it was ("" otherwise).
        count: how many feasible structures the level holds (``len(keys)`` unless capped).
    """

    n_modules: int | None
    keys: list[Key]
    evaluated: int
    oracle_calls: int
    seconds: float
    proof: str = ""
    count: int = -1

    def __post_init__(self) -> None:
        if self.count < 0:
            self.count = len(self.keys)


class KeptKeys(list):
    """The first ``limit`` keys added (all when None) and how many were added (``total``):
    memory stays bounded when a level holds millions of feasible structures."""

    def __init__(self, limit: int | None = None) -> None:
        super().__init__()
        self.limit = limit
        self.total = 0

    def add(self, key: Key) -> None:
        self.total += 1
        if self.limit is None or len(self) < self.limit:
            self.append(key)
