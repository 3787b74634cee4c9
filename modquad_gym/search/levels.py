"""Levels of the exhaustive searches: how many structures level n holds, and its progress bar.

Shared by the one-type search (:mod:`.exhaustive`) and the typed one (:mod:`.typed`).
"""

from __future__ import annotations

from modquad_gym.geometry.polyominoes import A001168


def level_size(n: int) -> int | None:
    """Connected structures of n modules up to translation (fixed polyominoes), or None past
    the counts :data:`~modquad_gym.geometry.polyominoes.A001168` holds."""
    return A001168[n - 1] if n <= len(A001168) else None


def level_progress(enabled: bool, n: int):
    """A tqdm bar over level n's structures on stderr, or None when not ``enabled``."""
    if not enabled:
        return None
    from tqdm.auto import tqdm

    # shown only when a level takes more than half a second
    return tqdm(total=level_size(n), desc=f"level {n}", unit=" structures", leave=False, delay=0.5)
