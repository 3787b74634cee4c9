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
from modquad_gym.search.levels import level_progress, level_size
from modquad_gym.search.result import SearchRun, allowed_counts, first_possible_level

MAX_PAIRS = 10**9
"""Most (shape, type assignment) pairs a level of the typed search may hold (fixed
polyominoes of n cells times K^n): 2 types reach it at 11 modules, 3 types at 10."""

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


def check_typed_memory(run: SearchRun) -> None:
    """Refuse before any allocation a typed search that would not fit in memory."""
    K = len(run.palette)
    check_memory(typed_search_bytes(K, run.n_max), f"n_max={run.n_max} with {K} module types")


def check_pair_budget(run: SearchRun, first_level: int) -> None:
    """Refuse before any work a typed search whose last level holds more than MAX_PAIRS."""
    n, K = run.n_max, len(run.palette)
    size = level_size(n)
    if first_level > n:
        return
    if n > run.n_max_limit or size is None or size * K**n > MAX_PAIRS:
        raise ValueError(
            f"n_max={n} with {K} module type(s) is beyond what the exhaustive search can "
            f"finish: at most {MAX_PAIRS:.0e} (shape, assignment) pairs per level"
        )


def search_typed(run: SearchRun, progress: bool, first_only: bool):
    """(n*, found, skipped levels, proof), found a list of (cells tuple, types tuple) pairs of
    level n* in the typed search's order (module docstring)."""
    check_typed_memory(run)
    first, proof = first_possible_level(run)
    if proof:
        run.skipped += sum(allowed_counts(run, n)[1] for n in range(1, run.n_max + 1))
        return None, [], list(range(1, run.n_max + 1)), proof
    check_pair_budget(run, first)
    skipped_levels = []
    for n in range(1, run.n_max + 1):
        allowed, skipped = allowed_counts(run, n)
        run.skipped += skipped
        if not allowed.any():
            skipped_levels.append(n)
            continue
        assign = assignments(n, allowed)
        per_block = max(1, PAIRS_PER_BLOCK // len(assign))
        bar = level_progress(progress, n)
        found = []
        try:
            for shapes in PolyominoStream(n, max(per_block, 1024)):
                for start in range(0, len(shapes), per_block):
                    block = shapes[start : start + per_block]
                    cells = np.repeat(block, len(assign), axis=0)
                    types = np.tile(assign, (len(block), 1))
                    rest = 0
                    while rest < len(cells):
                        i = run.checker.first_feasible(cells[rest:], types[rest:])
                        if i is None:
                            break
                        j = rest + i
                        found.append((tuple(map(tuple, cells[j].tolist())), tuple(types[j])))
                        if first_only:
                            return n, found, skipped_levels, ""
                        rest = j + 1
                if bar is not None:
                    bar.update(len(shapes))
        finally:
            if bar is not None:
                bar.close()
        if found:
            return n, found, skipped_levels, ""
    return None, [], skipped_levels, ""


def typed_structure(run: SearchRun, pair) -> Structure:
    """The structure of a (cells, types) pair, translation-normalised (sorted cells)."""
    cells, types = pair
    key = normalise_typed(cells, (run.palette[int(t)] for t in types))
    return Structure.from_trusted(tuple(c for c, _ in key), modules=tuple(m for _, m in key))
