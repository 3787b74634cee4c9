"""The typed exhaustive search: several module types (``modules=[...]``), or self-weight.

Several module types (``modules=[...]``) or a task of kind ``external``: every (shape, type
assignment) pair is visited, level by level; within a level shapes come in canonical order
and, for each shape, assignments in lexicographic order of the palette indices taken in the
shape's cell order, so the answer is again the first feasible pair in a fixed order. Exact
pruning before any pair is evaluated: the count bound rules out every count vector (how many
modules of each type) whose forces, and weight for ``external`` tasks, no shape can exert
(:func:`.bounds.counts_possible`), and the level bounds rule out the one-type counts they
cover; the pairs they rule out are counted in ``SearchResult.skipped``. Pairs are
distinct structures up to translation (fixed polyominoes times assignments); palette
types that are copies of one another are merged first.

:func:`~modquad_gym.search.exhaustive_search` (and :func:`.exhaustive.optimal_structures`)
call :func:`search_typed` for any search that is not one type with a ``total`` task.
"""

from __future__ import annotations

import itertools
import math

import numpy as np

from modquad_gym.core.resources import check_memory
from modquad_gym.geometry.polyominoes import PolyominoStream
from modquad_gym.geometry.structure import Structure, normalise_typed
from modquad_gym.search.bounds import allowed_counts, first_possible_level
from modquad_gym.search.levels import LevelAnswer, level_progress, level_size
from modquad_gym.search.partial import Partial
from modquad_gym.search.problem import EXACT_MODULES, FAULT_BLOCK, SearchProblem
from modquad_gym.search.result import SearchRun

MAX_PAIRS = 10**9
"""Most (shape, type assignment) pairs a level of the typed search may hold (fixed
polyominoes of n cells times K^n): 2 types go up to 11 modules, 3 types up to 9
(:func:`exhaustive_reach`)."""

PAIRS_PER_BLOCK = 8192
"""Pairs decided together by the typed search (whole shapes with all their assignments)."""


def assignments(n: int, allowed: np.ndarray) -> np.ndarray:
    """(T, n) int8: every assignment of K types to n cells in lexicographic order, kept when
    ``allowed[c_0, ..., c_{K-1}]`` is True for its counts c (``allowed``: K axes of length
    n + 1)."""
    K = allowed.ndim
    rows = np.array(list(itertools.product(range(K), repeat=n)), dtype=np.int8).reshape(-1, n)
    counts = np.stack([(rows == k).sum(axis=1) for k in range(K)], axis=1)
    keep = allowed[tuple(counts.T)]
    return np.ascontiguousarray(rows[keep])


def typed_search_bytes(K: int, n: int) -> int:
    """Peak bytes the typed search allocates up to level n with K types, before it decides any
    pair: the count vectors (C(n + K - 1, K - 1) rows of K, built as Python lists), the table of
    allowed counts ((n + 1)^K booleans) and the assignments (K^n rows, Python tuples first)."""
    return math.comb(n + K - 1, K - 1) * K * 48 + (n + 1) ** K + K**n * (72 + 9 * n)


def check_typed_memory(problem: SearchProblem) -> None:
    """Refuse before any allocation a typed search that would not fit in memory."""
    n, K = problem.n_max, len(problem.palette)
    check_memory(typed_search_bytes(K, n), f"n_max={n} with {K} module types")


def exhaustive_reach(n_types: int, shape_only: bool = False) -> int:
    """The largest n_max the exhaustive search takes (a larger one is refused before any work,
    unless the task's bounds rule out every level): :data:`EXACT_MODULES` for the search of
    shapes alone (``shape_only``: one type, wrenches that do not depend on the structure), else
    the last level of the typed search whose (shape, assignment) pairs with ``n_types`` types
    stay within MAX_PAIRS and whose structures are counted (:func:`~.levels.level_size`): 14
    for one type, 11 for two, 9 for three."""
    if shape_only:
        return EXACT_MODULES
    n = 0
    while n < EXACT_MODULES:
        size = level_size(n + 1)  # None past the counted levels
        if size is None or size * n_types ** (n + 1) > MAX_PAIRS:
            break
        n += 1
    return n


def check_pair_budget(problem: SearchProblem, first_level: int) -> None:
    """Refuse before any work a typed search whose last level holds more than MAX_PAIRS."""
    n, K = problem.n_max, len(problem.palette)
    if first_level > n:
        return
    if n > (reach := exhaustive_reach(K)):
        raise ValueError(
            f"n_max={n} with {K} module type(s) is beyond what the exhaustive search can "
            f"finish: at most {reach} modules ({MAX_PAIRS:.0e} (shape, assignment) pairs per "
            "level)"
        )


def search_typed(
    run: SearchRun, progress: bool, first_only: bool, part: Partial | None = None
) -> LevelAnswer:
    """The first level of ``run``'s problem holding a feasible (shape, assignment) pair
    (containing ``part``) and its feasible pairs, (cells tuple, types tuple), in the typed
    search's order (module docstring); only the first with ``first_only``."""
    p = run.problem
    check_typed_memory(p)
    first, proof = first_possible_level(p)
    if proof:
        run.skipped += sum(allowed_counts(p, n)[1] for n in range(1, p.n_max + 1))
        return LevelAnswer(None, [], list(range(1, p.n_max + 1)), proof)
    check_pair_budget(p, first)
    skipped_levels = []
    for n in range(1, p.n_max + 1):
        allowed, skipped = allowed_counts(p, n)
        run.skipped += skipped
        if not allowed.any():
            skipped_levels.append(n)
            continue
        if part is not None and n < part.size:  # no structure containing it: not ruled out
            continue
        found = _search_level(run, n, assignments(n, allowed), progress, first_only, part)
        if found:
            return LevelAnswer(n, found, skipped_levels, "")
    return LevelAnswer(None, [], skipped_levels, "")


def _search_level(run: SearchRun, n, assign, progress, first_only, part) -> list:
    """The feasible (cells, types) pairs of level n with the assignments ``assign``."""
    bar = level_progress(progress, n)
    found = []
    try:
        for pair in level_pairs(run, n, assign, part, bar):
            if pair is not None:
                found.append(pair)
                if first_only:
                    return found
    finally:
        if bar is not None:
            bar.close()
    return found


def level_pairs(run: SearchRun, n: int, assign: np.ndarray, part: Partial | None = None, bar=None):
    """Generator over level n of the typed search (assignments ``assign``): yields each
    feasible (cells, types) pair in order, and None after each block of shapes (about
    ``PAIRS_PER_BLOCK`` pairs, at least one shape): a point where a caller may stop for the
    clock."""
    pairs = PAIRS_PER_BLOCK if run.problem.fault is None else FAULT_BLOCK
    per_block = max(1, pairs // len(assign))
    for shapes in PolyominoStream(n, max(per_block, 1024)):
        for start in range(0, len(shapes), per_block):
            block = shapes[start : start + per_block]
            decided = len(block)  # shapes the bar moves by after this block
            if part is not None:
                block = block[part.mask(block)]
            cells = np.repeat(block, len(assign), axis=0)
            types = np.tile(assign, (len(block), 1))
            if part is not None and (part.types >= 0).any():
                keep = part.mask(cells, types)
                cells, types = cells[keep], types[keep]
            rest = 0
            while rest < len(cells):
                i = run.checker.first_feasible(cells[rest:], types[rest:])
                if i is None:
                    break
                j = rest + i
                yield tuple(map(tuple, cells[j].tolist())), tuple(types[j])
                rest = j + 1
            if bar is not None:  # per block, not per stream chunk: blocks of slow pairs
                bar.update(decided)
            yield None


def typed_structure(problem: SearchProblem, pair) -> Structure:
    """The structure of a (cells, types) pair, translation-normalised (sorted cells)."""
    cells, types = pair
    key = normalise_typed(cells, (problem.palette[int(t)] for t in types))
    return Structure.from_trusted(tuple(c for c, _ in key), modules=tuple(m for _, m in key))
