"""Progress bars on stderr, one definition for the package's loops that show one: tqdm (loaded
only when a bar is shown), gone from the terminal once closed."""

from __future__ import annotations

from collections.abc import Iterable
from typing import Any

__all__ = ["progress_bar"]


def progress_bar(show: bool, desc: str, unit: str = "it", *, items: Iterable | None = None,
                 total: float | None = None, **options: Any) -> Any:  # fmt: skip
    """A tqdm bar on stderr named ``desc`` counting ``unit``, when ``show``: over ``items``
    (iterate it; ``items`` themselves, as a list, when no bar is shown, nor over a single item,
    where it says nothing), or up to ``total`` (``update`` and ``close`` it; None when no bar is
    shown). ``options`` go to tqdm (``delay``, ``bar_format``)."""
    if items is not None:
        items = list(items)
        show = show and len(items) > 1
        total = len(items)
    if not show:
        return items
    from tqdm.auto import tqdm

    return tqdm(iterable=items, total=total, desc=desc, unit=unit, leave=False, **options)
