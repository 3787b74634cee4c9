"""The paper's centrosymmetric heuristic (Sec. V-B, Algorithm 2 with errata 3 fixed), bounded by
a time limit and a memory check instead of a module limit.

Each level grows every structure of the previous level by a module and its centrosymmetric
partner. Levels grow about 3.8 times per two modules (64,716 structures at 19 modules, 249,283
at 21, counted; about 3.7 million at 25 predicted) and each is held in memory, so before and
while a level is built its size is checked against :data:`MEMORY_BUDGET` (:data:`GROWTH` times
the previous level, each structure :func:`key_bytes`): a level that would not fit is refused
with a one-line ValueError naming ``n_max``. At the time limit the search returns no structure
(it returns the first feasible one it meets, so none was found yet) with the proved lower
bound. Where it finishes, its answers are those of the paper's algorithm, unchanged.
"""

from __future__ import annotations

from collections.abc import Iterable, Iterator

from modquad_gym.core.validation import check_flag
from modquad_gym.geometry.structure import (
    Cell,
    Key,
    Structure,
    free_neighbours,
    normalise,
    normalise_typed,
)
from modquad_gym.search.heuristic import Deadline, heuristic_result, impossible_result
from modquad_gym.search.problem import DEFAULT_TIME_LIMIT, MAX_MODULES, SearchProblem, search_entry
from modquad_gym.search.result import SearchResult, SearchRun

MEMORY_BUDGET = 2 * 2**30
"""Bytes the levels held at once (both parities, and the level being built) may take."""

GROWTH = 4.0
"""Predicted ratio of a level's size to the level two modules smaller (measured: 3.5 to 3.83
from 5 to 19 modules, slowly rising); the prediction only refuses early, the count while a
level is built is exact."""


def key_bytes(n: int, typed: bool) -> int:
    """Bytes one structure of n modules takes in a level (its key tuple, one tuple per cell and,
    with types, one per (cell, type) pair, and its dict entry): measured with sys.getsizeof."""
    return 120 + n * (8 + 56 + (64 if typed else 0))


@search_entry(
    "centrosymmetric",
    options={"block_seed": ("also grow from a 2 x 2 block (even counts)", check_flag)},
)
def centrosymmetric_search(
    problem: SearchProblem,
    *,
    block_seed: bool = False,
    time_limit: float = DEFAULT_TIME_LIMIT,
) -> SearchResult:
    """Paper Algorithm 2: grow structures by a module *and* its centrosymmetric partner about
    the COM, so the COM never moves and every structure is torque-balanced by symmetry.

    Seeds: one module (odd counts 1, 3, 5, ...) and, with ``block_seed=True``, also a 2 x 2
    block (even counts 4, 6, ...). Levels are visited by increasing module count and the first
    feasible structure is returned; it is minimal among centrosymmetric structures reachable
    this way, not certified minimal overall. With ``modules`` every seed type and every type
    of each added pair is tried (a pair shares one type, diagonal pairs of the block too).
    Up to 128 modules within ``time_limit`` seconds and :data:`MEMORY_BUDGET` (module
    docstring).
    """
    run = SearchRun("centrosymmetric", problem)
    deadline = Deadline(run, time_limit)
    if (done := impossible_result(run, MAX_MODULES)) is not None:
        return done
    K = len(problem.palette)
    fronts = _seeds(K, block_seed and problem.n_max >= 4)
    for n in range(1, problem.n_max + 1):
        level = fronts.get(n, [])
        for key in level:
            if deadline.passed():
                return heuristic_result(run, None)
            if K == 1:
                s = Structure.from_trusted(key, problem.module)
            else:
                palette = problem.palette
                s = Structure.from_trusted(
                    tuple(c for c, _ in key), modules=tuple(palette[t] for _, t in key)
                )
            if run.checker.check(s):
                return heuristic_result(run, s)
        if level and n + 2 <= problem.n_max:
            grown = _grow_level(fronts, n, K, deadline)
            if grown is None:
                return heuristic_result(run, None)
            fronts[n + 2] = grown
        fronts.pop(n, None)
    return heuristic_result(run, None)


def _seeds(K: int, block: bool) -> dict[int, list]:
    """The first levels: one module of each type and, with ``block``, the 2 x 2 blocks."""
    if K == 1:
        fronts: dict[int, list] = {1: [((0, 0),)]}
        if block:
            fronts[4] = [((0, 0), (0, 1), (1, 0), (1, 1))]
        return fronts
    fronts = {1: [(((0, 0), t),) for t in range(K)]}
    if block:
        fronts[4] = [
            tuple(sorted((((0, 0), a), ((1, 1), a), ((0, 1), b), ((1, 0), b))))
            for a in range(K)
            for b in range(K)
        ]
    return fronts


def _grow_level(fronts: dict[int, list], n: int, K: int, deadline: Deadline) -> list | None:
    """Level n + 2 (its seeds first, then level n grown, first copies kept), or None at the
    deadline; ValueError when it would not fit :data:`MEMORY_BUDGET`."""
    typed = K > 1
    held = sum(len(v) * key_bytes(m, typed) for m, v in fronts.items() if m != n + 2)
    per = key_bytes(n + 2, typed)
    cap = max(0, (MEMORY_BUDGET - held) // per)
    level = fronts[n]
    if GROWTH * len(level) > cap:
        _refuse(n + 2, int(GROWTH * len(level)), per)
    out: dict = dict.fromkeys(fronts.get(n + 2, []))
    for keys in _children(level, K):
        if deadline.passed():
            return None
        out.update(dict.fromkeys(keys))
        if len(out) > cap:
            _refuse(n + 2, len(out), per)
    return list(out)


def _refuse(n: int, count: int, per: int) -> None:
    raise ValueError(
        f"the centrosymmetric search found nothing below {n} modules and its level of {n} "
        f"modules would hold over {count:,} structures (about {count * per / 2**30:.1f} GiB, "
        f"beyond its {MEMORY_BUDGET / 2**30:.3g} GiB budget): lower n_max to {n - 1} or less, "
        "or use --method anytime, beam or genetic"
    )


def _children(level: Iterable[tuple], K: int) -> Iterator[list]:
    """Per structure of the level, its grown keys in order (one type: cell keys; several
    types: typed keys, each added pair taking each type in turn)."""
    for key in level:
        if K == 1:
            yield [normalise(key + (cell, sym)) for cell, sym in _symmetric_pairs(key)]
            continue
        out = []
        for cell, sym in _symmetric_pairs(tuple(c for c, _ in key)):
            for t in range(K):
                grown = key + ((cell, t), (sym, t))
                out.append(normalise_typed((c for c, _ in grown), (u for _, u in grown)))
        yield out


def _symmetric_pairs(cells: Key) -> Iterator[tuple[Cell, Cell]]:
    """Each attachable cell s of ``cells`` with the cell s_sym centrosymmetric to s about their
    centre, when s_sym is also attachable (and not s itself)."""
    s = Structure.from_trusted(cells)
    taken = set(cells)
    for cell in free_neighbours(cells):
        sym = s.centrosymmetric_partner(cell)
        if sym is not None and sym != cell and sym not in taken:
            yield cell, sym
