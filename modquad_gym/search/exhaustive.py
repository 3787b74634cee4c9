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

from collections.abc import Iterator, Sequence
from contextlib import nullcontext
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from modquad_gym.core.compile_clock import now
from modquad_gym.core.validation import check_int
from modquad_gym.dynamics import LinearWrenches
from modquad_gym.geometry.module import ModuleType
from modquad_gym.geometry.polyominoes import DEFAULT_CHUNK, PolyominoStream, level_chunks
from modquad_gym.geometry.structure import Key, Structure, normalise_typed
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
from modquad_gym.search.split import (
    OrderedEngine,
    check_engine,
    first_key,
    key_of,
    scan_parallel,
    seeded_checker,
)
from modquad_gym.search.typed import (
    MAX_PAIRS,
    PAIRS_PER_BLOCK,
    assignments,
    check_pair_budget,
    search_typed,
    typed_structure,
)

PARALLEL_FROM = 100_000
"""Levels with at least this many structures are split into ranges (with an engine,
:mod:`.split`)."""


class ChunkScan(NamedTuple):
    """What :func:`scan_chunks` found in a range of chunks."""

    key: Key | None
    evaluated: int
    oracle_calls: int


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
    checker = seeded_checker(TaskChecker(LinearWrenches.of_static(W), f_max, module), pool)
    key, _ = first_key(checker, level_chunks(n, chunk, start, stop), None)
    return ChunkScan(key, checker.evaluated, checker.oracle_calls)


def _scan(
    run: SearchRun, n: int, chunk: int, engine: OrderedEngine | None, progress, part
) -> Iterator[Key]:
    """Keys of the feasible structures of level n (containing ``part``), in canonical order
    (lazily); only the first one when the level is split across ``engine``'s workers."""
    size = level_size(n)
    if engine is not None and size is not None and size >= PARALLEL_FROM:
        key = scan_parallel(run, n, chunk, engine, progress, part)
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
            yield key_of(rest[i])
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
    (``modquad_gym.core.distributed.Engine(workers)``; its Ray starts once, at the first split
    level, and stops after the result unless the caller's ``with`` block holds it) levels of at
    least :data:`PARALLEL_FROM` structures are split into ranges decided in parallel. The
    answer does not depend on the engine or ``chunk``; ``evaluated`` depends on ``chunk`` and on
    whether levels are split (each range learns its own separating directions), not on the
    number of workers. ``progress`` shows a bar per level on stderr.

    ``modules=[mA, mB, ...]`` searches every shape with every assignment of those types (one
    per cell; the module docstring gives the order and the pruning); the result's
    ``structure.modules`` lists each cell's type in ``structure.cells`` order. ``kind``
    overrides the task's kind (``external``: the rotors also carry the structure's weight).
    The typed search runs in this process: an ``engine`` of several workers is refused for it
    (ValueError; :func:`~.split.check_engine`). Ray's start is not counted in ``seconds``
    (``ray_start_seconds`` says how long it took).

    ``start`` (a Structure, or connected (x, y) cells, at most ``n_max`` of them): only
    structures containing it up to translation are searched (its module types too when it is
    a Structure of a search over several types). The structure returned is the minimum among
    them (``scope`` says so, and the message); ``lower_bound`` stays what is proved for the
    task, by the exact bounds (:func:`~.bounds.bound_levels`), so ``certified`` (status
    ``optimal``) only when the answer meets it, and ``infeasible`` only when the bounds rule
    out every level.
    """
    check_engine(problem, engine)
    run = SearchRun("exhaustive", problem)
    chunk = check_chunk(chunk)
    part = None
    if start is not None:
        part = make_partial(start, problem.palette, problem.typed, problem.n_max)
    with engine if hasattr(engine, "__enter__") else nullcontext():  # Ray starts once
        return _exhaustive_result(run, _exhaustive(run, chunk, engine, progress, True, part), part)


def _exhaustive_result(run: SearchRun, answer: LevelAnswer, part: Partial | None) -> SearchResult:
    """:func:`exhaustive_search`'s result of the minimal level ``answer``."""
    problem = run.problem
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
