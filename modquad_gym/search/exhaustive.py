"""The certified exhaustive search (paper Sec. V-A) and the whole minimal level.

Every connected structure up to translation is visited level by level, each level streamed in
chunks of the canonical order (:mod:`modquad_gym.polyominoes`); the first level holding a
feasible structure is the certified minimum, and the structure returned is the first feasible
one in canonical order, whatever the chunk size or the number of workers. Nothing is pruned
except by exact bounds (:mod:`.bounds`) and cached separating directions (:mod:`.checker`).

Large levels are split into ranges of chunks decided by worker processes
(:func:`scan_chunks` is the unit of work, runnable by any executor); the answer is the first
feasible structure of the first range that has one.
"""

from __future__ import annotations

import os
from collections.abc import Iterator
from concurrent.futures import ProcessPoolExecutor

import numpy as np

from ..module import ModuleType
from ..polyominoes import A001168, DEFAULT_CHUNK, PolyominoStream, level_chunks
from ..structure import Key, Structure, normalise
from ..validation import check_int
from .bounds import NO_SIZE, force_lower_bound, level_excluded
from .checker import TaskChecker
from .result import SearchResult, SearchRun

MAX_MODULES = 16
"""The exhaustive search's module limit: level 16 holds 1.0e8 structures, level 17 4.0e8."""

PARALLEL_FROM = 100_000
"""Levels with at least this many structures are split across worker processes."""

CHUNKS_PER_RANGE = 4


def level_size(n: int) -> int | None:
    return A001168[n - 1] if n <= len(A001168) else None


def _key(cells: np.ndarray) -> Key:
    return normalise(tuple(map(tuple, cells.tolist())))


def scan_chunks(
    W: np.ndarray,
    f_max: float,
    module: ModuleType,
    n: int,
    chunk: int,
    start: int,
    stop: int,
    pool: np.ndarray | None = None,
) -> tuple[Key | None, int, int]:
    """Decide chunks [start, stop) of level n: (key of the first feasible structure or None,
    structures evaluated, oracle calls). ``pool`` seeds the separating directions."""
    checker = TaskChecker(W, f_max, module)
    for d in (pool if pool is not None else [])[::-1]:
        checker.remember(d)
    for cells in level_chunks(n, chunk, start, stop):
        i = checker.first_feasible(cells)
        if i is not None:
            return _key(cells[i]), checker.evaluated, checker.oracle_calls
    return None, checker.evaluated, checker.oracle_calls


def _ranges(n: int, chunk: int) -> Iterator[tuple[int, int]]:
    total = level_size(n) or sum(len(c) for c in PolyominoStream(n, chunk))
    n_chunks = -(-total // chunk)
    for start in range(0, n_chunks, CHUNKS_PER_RANGE):
        yield start, min(start + CHUNKS_PER_RANGE, n_chunks)


def _scan_parallel(run: SearchRun, n: int, chunk: int, workers: int) -> Key | None:
    checker = run.checker
    with ProcessPoolExecutor(max_workers=workers) as ex:
        futures = [
            ex.submit(scan_chunks, run.W, run.f_max, run.module, n, chunk, a, b, checker.pool)
            for a, b in _ranges(n, chunk)
        ]
        try:
            for fut in futures:  # in canonical order: the first range with an answer wins
                key, evaluated, calls = fut.result()
                checker.evaluated += evaluated
                checker.oracle_calls += calls
                if key is not None:
                    return key
        finally:
            for fut in futures:
                fut.cancel()
    return None


def _scan(run: SearchRun, n: int, chunk: int, workers: int, progress) -> Iterator[Key]:
    """Keys of the feasible structures of level n, in canonical order (lazily)."""
    size = level_size(n)
    if workers > 1 and size is not None and size >= PARALLEL_FROM:
        key = _scan_parallel(run, n, chunk, workers)
        if progress is not None:
            progress.update(size)
        if key is not None:
            yield key
        return
    for cells in PolyominoStream(n, chunk):
        rest = cells
        while len(rest):
            i = run.checker.first_feasible(rest)
            if i is None:
                break
            yield _key(rest[i])
            rest = rest[i + 1 :]
        if progress is not None:
            progress.update(len(cells))


def _workers(workers: int | None) -> int:
    if workers is None:
        return max(1, min(os.cpu_count() or 1, 8))
    return check_int(workers, "workers", low=1)


def _progress(enabled: bool, n: int):
    if not enabled:
        return None
    from tqdm.auto import tqdm

    # shown only when a level takes more than half a second
    return tqdm(total=level_size(n), desc=f"level {n}", unit=" structures", leave=False, delay=0.5)


def _levels_to_search(run: SearchRun) -> tuple[int, list[int], str]:
    """(first level to search, levels ruled out as a whole, proof when none is left)."""
    n_lb = force_lower_bound(run.W, run.module, run.f_max)
    if n_lb == NO_SIZE:
        return NO_SIZE, [], "force bound: no number of modules can exert the task's forces"
    run.check_budget(n_lb)
    skipped = list(range(1, min(n_lb, run.n_max + 1)))
    if n_lb > run.n_max:
        return n_lb, skipped, f"force bound: the task's forces need at least {n_lb} modules"
    return n_lb, skipped, ""


def _search_levels(run: SearchRun, chunk, workers, progress, first_only):
    n_lb, skipped, proof = _levels_to_search(run)
    for n in range(n_lb, run.n_max + 1) if not proof else ():
        if level_excluded(run.W, run.f_max, run.module, n):
            skipped.append(n)
            continue
        bar = _progress(progress, n)
        try:
            found = []
            for key in _scan(run, n, chunk, workers if first_only else 1, bar):
                found.append(key)
                if first_only:
                    break
        finally:
            if bar is not None:
                bar.close()
        if found:
            return n, found, skipped, proof
    return None, [], skipped, proof


def exhaustive_search(
    task,
    n_max: int = 7,
    f_max: float | None = None,
    module: ModuleType | None = None,
    *,
    workers: int | None = 1,
    chunk: int = DEFAULT_CHUNK,
    progress: bool = False,
) -> SearchResult:
    """Certified minimum-module structure for ``task`` (a (t, 6) wrench array or a
    TaskRequirement), searching every connected structure of up to ``n_max`` modules.

    ``certified`` is always True: either the structure is minimal, or no structure of up to
    ``n_max`` modules can satisfy the task. ``workers`` processes share large levels (None:
    every local core); the answer does not depend on ``workers`` or ``chunk`` (``evaluated``
    does, since each worker learns its own separating directions). ``progress`` shows a bar
    per level on stderr.
    """
    run = SearchRun("exhaustive", task, n_max, f_max, module, MAX_MODULES)
    chunk = check_int(chunk, "chunk", low=1)
    n, keys, skipped, proof = _search_levels(run, chunk, _workers(workers), progress, True)
    structure = Structure.from_trusted(keys[0], run.module) if keys else None
    return run.finish(structure, True, skipped, proof)


def optimal_structures(
    task,
    n_max: int = 7,
    f_max: float | None = None,
    module: ModuleType | None = None,
    *,
    chunk: int = DEFAULT_CHUNK,
) -> tuple[int | None, list[Key]]:
    """Every minimum-module structure of ``task``: (n*, keys of all feasible structures of n*
    modules, up to translation, in canonical order), or (None, []) when none of up to
    ``n_max`` modules works. Certified like :func:`exhaustive_search`, which stops at the
    first feasible structure; this one decides the whole minimal level."""
    run = SearchRun("exhaustive", task, n_max, f_max, module, MAX_MODULES)
    n, keys, _, _ = _search_levels(run, check_int(chunk, "chunk", low=1), 1, False, False)
    return n, keys
