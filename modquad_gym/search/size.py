"""How many task wrenches a search takes, and the one message that refuses more (the search
and the command line's early check of a task file both use it)."""

from __future__ import annotations

import numpy as np

MAX_SEARCH_WRENCHES = 10_000
"""Most task wrenches a search takes: it decides every one of them for each structure it
evaluates (at 64 modules about 20,000 decisions a second). Only the extreme wrenches matter
(a structure exerts every wrench of their convex hull), so a longer task can be thinned."""


def check_search_size(W: np.ndarray, dynamic: bool = False) -> None:
    """ValueError when the task holds more than :data:`MAX_SEARCH_WRENCHES` wrenches (for a
    ``dynamic`` task: distinct trajectory samples, :func:`search_size_message`)."""
    if len(W) > MAX_SEARCH_WRENCHES:
        raise ValueError(search_size_message(f"{len(W):,}", dynamic))


def search_size_message(count: str, dynamic: bool = False) -> str:
    """Why a task of ``count`` wrenches (``"1,000,000"``, ``"more than 10,000"``) is refused, and
    what to do: keep a static task's extreme wrenches; sample a dynamic task's trajectory more
    coarsely (its wrenches are its samples, none of which may be dropped)."""
    has, advice = (
        (f"'s trajectory has {count} distinct samples", "sample the trajectory more coarsely "
         "(fewer times in trajectory.t; modquad task motion --rate)") if dynamic
        else (f" has {count} wrenches", "keep the extreme ones, e.g. the vertices of their "
              "convex hull")
    )  # fmt: skip
    return (
        f"the task{has}; a search takes at most {MAX_SEARCH_WRENCHES:,} (it decides each for "
        f"every structure it evaluates): {advice}"
    )
