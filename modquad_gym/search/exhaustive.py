"""The certified exhaustive search (paper Sec. V-A) and the whole minimal level.

Every connected structure up to translation is visited level by level, each level streamed in
chunks of the canonical order (:mod:`modquad_gym.geometry.polyominoes`); the first level holding a
feasible structure is the certified minimum, and the structure returned is the first feasible
one in canonical order, whatever the chunk size or the number of workers. Nothing is pruned
except by exact bounds (:mod:`.bounds`) and cached separating directions (:mod:`.checker`).

Large levels may be split into ranges of chunks decided in parallel by an ``engine`` the caller
passes in (the CLI and the benchmarks pass :class:`modquad_gym.core.distributed.Engine`: Ray
tasks; :func:`scan_chunks` decides any range alone); the answer is the first feasible structure
of the first range that has one, so it is the same for any number of workers, on one machine or
a cluster. This package never imports Ray itself.

Several module types (``modules=[...]``) or a task of kind ``external``: every (shape, type
assignment) pair is visited level by level, by :mod:`.typed` (re-exported here).

``start=``: only the structures containing a given partial structure are searched
(:mod:`.partial`); the answer is the minimum among them, its lower bound the task's.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Iterator, Sequence
from dataclasses import dataclass
from functools import partial
from itertools import islice
from typing import Any, NamedTuple, Protocol

import numpy as np

from modquad_gym.core.compile_clock import now
from modquad_gym.core.validation import check_int
from modquad_gym.dynamics import LinearWrenches
from modquad_gym.geometry.module import ModuleType
from modquad_gym.geometry.polyominoes import DEFAULT_CHUNK, PolyominoStream, level_chunks
from modquad_gym.geometry.structure import Key, Structure, normalise, normalise_typed
from modquad_gym.search.bounds import NO_SIZE, bound_levels, force_lower_bound, level_excluded
from modquad_gym.search.checker import TaskChecker
from modquad_gym.search.levels import (
    ChunkBar,
    KeptKeys,
    LevelAnswer,
    Optima,
    level_progress,
    level_size,
)
from modquad_gym.search.options import check_chunk, count
from modquad_gym.search.partial import Partial, make_partial
from modquad_gym.search.problem import EXACT_MODULES, SearchProblem, search_entry
from modquad_gym.search.result import SearchResult, SearchRun
from modquad_gym.search.typed import (
    MAX_PAIRS,
    PAIRS_PER_BLOCK,
    assignments,
    check_pair_budget,
    search_typed,
    typed_structure,
)

PARALLEL_FROM = 100_000
"""Levels with at least this many structures are split into ranges (with an engine)."""

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


class ChunkScan(NamedTuple):
    """What :func:`scan_chunks` found in a range of chunks."""

    key: Key | None
    evaluated: int
    oracle_calls: int


@dataclass
class RangeScan:
    """One range of a split level, decided alone (one engine task)."""

    key: Key | None  # the first feasible structure of the range, or None
    evaluated: int
    oracle_calls: int
    pool: np.ndarray  # the separating directions known at the end
    seen: int  # structures of the range decided or passed


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
) -> ChunkScan:
    """Decide chunks [start, stop) of level n: the key of the first feasible structure or None,
    structures evaluated, oracle calls. ``pool`` seeds the separating directions."""
    checker = _seeded_checker(TaskChecker(LinearWrenches.of_static(W), f_max, module), pool)
    key, _ = _first_key(checker, level_chunks(n, chunk, start, stop), None)
    return ChunkScan(key, checker.evaluated, checker.oracle_calls)


def _seeded_checker(checker: TaskChecker, pool: np.ndarray | None) -> TaskChecker:
    if pool is not None and len(pool):
        checker.adopt(pool)
    return checker


def _first_key(checker: TaskChecker, chunks, part: Partial | None) -> tuple[Key | None, int]:
    """(key of the first feasible structure of ``chunks`` (containing ``part``), structures
    in the chunks read)."""
    seen = 0
    for cells in chunks:
        seen += len(cells)
        kept = cells if part is None else cells[part.mask(cells)]
        i = checker.first_feasible(kept)
        if i is not None:
            return _key(kept[i]), seen
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


def _scan_range(
    problem: SearchProblem, n: int, chunk: int, pool, part: Partial | None, job
) -> RangeScan:
    """One range (an engine task), decided with a fresh checker seeded with ``pool``."""
    count, state = job
    stream = PolyominoStream(n, chunk)
    stream.restore(state)
    checker = _seeded_checker(problem.checker(), pool)
    key, seen = _first_key(checker, islice(stream, count), part)
    return RangeScan(key, checker.evaluated, checker.oracle_calls, checker.pool, seen)


def _scan_parallel(
    run: SearchRun, n: int, chunk: int, engine: OrderedEngine, progress, part
) -> Key | None:
    """The first feasible structure of level n: ranges of chunks as tasks on ``engine``, each
    seeded with the separating directions known before the level; ranges after the first
    answer are cancelled, the work of ranges up to it is counted. With no answer, the
    directions the ranges learnt are kept for the next level."""

    def advance(_i: int, result: RangeScan) -> None:
        if progress is not None:
            progress.update(result.seen)

    pool = run.checker.pool.copy()
    scan = partial(_scan_range, run.problem, n, chunk, pool, part)
    results: list[RangeScan] = engine.first(
        scan, _ranges(n, chunk), lambda r: r.key is not None, on_result=advance
    )
    for r in results:
        run.checker.evaluated += r.evaluated
        run.checker.oracle_calls += r.oracle_calls
    key = results[-1].key
    if key is None:  # newest first: the last ranges' directions, then the earlier ones
        run.checker.adopt(np.vstack([r.pool for r in reversed(results)]))
    return key


def _scan(
    run: SearchRun, n: int, chunk: int, engine: OrderedEngine | None, progress, part
) -> Iterator[Key]:
    """Keys of the feasible structures of level n (containing ``part``), in canonical order
    (lazily); only the first one when the level is split across ``engine``'s workers."""
    size = level_size(n)
    if engine is not None and size is not None and size >= PARALLEL_FROM:
        key = _scan_parallel(run, n, chunk, engine, progress, part)
        if key is not None:
            yield key
        return
    for cells in PolyominoStream(n, chunk):
        rest = cells if part is None else cells[part.mask(cells)]
        moves = ChunkBar(progress, len(cells))
        while len(rest):
            i = run.checker.first_feasible(rest, seen=moves.seen)
            if i is None:
                break
            yield _key(rest[i])
            rest = rest[i + 1 :]
            moves.start += i + 1
        moves.close()


@dataclass
class Levels:
    """Which levels a search visits: the first one, those ruled out before it, and the proof
    when none is left."""

    first: int
    skipped: list[int]
    proof: str


def _levels_to_search(run: SearchRun, part: Partial | None) -> Levels:
    """The levels left by the force bound (the first at least the size of ``part``: smaller
    levels hold no structure containing it, they are not searched, nor ruled out)."""
    p = run.problem
    n_lb = force_lower_bound(p.wrenches, p.module, p.f_max, p.fault)
    if n_lb == NO_SIZE:
        return Levels(NO_SIZE, [], "force bound: no number of modules can exert the task's forces")
    run.check_budget(EXACT_MODULES, n_lb)
    skipped = list(range(1, min(n_lb, p.n_max + 1)))
    first = n_lb if part is None else max(n_lb, part.size)  # part.size <= n_max: checked
    if n_lb > p.n_max:
        return Levels(n_lb, skipped, f"force bound: the task's forces need at least {n_lb} modules")
    return Levels(first, skipped, "")


def _search_levels(
    run: SearchRun, chunk, engine, progress, first_only, part, keep=None
) -> LevelAnswer:
    """The first level holding a feasible structure (containing ``part``) and its feasible
    structures (only the first with ``first_only``)."""
    p = run.problem
    levels = _levels_to_search(run, part)
    skipped = levels.skipped
    run.skipped += sum(level_size(n) or 0 for n in skipped)
    for n in range(levels.first, p.n_max + 1) if not levels.proof else ():
        if level_excluded(p.wrenches, p.f_max, p.module, n, p.fault):
            skipped.append(n)
            run.skipped += level_size(n) or 0
            continue
        bar = level_progress(progress, n)
        try:
            found = KeptKeys(keep)  # the first `keep` keys, and how many
            for key in _scan(run, n, chunk, engine if first_only else None, bar, part):
                found.add(key)
                if first_only:
                    break
        finally:
            if bar is not None:
                bar.close()
        if found:
            return LevelAnswer(n, found, skipped, levels.proof)
    proof = levels.proof
    if not proof and len(skipped) == p.n_max:  # no level searched: bounds ruled out every one
        proof = f"level bounds: no structure of 1 to {p.n_max} modules reaches the task"
    return LevelAnswer(None, [], skipped, proof)


def _exhaustive(
    run: SearchRun, chunk: int, engine, progress: bool, first_only: bool, part, keep=None
) -> LevelAnswer:
    """The minimal level of ``run``'s problem: the one-type search or the typed one."""
    run.reach = EXACT_MODULES  # the typed search too: what an infeasible answer may advise
    if run.problem.shape_only:
        return _search_levels(run, chunk, engine, progress, first_only, part, keep)
    return search_typed(run, progress, first_only, part)


@search_entry("exhaustive")
def exhaustive_search(
    problem: SearchProblem,
    *,
    engine: OrderedEngine | None = None,
    chunk: int = DEFAULT_CHUNK,
    progress: bool = False,
    start: Structure | Sequence[tuple[int, int]] | None = None,
) -> SearchResult:
    """Certified minimum-module structure for ``task`` (a (t, 6) wrench array or a
    TaskRequirement), searching every connected structure of up to ``n_max`` modules.

    Without ``start`` it is certified: the structure is minimal (``lower_bound`` = ``n_modules``:
    every smaller level refuted, by exact bounds or structure by structure), or none of up to
    ``n_max`` modules satisfies the task (``lower_bound`` > n_max: n_max + 1, or more where the
    exact bounds prove more, :mod:`.beyond`); with ``start``, as below. With an ``engine``
    (``modquad_gym.core.distributed.Engine(workers)``, used inside its ``with`` block so Ray
    starts once) levels of at least :data:`PARALLEL_FROM` structures are split into ranges
    decided in parallel. The answer does not depend on the engine or ``chunk``; ``evaluated``
    depends on ``chunk`` and on whether levels are split (each range learns its own separating
    directions), not on the number of workers. ``progress`` shows a bar per level on stderr.

    ``modules=[mA, mB, ...]`` searches every shape with every assignment of those types (one
    per cell; the module docstring gives the order and the pruning); the result's
    ``structure.modules`` lists each cell's type in ``structure.cells`` order. ``kind``
    overrides the task's kind (``external``: the rotors also carry the structure's weight).
    The typed search runs in this process (``engine`` applies to one-type ``total`` tasks).

    ``start`` (a Structure, or connected (x, y) cells, at most ``n_max`` of them): only
    structures containing it up to translation are searched (its module types too when it is
    a Structure of a search over several types). The structure returned is the minimum among
    them (``scope`` says so, and the message); ``lower_bound`` stays what is proved for the
    task, by the exact bounds (:func:`~.bounds.bound_levels`), so ``certified`` (status
    ``optimal``) only when the answer meets it, and ``infeasible`` only when the bounds rule
    out every level.
    """
    run = SearchRun("exhaustive", problem)
    chunk = check_chunk(chunk)
    part = None
    if start is not None:
        part = make_partial(start, problem.palette, problem.typed, problem.n_max)
    answer = _exhaustive(run, chunk, engine, progress, True, part)
    bound = problem.n_max + 1 if answer.n is None else answer.n
    scope = "" if part is None else "containing start"
    if part is not None:  # proved for the structures containing start only: the task's bound
        bound = bound_levels(problem)
    proof = answer.proof if bound > problem.n_max else ""
    if answer.n is None:
        return run.finish(None, bound, answer.skipped, proof, scope)
    if problem.shape_only:
        structure = Structure.from_trusted(answer.found[0], problem.module)
    else:
        structure = typed_structure(problem, answer.found[0])
    return run.finish(structure, bound, answer.skipped, proof, scope)


@search_entry("exhaustive", options={"max_keys": ("most structures kept (None: all)", count(1))})
def optimal_level(
    problem: SearchProblem,
    *,
    chunk: int = DEFAULT_CHUNK,
    max_keys: int | None = None,
    progress: bool = False,
) -> Optima:
    """Every minimum-module structure of ``task`` with the work it took (:class:`Optima`).
    Certified like :func:`exhaustive_search`, which stops at the first feasible structure; this
    one decides the whole minimal level (in this process: batches of tasks are what
    :mod:`modquad_gym.core.distributed` spreads). ``max_keys`` keeps only the first structures
    (``count`` still counts them all), bounding memory on huge levels. With ``modules`` the
    keys are typed, ``((x, y), type)`` pairs, as :func:`optimal_structures` gives them.
    ``progress`` shows a bar per level on stderr, as :func:`exhaustive_search` does."""
    run = SearchRun("exhaustive", problem)
    keep = None if max_keys is None else check_int(max_keys, "max_keys", low=1)
    answer = _exhaustive(run, check_chunk(chunk), None, progress, False, None, keep)
    keys, typed = KeptKeys(keep), not run.problem.shape_only  # typed: external task
    for found in answer.found:
        s = typed_structure(run.problem, found) if typed else None
        keys.add(found if s is None else normalise_typed(s.cells, s.modules) if run.problem.typed
                 else s.key)  # fmt: skip
    return Optima(
        n_modules=answer.n,
        keys=list(keys),
        count=getattr(answer.found, "total", keys.total),
        evaluated=run.checker.evaluated,
        oracle_calls=run.checker.oracle_calls,
        seconds=now() - run.t0,
        proof=answer.proof,
    )


@search_entry("exhaustive")
def optimal_structures(
    problem: SearchProblem,
    *,
    chunk: int = DEFAULT_CHUNK,
) -> tuple[int | None, list]:
    """Every minimum-module structure of ``task``: (n*, keys of all feasible structures of n*
    modules, up to translation, in canonical order), or (None, []) when none of up to
    ``n_max`` modules works. Certified like :func:`exhaustive_search`, which stops at the
    first feasible structure; this one decides the whole minimal level. With ``modules`` or
    an ``external`` task the keys are typed
    (:func:`~modquad_gym.geometry.structure.normalise_typed`; one-type structures of such a
    search too)."""
    run = SearchRun("exhaustive", problem)
    answer = _exhaustive(run, check_chunk(chunk), None, False, False, None)
    if problem.shape_only:
        return answer.n, answer.found
    structures = (typed_structure(problem, f) for f in answer.found)
    if problem.typed:
        return answer.n, [normalise_typed(s.cells, s.modules) for s in structures]
    return answer.n, [s.key for s in structures]


__all__ = ["EXACT_MODULES", "MAX_PAIRS", "PAIRS_PER_BLOCK", "ChunkScan", "OrderedEngine",
           "assignments", "check_pair_budget", "exhaustive_search", "level_size",
           "normalise_typed", "optimal_level", "optimal_structures", "scan_chunks"]  # fmt: skip
