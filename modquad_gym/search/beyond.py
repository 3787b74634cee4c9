"""The bound an infeasible answer proves beyond its budget.

A search that rules out every module count up to ``n_max`` has proved ``lower_bound`` n_max + 1
by its own work; the exact bounds that need no structure often prove more, whatever n_max: the
force bound of one module type (the task's forces need at least that many modules), and for a
palette, an ``external`` or a dynamic task the count bound, level by level from there
(:func:`.bounds.counts_possible`: a count vector it rules out holds no feasible structure,
whatever the shape). :func:`bound_beyond` raises the bound to theirs, so a result's
``lower_bound`` is the strongest bound its search proved, and still never above an optimum.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

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
"""Most count vectors the count bound examines past ``n_max``, all levels together (a quarter
of a second with three types); where they run out the bound stays where the scan stopped."""


def bound_beyond(problem: SearchProblem, lower_bound: int) -> int:
    """``lower_bound`` raised by the exact bounds past ``n_max`` when it already exceeds
    ``n_max`` (every level up to it ruled out); else ``lower_bound`` as it is. One type and a
    ``total`` task: the force bound (unless no number of modules exerts the forces: then the
    proof says so and the bound stays); otherwise the count bound from ``lower_bound`` up to
    :data:`~modquad_gym.geometry.cells.MAX_MODULES` + 1 at most."""
    p = problem
    if lower_bound <= p.n_max:
        return lower_bound
    if p.shape_only:
        n = force_lower_bound(p.wrenches, p.module, p.f_max, p.fault)
        return lower_bound if n == NO_SIZE else max(lower_bound, n)
    n, k, left = lower_bound, len(p.palette), EXTRA_COUNT_VECTORS
    while n <= MAX_MODULES and (left := left - n_count_vectors(n, k)) >= 0:
        counts = count_vectors(n, k)
        if counts_possible(p.model, list(p.palette), counts, p.f_max, p.fault).any():
            break
        n += 1
    return n
