"""The exhaustive search's large levels split over an engine's workers (:mod:`.exhaustive`).

A level is cut into ranges of :data:`CHUNKS_PER_RANGE` chunks in canonical order; each range is
decided alone (a fresh checker seeded with the separating directions known before the level)
as one task of an engine (:class:`OrderedEngine`, e.g.
:class:`modquad_gym.core.distributed.Engine`), and the answer is the first feasible structure
of the first range that has one, so it does not depend on the number of workers. Only the
one-type search of a task whose rotor wrenches do not depend on the structure splits: the
typed search runs in this process, and an engine of several workers given for it is refused
(:func:`check_engine`) rather than silently left unused. Ray's start is not the search's time
(:func:`start_engine`), as for the anytime search.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Iterator
from dataclasses import dataclass
from functools import partial
from itertools import islice
from typing import Any, Protocol

import numpy as np

from modquad_gym.core.compile_clock import now
from modquad_gym.geometry.polyominoes import PolyominoStream
from modquad_gym.geometry.structure import Key, normalise
from modquad_gym.search.checker import TaskChecker
from modquad_gym.search.levels import level_size
from modquad_gym.search.partial import Partial
from modquad_gym.search.problem import SearchProblem
from modquad_gym.search.result import SearchRun

CHUNKS_PER_RANGE = 16
"""Chunks per range of a split level (262,144 structures with the default chunk): each range
starts a fresh cache of separating directions, so fewer, longer ranges waste less."""


class OrderedEngine(Protocol):
    """What a search needs to split a level: ``first(fn, items, accept, on_result=)`` returns
    the results of items 0..k in item order, k the first item whose result is accepted (every
    item when none is), as :meth:`modquad_gym.core.distributed.Engine.first` does."""

    def first(
        self,
        fn: Callable[[Any], Any],
        items: Iterable[Any],
        accept: Callable[[Any], bool],
        *,
        on_result: Callable[[int, Any], None] | None = None,
    ) -> list[Any]: ...


@dataclass
class RangeScan:
    """One range of a split level, decided alone (one engine task)."""

    key: Key | None  # the first feasible structure of the range, or None
    evaluated: int
    oracle_calls: int
    pool: np.ndarray  # the separating directions known at the end
    seen: int  # structures of the range decided or passed


def unsplit_reason(problem: SearchProblem) -> str | None:
    """Why ``problem``'s exhaustive search cannot be split over workers (it runs in this
    process), or None when it can."""
    if problem.shape_only:
        return None
    if len(problem.palette) > 1:
        return "the exhaustive search over several module types runs in this process"
    return (f"the exhaustive search of a task whose rotor wrenches depend on the structure "
            f"(kind {problem.kind}) runs in this process")  # fmt: skip


def check_engine(problem: SearchProblem, engine: Any) -> None:
    """ValueError naming ``engine`` when it has several workers (or no number: a cluster's
    CPUs) and ``problem``'s search would not use them (:func:`unsplit_reason`)."""
    if engine is None or getattr(engine, "workers", None) == 1:
        return
    why = unsplit_reason(problem)
    if why is not None:
        raise ValueError(
            f"engine {engine!r}: {why}, so its workers would stay idle; leave engine out (an "
            "engine splits the one-type search of a task of kind total)"
        )


def start_engine(run: SearchRun, engine: Any) -> None:
    """Start ``engine``'s Ray (when it has Ray workers) with the search's clock stopped: Ray's
    start is not the search's time, the result's ``ray_start_seconds`` says how long it took."""
    if not getattr(engine, "use_ray", False):
        return
    before = now()
    engine.start()
    took = now() - before
    run.ray_start_seconds += took
    run.t0 += took


def key_of(cells: np.ndarray) -> Key:
    """The key of one structure's cells."""
    return normalise(tuple(map(tuple, cells.tolist())))


def seeded_checker(checker: TaskChecker, pool: np.ndarray | None) -> TaskChecker:
    """``checker`` knowing the separating directions ``pool`` (None or empty: none)."""
    if pool is not None and len(pool):
        checker.adopt(pool)
    return checker


def first_key(checker: TaskChecker, chunks, part: Partial | None) -> tuple[Key | None, int]:
    """(key of the first feasible structure of ``chunks`` (containing ``part``), structures
    in the chunks read)."""
    seen = 0
    for cells in chunks:
        seen += len(cells)
        kept = cells if part is None else cells[part.mask(cells)]
        i = checker.first_feasible(kept)
        if i is not None:
            return key_of(kept[i]), seen
    return None, seen


def ranges(n: int, chunk: int) -> Iterator[tuple[int, tuple]]:
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


def scan_range(
    problem: SearchProblem, n: int, chunk: int, pool, part: Partial | None, job
) -> RangeScan:
    """One range (an engine task), decided with a fresh checker seeded with ``pool``."""
    count, state = job
    stream = PolyominoStream(n, chunk)
    stream.restore(state)
    checker = seeded_checker(problem.checker(), pool)
    key, seen = first_key(checker, islice(stream, count), part)
    return RangeScan(key, checker.evaluated, checker.oracle_calls, checker.pool, seen)


def scan_parallel(
    run: SearchRun, n: int, chunk: int, engine: OrderedEngine, progress, part
) -> Key | None:
    """The first feasible structure of level n: ranges of chunks as tasks on ``engine``, each
    seeded with the separating directions known before the level; ranges after the first
    answer are cancelled, the work of ranges up to it is counted. With no answer, the
    directions the ranges learnt are kept for the next level. Ray's start (at the first level
    of several ranges) is left out of the search's clock (:func:`start_engine`)."""

    def advance(_i: int, result: RangeScan) -> None:
        if progress is not None:
            progress.update(result.seen)

    if -(-(level_size(n) or 0) // chunk) > CHUNKS_PER_RANGE:  # tasks for the engine's workers
        start_engine(run, engine)  # (one range runs in this process, as the engine does)
    pool = run.checker.pool.copy()
    scan = partial(scan_range, run.problem, n, chunk, pool, part)
    results: list[RangeScan] = engine.first(
        scan, ranges(n, chunk), lambda r: r.key is not None, on_result=advance
    )
    for r in results:
        run.checker.evaluated += r.evaluated
        run.checker.oracle_calls += r.oracle_calls
    key = results[-1].key
    if key is None:  # newest first: the last ranges' directions, then the earlier ones
        run.checker.adopt(np.vstack([r.pool for r in reversed(results)]))
    return key
