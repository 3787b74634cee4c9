"""Beam search over growing structures: the greedy baseline widened to ``beam_width``
structures per size, up to 128 modules, within a time limit.

Level 1 holds one module of each palette type. Each level's children are every docking of one
module (each palette type in turn) at a free neighbour cell of a structure of the beam,
deduplicated up to translation. Children are scored exactly (:class:`.heuristic.Scores`): the
share of task wrenches satisfied, then the mean clipped margin (how far from the wrenches it
misses), then a seeded random order; the ``beam_width`` best form the next beam. The first
feasible child found is returned: the smallest size the beam reaches. It is a heuristic: the
answer is verified by the exact LP and comes with the proved lower bound
(:func:`.bounds.bound_levels`), certified when they meet.
"""

from __future__ import annotations

from collections.abc import Sequence
from contextlib import suppress

from modquad_gym.core.validation import check_int
from modquad_gym.geometry.cells import free_neighbours
from modquad_gym.oracle.faults import DecisionInterruptedError
from modquad_gym.search.bounds import bound_levels
from modquad_gym.search.heuristic import (
    Candidate,
    Deadline,
    Scores,
    candidate,
    heuristic_result,
    impossible_result,
)
from modquad_gym.search.options import count, seeded_rng
from modquad_gym.search.problem import DEFAULT_TIME_LIMIT, MAX_MODULES, SearchProblem, search_entry
from modquad_gym.search.prune import pruned_search
from modquad_gym.search.result import SearchResult, SearchRun

DEFAULT_BEAM_WIDTH = 4
"""Structures kept per size. Tuned on planted 64-module tasks (40 wrenches, generator seeds
1000 and 1001, 60 s): widths 4, 6 and 10 found 59/58, 59/61 and 59/58 modules (lower bounds 59
and 58); 4 found as small structures at the least work per level (20-55 s on a loaded 2-core
machine), within the default time limit."""

MAX_BEAM_WIDTH = 4096
"""The widest beam accepted (each level scores up to width x perimeter x types children)."""


def children(beam: Sequence[Candidate], n_types: int) -> list[Candidate]:
    """Every docking of one module of each type at a free neighbour of a structure of the
    beam, up to translation, in order (structure, cell, type); the first copy kept."""
    out: dict[Candidate, None] = {}
    for cand in beam:
        cells = [c for c, _ in cand]
        types = [t for _, t in cand]
        for cell in free_neighbours(cells):
            for t in range(n_types):
                out.setdefault(candidate(cells + [cell], types + [t]), None)
    return list(out)


@search_entry(
    "beam",
    prune=pruned_search,
    options={"beam_width": ("structures kept per level", count(1, MAX_BEAM_WIDTH))},
)
def beam_search(
    problem: SearchProblem,
    *,
    beam_width: int = DEFAULT_BEAM_WIDTH,
    time_limit: float = DEFAULT_TIME_LIMIT,
    seed: int | None = 0,
) -> SearchResult:
    """The smallest structure the beam reaches for ``task`` within ``time_limit`` seconds
    (module docstring), or None when the beam reaches ``n_max`` (or the time limit) first;
    always with the proved lower bound. ``modules``, ``kind`` and ``f_max`` as for
    :func:`~.exhaustive.exhaustive_search`; ``seed`` orders children of equal scores."""
    run = SearchRun("beam", problem)
    deadline = Deadline(run, time_limit, interrupt=True)
    width = check_int(beam_width, "beam_width", low=1, high=MAX_BEAM_WIDTH)
    rng = seeded_rng(seed)
    if (done := impossible_result(run, MAX_MODULES)) is not None:
        return done
    lower = bound_levels(problem)
    if lower > problem.n_max:  # the exact bounds rule out every level
        return heuristic_result(run, None, lower)
    scores = Scores(run)
    K = len(problem.palette)
    with suppress(DecisionInterruptedError):  # a cut fault decision proves nothing
        level: list[Candidate] = [(((0, 0), t),) for t in range(K)]
        for n in range(1, problem.n_max + 1):
            ranked = []
            for i, cand in zip(rng.permutation(len(level)), level, strict=True):
                if deadline.passed():
                    return heuristic_result(run, None, lower)
                missed, share, tie = scores.score(cand)
                if missed == 0:
                    return heuristic_result(run, scores.structure(cand), lower)
                ranked.append((-share, -tie, int(i), cand))
            if n == problem.n_max:
                break
            ranked.sort(key=lambda r: r[:3])
            level = children([r[3] for r in ranked[:width]], K)
    return heuristic_result(run, None, lower)
