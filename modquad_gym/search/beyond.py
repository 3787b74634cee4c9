"""The bound an infeasible answer proves beyond its budget.

A search that rules out every module count up to ``n_max`` has proved ``lower_bound`` n_max + 1
by its own work; the exact bounds that need no structure often prove more, whatever n_max: the
force bound of one module type (the task's forces need at least that many modules), and for a
palette, an ``external`` or a dynamic task the count bound, level by level from there
(:func:`.bounds.counts_possible`: a count vector it rules out holds no feasible structure,
whatever the shape). :func:`bound_beyond` raises the bound to theirs, so a result's
``lower_bound`` is the strongest bound its search proved, and still never above an optimum.
The count bound's scan is capped by work (:data:`EXTRA_COUNT_VECTORS`) and by the search's time
left, so that an infeasible answer keeps its search's time limit.
"""

from __future__ import annotations

from collections.abc import Iterator
from typing import TYPE_CHECKING

import numpy as np

from modquad_gym.core.compile_clock import now
from modquad_gym.geometry.cells import MAX_MODULES
from modquad_gym.search.bounds import (
    NO_SIZE,
    count_vectors,
    counts_possible,
    force_lower_bound,
    n_count_vectors,
)

if TYPE_CHECKING:
    from modquad_gym.search.problem import SearchProblem

EXTRA_COUNT_VECTORS = 100_000
"""Most count vectors the count bound examines past ``n_max``, all levels together (about a
quarter of a second with three types, one second with five); where they run out the bound stays
where the scan stopped."""

BLOCK = 2048
"""Count vectors decided between two looks at the clock (at least; a few milliseconds)."""


def bound_beyond(problem: SearchProblem, lower_bound: int, seconds: float | None = None) -> int:
    """``lower_bound`` raised by the exact bounds past ``n_max`` when it already exceeds
    ``n_max`` (every level up to it ruled out); else ``lower_bound`` as it is. One type and a
    ``total`` task: the force bound (unless no number of modules exerts the forces: then the
    proof says so and the bound stays); otherwise the count bound from ``lower_bound`` up to
    :data:`~modquad_gym.geometry.cells.MAX_MODULES` + 1 at most, within ``seconds`` (the
    search's time left; None: no limit but :data:`EXTRA_COUNT_VECTORS`): the bound proved when
    the time runs out, ``lower_bound`` at least."""
    p = problem
    if lower_bound <= p.n_max:
        return lower_bound
    if p.shape_only:
        n = force_lower_bound(p.wrenches, p.module, p.f_max, p.fault)
        return lower_bound if n == NO_SIZE else max(lower_bound, n)
    ends = None if seconds is None else now() + seconds
    n, k, left = lower_bound, len(p.palette), EXTRA_COUNT_VECTORS
    while n <= MAX_MODULES and (left := left - n_count_vectors(n, k)) >= 0:
        if not _ruled_out(p, n, ends):
            break
        n += 1
    return n


def _ruled_out(problem: SearchProblem, n: int, ends: float | None) -> bool:
    """Does the count bound rule out every count vector of ``n`` modules before ``ends``
    (on the search clock, :func:`~modquad_gym.core.compile_clock.now`; None: no end)? A level
    left undecided is not ruled out."""
    p = problem
    for counts in _blocks(n, len(p.palette)):
        if ends is not None and now() >= ends:
            return False
        if counts_possible(p.model, list(p.palette), counts, p.f_max, p.fault).any():
            return False
    return True


def _blocks(n: int, k: int) -> Iterator[np.ndarray]:
    """The rows of ``count_vectors(n, k)`` in blocks of at least :data:`BLOCK` rows (the last
    fewer), made block by block: those of each first count together."""
    if k == 1:
        yield count_vectors(n, 1)
        return
    block: list[np.ndarray] = []
    size = 0
    for first in range(n, -1, -1):
        rest = count_vectors(n - first, k - 1)
        block.append(np.column_stack((np.full(len(rest), first), rest)))
        size += len(rest)
        if size >= BLOCK or first == 0:
            yield np.concatenate(block)
            block, size = [], 0
