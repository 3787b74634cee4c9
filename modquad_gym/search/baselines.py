"""Two constructive baselines, up to 128 modules within a time limit (the centrosymmetric
heuristic, the beam and the genetic search have modules of their own).

* :func:`greedy_search`: attach the module that most increases the satisfied share.
* :func:`random_search`: attach modules at random free cells.

Each reports the exact lower bound the force (or count) and level bounds prove
(:func:`.bounds.bound_levels`), so an answer is certified when it meets it; each returns at once
when the exact force bound proves the task impossible up to ``n_max``, and at ``time_limit``
seconds with what it has (greedy: nothing, random: the smallest structure seen). With
``modules=[...]`` each also chooses module types: greedy tries every (cell, type) child, random
draws a type with each cell. With one type and a ``total`` task each runs exactly as before.
"""

from __future__ import annotations

from collections.abc import Iterable
from contextlib import suppress

import numpy as np

from modquad_gym.geometry.structure import Cell, Structure, free_neighbours
from modquad_gym.oracle import margin
from modquad_gym.oracle.faults import DecisionInterruptedError
from modquad_gym.search.bounds import bound_levels
from modquad_gym.search.heuristic import Deadline, heuristic_result, impossible_result
from modquad_gym.search.options import count, seeded_rng
from modquad_gym.search.partial import check_start, make_partial
from modquad_gym.search.problem import DEFAULT_TIME_LIMIT, MAX_MODULES, SearchProblem, search_entry
from modquad_gym.search.prune import pruned_search
from modquad_gym.search.result import SearchResult, SearchRun

TIE_DECIMALS = 9
"""Greedy compares mean margins rounded to this many decimals: children that differ by round-off
only (mirror images of a symmetric task) tie on every machine, and the first in cell order
wins."""


def greedy_rank(share: float, mean_margin: float) -> tuple[float, float]:
    """How greedy ranks a child structure: (satisfied share, mean of its margins clipped to
    [-1, 1], rounded to :data:`TIE_DECIMALS`), a feasible child (share 1) scoring (1, 0). The
    environment's exact lookahead flags its choice by the same rank."""
    if share == 1.0:
        return 1.0, 0.0
    return share, round(mean_margin, TIE_DECIMALS)


def _typed(run: SearchRun, cells: Iterable[Cell], types: Iterable[int]) -> Structure:
    palette = run.problem.palette
    return Structure.from_trusted(tuple(cells), modules=tuple(palette[t] for t in types))


@search_entry("greedy", prune=pruned_search)
def greedy_search(
    problem: SearchProblem,
    *,
    time_limit: float = DEFAULT_TIME_LIMIT,
    start: Structure | Iterable[Cell] | None = None,
) -> SearchResult:
    """Baseline: from one module, repeatedly attach the module that most increases the fraction
    of satisfied wrenches, ties broken by the larger mean margin (exact margins clipped to
    [-1, 1], :func:`greedy_rank`), then by cell order. Stops at the first feasible structure or
    at ``n_max``.

    Children that are the same structure up to translation are evaluated and counted once, at
    their first cell in sorted order; equal structures score equally, so results are unchanged.
    With ``modules`` the first module is the best-scoring type and every child is a (cell,
    type) pair (ties by cell order, then palette order). At ``time_limit`` seconds it stops
    with no structure (and the proved lower bound). ``start`` (a Structure of the searched
    types, or connected cells, at most ``n_max``) is extended instead of one module: greedy's
    completion of a partial structure, as expert iteration labels a learner's states by it."""
    run = SearchRun("greedy", problem)
    f, palette = problem.f_max, problem.palette
    if start is not None:  # refused first, as by the exhaustive search, whatever the bounds say
        start = check_start(start)  # read once: checking would use up a generator
        make_partial(start, palette, problem.typed, problem.n_max)  # ValueError naming it
        if not isinstance(start, Structure):
            start = Structure(start, problem.module)
    deadline = Deadline(run, time_limit, interrupt=True)
    if (done := impossible_result(run, MAX_MODULES)) is not None:
        return done

    def score(s: Structure) -> tuple[bool, tuple[float, float]]:
        z, W, ok = run.decide(s)
        if ok.all():
            return True, (1.0, 0.0)
        mean = float(np.clip(margin(z.A, W, f, method="compiled"), -1.0, 1.0).mean())
        return False, greedy_rank(float(ok.mean()), mean)

    with suppress(DecisionInterruptedError):  # a cut fault decision proves nothing
        if start is not None or len(palette) == 1:
            current = Structure([(0, 0)], problem.module) if start is None else start
            if run.decide(current)[2].all():
                return heuristic_result(run, current)
        else:
            current, best_score = None, None
            for m in palette:
                s = Structure([(0, 0)], module=m)
                done, sc = score(s)
                if done:
                    return heuristic_result(run, s)
                if best_score is None or sc > best_score:
                    current, best_score = s, sc
        while current.n_modules < problem.n_max:
            best, best_score = None, None
            seen: set[Structure] = set()
            for cell in current.attachable_cells():  # sorted: ties go to the first cell
                for m in palette:
                    child = (
                        current.with_cells(cell)
                        if len(palette) == 1
                        else Structure(current.cells + (cell,), modules=current.modules + (m,))
                    )
                    if child in seen:  # the same structure up to translation: already scored
                        continue
                    if deadline.passed():
                        return heuristic_result(run, None)
                    seen.add(child)
                    done, sc = score(child)
                    if done:
                        return heuristic_result(run, child)
                    if best_score is None or sc > best_score:
                        best, best_score = child, sc
            current = best
    return heuristic_result(run, None)


MAX_RESTARTS = 10**6
"""The most ``restarts`` of the random search, capped as the other searches' counts are (the
genetic search's ``population``: 10,000); the documented runs use a handful."""

RESTARTS = count(1, MAX_RESTARTS)
"""The check of ``restarts``."""


@search_entry(
    "random",
    prune=pruned_search,
    options={"restarts": (f"independent random builds, 1 to {MAX_RESTARTS:,}", RESTARTS)},
)
def random_search(
    problem: SearchProblem,
    *,
    seed: int | None = 0,
    restarts: int = 1,
    time_limit: float = DEFAULT_TIME_LIMIT,
) -> SearchResult:
    """Baseline: attach modules at uniformly random free cells until the task is satisfied or
    ``n_max`` is reached, ``restarts`` times (at most :data:`MAX_RESTARTS`), until
    ``time_limit`` seconds or until a structure meets the proved lower bound
    (:func:`.bounds.bound_levels`: none can be smaller); returns the smallest feasible
    structure seen. With several ``modules`` each module's type is drawn uniformly too."""
    run = SearchRun("random", problem)
    deadline = Deadline(run, time_limit, interrupt=True)
    if (done := impossible_result(run, MAX_MODULES)) is not None:
        return done
    rng = seeded_rng(seed)
    K, lower = len(problem.palette), bound_levels(problem)
    best: Structure | None = None
    with suppress(DecisionInterruptedError):  # a cut fault decision proves nothing
        for _ in range(restarts):
            if deadline.passed() or best is not None and best.n_modules <= lower:
                break
            cells: list[Cell] = [(0, 0)]
            types: list[int] = [int(rng.integers(K))] if K > 1 else [0]
            while True:
                if K > 1:
                    s = _typed(run, cells, types)
                else:
                    s = Structure.from_trusted(tuple(cells), problem.module)
                if (best is not None and s.n_modules >= best.n_modules) or deadline.passed():
                    break
                if run.checker.check(s):
                    best = s
                    break
                if s.n_modules >= problem.n_max:
                    break
                options = free_neighbours(cells)
                cells.append(options[int(rng.integers(len(options)))])
                if K > 1:
                    types.append(int(rng.integers(K)))
    if best is not None:
        best = Structure(best.cells, modules=best.modules)
    return heuristic_result(run, best, lower)
