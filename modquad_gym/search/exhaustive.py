"""The certified exhaustive search (paper Sec. V-A) and the whole minimal level.

Every connected structure up to translation is visited level by level, each level streamed in
chunks of the canonical order (:mod:`modquad_gym.geometry.polyominoes`); the first level holding a
feasible structure is the certified minimum, and the structure returned is the first feasible
one in canonical order, whatever the chunk size or the number of workers. Nothing is pruned
except by exact bounds (:mod:`.bounds`) and cached separating directions (:mod:`.checker`).

Large levels are split into ranges of chunks decided as Ray tasks
(:mod:`modquad_gym.core.distributed`; :func:`scan_chunks` decides any range alone); the answer
is the first feasible structure of the first range that has one, so it is the same for any number of
workers, on one machine or a cluster.

Several module types (``modules=[...]``) or a task of kind ``external``: every (shape, type
assignment) pair is visited level by level, by :mod:`.typed` (re-exported here).
"""

from __future__ import annotations

import os
import time
from collections.abc import Iterator, Sequence
from contextlib import nullcontext
from functools import partial
from itertools import islice

import numpy as np

from modquad_gym.core.distributed import Engine
from modquad_gym.core.validation import check_int
from modquad_gym.geometry.module import ModuleType
from modquad_gym.geometry.polyominoes import DEFAULT_CHUNK, PolyominoStream, level_chunks
from modquad_gym.geometry.structure import Key, Structure, normalise, normalise_typed
from modquad_gym.search.bounds import NO_SIZE, force_lower_bound, level_excluded
from modquad_gym.search.checker import TaskChecker
from modquad_gym.search.levels import level_progress, level_size
from modquad_gym.search.result import KeptKeys, Optima, SearchResult, SearchRun
from modquad_gym.search.typed import (
    MAX_PAIRS,
    PAIRS_PER_BLOCK,
    assignments,
    check_pair_budget,
    search_typed,
    typed_structure,
)

MAX_MODULES = 16
"""The exhaustive search's module limit: level 16 holds 1.0e8 structures, level 17 4.0e8."""

PARALLEL_FROM = 100_000
"""Levels with at least this many structures are split into Ray tasks (with workers > 1)."""

CHUNKS_PER_RANGE = 16
"""Chunks per Ray task of a split level (262,144 structures with the default chunk): each task
starts a fresh cache of separating directions, so fewer, longer tasks waste less."""


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
    checker = _seeded_checker(W, f_max, module, pool)
    key, _ = _first_key(checker, level_chunks(n, chunk, start, stop))
    return key, checker.evaluated, checker.oracle_calls


def _seeded_checker(W, f_max, module, pool) -> TaskChecker:
    checker = TaskChecker(W, f_max, module)
    if pool is not None and len(pool):
        checker.adopt(pool)
    return checker


def _first_key(checker: TaskChecker, chunks) -> tuple[Key | None, int]:
    """(key of the first feasible structure of ``chunks``, structures in the chunks read)."""
    seen = 0
    for cells in chunks:
        seen += len(cells)
        i = checker.first_feasible(cells)
        if i is not None:
            return _key(cells[i]), seen
    return None, seen


def _ranges(n: int, chunk: int) -> Iterator[tuple[int, tuple]]:
    """Ranges of CHUNKS_PER_RANGE chunks of level n in canonical order, each as (chunks, the
    enumeration's state at its start). Lazy: one pass over the level, read only as far ahead
    as the tasks in flight need (enumerating is several times faster than deciding)."""
    total = level_size(n) or sum(len(c) for c in PolyominoStream(n, chunk))
    n_chunks = -(-total // chunk)
    stream = PolyominoStream(n, chunk)
    for start in range(0, n_chunks, CHUNKS_PER_RANGE):
        count = min(CHUNKS_PER_RANGE, n_chunks - start)
        yield count, stream.snapshot()
        stream.skip(count)


def _scan_range(W, f_max, module, n, chunk, pool, job) -> tuple:
    """One range (a Ray task): (first feasible key or None, evaluated, oracle calls, the
    separating directions known at the end, structures decided or passed)."""
    count, state = job
    stream = PolyominoStream(n, chunk)
    stream.restore(state)
    checker = _seeded_checker(W, f_max, module, pool)
    key, seen = _first_key(checker, islice(stream, count))
    return key, checker.evaluated, checker.oracle_calls, checker.pool, seen


def _scan_parallel(run: SearchRun, n: int, chunk: int, engine: Engine, progress) -> Key | None:
    """The first feasible structure of level n: ranges of chunks as tasks on ``engine``, each
    seeded with the separating directions known before the level; ranges after the first
    answer are cancelled, the work of ranges up to it is counted. With no answer, the
    directions the ranges learnt are kept for the next level."""

    def advance(_i: int, result) -> None:
        if progress is not None:
            progress.update(result[4])

    scan = partial(_scan_range, run.W, run.f_max, run.module, n, chunk, run.checker.pool.copy())
    results = engine.first(scan, _ranges(n, chunk), lambda r: r[0] is not None, on_result=advance)
    for _, evaluated, calls, _, _ in results:
        run.checker.evaluated += evaluated
        run.checker.oracle_calls += calls
    key = results[-1][0]
    if key is None:  # newest first: the last ranges' directions, then the earlier ones
        run.checker.adopt(np.vstack([r[3] for r in reversed(results)]))
    return key


def _scan(run: SearchRun, n: int, chunk: int, engine: Engine | None, progress) -> Iterator[Key]:
    """Keys of the feasible structures of level n, in canonical order (lazily); only the first
    one when the level is split across ``engine``'s workers."""
    size = level_size(n)
    if engine is not None and size is not None and size >= PARALLEL_FROM:
        key = _scan_parallel(run, n, chunk, engine, progress)
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


def _search_levels(run: SearchRun, chunk, engine, progress, first_only, keep=None):
    n_lb, skipped, proof = _levels_to_search(run)
    run.skipped += sum(level_size(n) or 0 for n in skipped)
    for n in range(n_lb, run.n_max + 1) if not proof else ():
        if level_excluded(run.W, run.f_max, run.module, n):
            skipped.append(n)
            run.skipped += level_size(n) or 0
            continue
        bar = level_progress(progress, n)
        try:
            found = KeptKeys(keep)  # the first `keep` keys, and how many
            for key in _scan(run, n, chunk, engine if first_only else None, bar):
                found.add(key)
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
    modules: Sequence[ModuleType] | None = None,
    kind: str | None = None,
    workers: int | None = 1,
    address: str | None = None,
    chunk: int = DEFAULT_CHUNK,
    progress: bool = False,
) -> SearchResult:
    """Certified minimum-module structure for ``task`` (a (t, 6) wrench array or a
    TaskRequirement), searching every connected structure of up to ``n_max`` modules.

    ``certified`` is always True: either the structure is minimal, or no structure of up to
    ``n_max`` modules can satisfy the task. With ``workers`` > 1 (None: every local core, at
    most 8) levels of at least :data:`PARALLEL_FROM` structures are split into Ray tasks, on
    an embedded Ray or the cluster at ``address`` / ``RAY_ADDRESS``
    (:mod:`modquad_gym.core.distributed`; serial when Ray is not installed). The answer does not
    depend on ``workers``, ``address`` or ``chunk``; ``evaluated`` depends on ``chunk`` and on
    whether levels are split (each range learns its own separating directions), not on the
    number of workers. ``progress`` shows a bar per level on stderr.

    ``modules=[mA, mB, ...]`` searches every shape with every assignment of those types (one
    per cell; the module docstring gives the order and the pruning); the result's
    ``structure.modules`` lists each cell's type in ``structure.cells`` order. ``kind``
    overrides the task's kind (``external``: the rotors also carry the structure's weight).
    The typed search runs in this process (``workers`` applies to one-type ``total`` tasks).
    """
    run = SearchRun("exhaustive", task, n_max, f_max, module, MAX_MODULES, modules, kind)
    chunk = check_int(chunk, "chunk", low=1)
    if not run.homogeneous_total:
        n, found, skipped, proof = search_typed(run, progress, True)
        structure = typed_structure(run, found[0]) if found else None
        return run.finish(structure, True, skipped, proof)
    workers = _workers(workers)
    engine = Engine(workers, address) if workers > 1 else None
    with engine or nullcontext():  # Ray starts at the first split level, once per search
        n, keys, skipped, proof = _search_levels(run, chunk, engine, progress, True)
    structure = Structure.from_trusted(keys[0], run.module) if keys else None
    return run.finish(structure, True, skipped, proof)


def optimal_level(
    task,
    n_max: int = 7,
    f_max: float | None = None,
    module: ModuleType | None = None,
    *,
    chunk: int = DEFAULT_CHUNK,
    max_keys: int | None = None,
) -> Optima:
    """Every minimum-module structure of ``task`` (one module type) with the work it took
    (:class:`Optima`). Certified like :func:`exhaustive_search`, which stops at the first
    feasible structure; this one decides the whole minimal level (in this process: batches of
    tasks are what :mod:`modquad_gym.core.distributed` spreads). ``max_keys`` keeps only the
    first structures (``count`` still counts them all), bounding memory on huge levels."""
    run = SearchRun("exhaustive", task, n_max, f_max, module, MAX_MODULES)
    chunk = check_int(chunk, "chunk", low=1)
    if max_keys is not None:
        max_keys = check_int(max_keys, "max_keys", low=1)
    if run.homogeneous_total:
        n, keys, _, proof = _search_levels(run, chunk, None, False, False, max_keys)
    else:  # an external task: self-weight, one type
        n, found, _, proof = search_typed(run, False, False)
        keys = KeptKeys(max_keys)
        for f in found:
            keys.add(typed_structure(run, f).key)
    return Optima(
        n_modules=n,
        keys=list(keys),
        count=getattr(keys, "total", len(keys)),
        evaluated=run.checker.evaluated,
        oracle_calls=run.checker.oracle_calls,
        seconds=time.perf_counter() - run.t0,
        proof=proof,
    )


def optimal_structures(
    task,
    n_max: int = 7,
    f_max: float | None = None,
    module: ModuleType | None = None,
    *,
    modules: Sequence[ModuleType] | None = None,
    kind: str | None = None,
    chunk: int = DEFAULT_CHUNK,
) -> tuple[int | None, list]:
    """Every minimum-module structure of ``task``: (n*, keys of all feasible structures of n*
    modules, up to translation, in canonical order), or (None, []) when none of up to
    ``n_max`` modules works. Certified like :func:`exhaustive_search`, which stops at the
    first feasible structure; this one decides the whole minimal level. With ``modules`` or
    an ``external`` task the keys are typed
    (:func:`~modquad_gym.geometry.structure.normalise_typed`; one-type structures of such a
    search too)."""
    run = SearchRun("exhaustive", task, n_max, f_max, module, MAX_MODULES, modules, kind)
    if not run.homogeneous_total:
        n, found, _, _ = search_typed(run, False, False)
        structures = (typed_structure(run, f) for f in found)
        if run.typed:
            return n, [normalise_typed(s.cells, s.modules) for s in structures]
        return n, [s.key for s in structures]
    n, keys, _, _ = _search_levels(run, check_int(chunk, "chunk", low=1), None, False, False)
    return n, keys


__all__ = [
    "MAX_MODULES",
    "MAX_PAIRS",
    "PAIRS_PER_BLOCK",
    "assignments",
    "check_pair_budget",
    "exhaustive_search",
    "level_size",
    "normalise_typed",
    "optimal_level",
    "optimal_structures",
    "scan_chunks",
]
