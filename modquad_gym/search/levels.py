"""Levels of the exhaustive searches: how many structures level n holds, its progress bar and
the answer of a level-by-level search.

Shared by the one-type search (:mod:`.exhaustive`) and the typed one (:mod:`.typed`).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from modquad_gym.geometry.polyominoes import A001168


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
