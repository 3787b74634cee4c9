"""The paper's centrosymmetric heuristic (Sec. V-B) and two seeded baselines.

* :func:`centrosymmetric_search` (Algorithm 2 with errata 3 fixed): each level grows every
  structure of the previous level by a module and its centrosymmetric partner.
* :func:`greedy_search`: attach the module that most increases the satisfied share.
* :func:`random_search`: attach modules at random free cells.

Each reports the exact lower bound the force (or count) and level bounds prove
(:func:`.bounds.bound_levels`), so an answer is certified when it meets it; each returns at once
when the exact force bound proves the task impossible up to ``n_max``. With ``modules=[...]``
each also chooses module types: the centrosymmetric partner gets the same type (so the centre
of mass stays put), greedy tries every (cell, type) child, random draws a type with each cell.
With one type and a ``total`` task each runs exactly as before.
"""

from __future__ import annotations

from collections.abc import Iterable, Iterator, Sequence

import numpy as np

from modquad_gym.core.validation import check_int
from modquad_gym.geometry.module import ModuleType
from modquad_gym.geometry.structure import (
    Cell,
    Key,
    Structure,
    free_neighbours,
    normalise,
    normalise_typed,
)
from modquad_gym.oracle import Zonotope, margin
from modquad_gym.search.bounds import (
    NO_SIZE,
    bound_levels,
    first_possible_level,
    force_lower_bound,
)
from modquad_gym.search.problem import SearchProblem
from modquad_gym.search.result import SearchResult, SearchRun

MAX_MODULES = 64
"""Module limit of the constructive baselines (each step decides O(n) children of 4n rotors)."""

MAX_CENTROSYMMETRIC_MODULES = 21
"""Module limit of the centrosymmetric search: its levels grow about 3.9 times per two modules
(249,283 structures at 21 modules, about 3.7 million at 25), and each level is held in memory."""


def _impossible(run: SearchRun, limit: int) -> SearchResult | None:
    """The result at once when the force bound rules out every size up to n_max."""
    p = run.problem
    none_left = p.n_max + 1
    if p.homogeneous_total:
        n_lb = force_lower_bound(p.wrenches, p.module, p.f_max)
        if n_lb == NO_SIZE:
            proof = "force bound: no number of modules can exert the task's forces"
            return run.finish(None, none_left, proof=proof)
        if n_lb > p.n_max:
            return run.finish(None, none_left, proof=f"force bound: needs at least {n_lb} modules")
    else:
        n_lb, proof = first_possible_level(p)
        if proof:
            return run.finish(None, none_left, proof=proof)
    run.check_budget(limit, n_lb)
    return None


def _done(run: SearchRun, structure: Structure | None) -> SearchResult:
    """The result of a heuristic with the lower bound the exact bounds prove."""
    bound = bound_levels(run.problem)
    proof = ""
    if structure is None and bound > run.problem.n_max:
        proof = f"exact bounds rule out every level up to {run.problem.n_max}"
    return run.finish(structure, bound, proof=proof)


def _typed(run: SearchRun, cells: Iterable[Cell], types: Iterable[int]) -> Structure:
    palette = run.problem.palette
    return Structure.from_trusted(tuple(cells), modules=tuple(palette[t] for t in types))


def centrosymmetric_search(
    task,
    n_max: int = 7,
    f_max: float | None = None,
    module: ModuleType | None = None,
    block_seed: bool = False,
    *,
    modules: Sequence[ModuleType] | None = None,
    kind: str | None = None,
) -> SearchResult:
    """Paper Algorithm 2: grow structures by a module *and* its centrosymmetric partner about
    the COM, so the COM never moves and every structure is torque-balanced by symmetry.

    Seeds: one module (odd counts 1, 3, 5, ...) and, with ``block_seed=True``, also a 2 x 2
    block (even counts 4, 6, ...). Levels are visited by increasing module count and the first
    feasible structure is returned; it is minimal among centrosymmetric structures reachable
    this way, not certified minimal overall. With ``modules`` every seed type and every type
    of each added pair is tried (a pair shares one type, diagonal pairs of the block too).
    """
    problem = SearchProblem.build(task, n_max, f_max, module, modules=modules, kind=kind)
    run = SearchRun("centrosymmetric", problem)
    if (done := _impossible(run, MAX_CENTROSYMMETRIC_MODULES)) is not None:
        return done
    K = len(problem.palette)
    if K == 1:
        fronts: dict[int, list] = {1: [((0, 0),)]}
        if block_seed and problem.n_max >= 4:
            fronts[4] = [((0, 0), (0, 1), (1, 0), (1, 1))]
    else:
        fronts = {1: [(((0, 0), t),) for t in range(K)]}
        if block_seed and problem.n_max >= 4:
            fronts[4] = [
                tuple(sorted((((0, 0), a), ((1, 1), a), ((0, 1), b), ((1, 0), b))))
                for a in range(K)
                for b in range(K)
            ]
    for n in range(1, problem.n_max + 1):
        level = fronts.get(n, [])
        for key in level:
            if K == 1:
                s = Structure.from_trusted(key, problem.module)
            else:
                s = _typed(run, (c for c, _ in key), (t for _, t in key))
            if run.checker.check(s):
                return _done(run, s)
        if level and n + 2 <= problem.n_max:
            grow = grow_symmetric(level) if K == 1 else grow_symmetric_typed(level, K)
            fronts[n + 2] = list(dict.fromkeys(fronts.setdefault(n + 2, []) + grow))
    return _done(run, None)


def _symmetric_pairs(cells: Key) -> Iterator[tuple[Cell, Cell]]:
    """Each attachable cell s of ``cells`` with the cell s_sym centrosymmetric to s about their
    centre, when s_sym is also attachable (and not s itself)."""
    s = Structure.from_trusted(cells)
    taken = set(cells)
    for cell in free_neighbours(cells):
        sym = s.centrosymmetric_partner(cell)
        if sym is not None and sym != cell and sym not in taken:
            yield cell, sym


def grow_symmetric(level: Iterable[Key]) -> list[Key]:
    """Errata 3 fixed: every structure of the level, grown by each attachable cell s together
    with the cell s_sym centrosymmetric to s about the COM (when s_sym is also attachable)."""
    out: dict[Key, None] = {}
    for key in level:
        for cell, sym in _symmetric_pairs(key):
            out.setdefault(normalise(key + (cell, sym)), None)
    return list(out)


def grow_symmetric_typed(level: Iterable[tuple], n_types: int) -> list[tuple]:
    """:func:`grow_symmetric` for typed keys (``((x, y), type index)`` pairs, sorted): each
    pair of added cells takes each type in turn. Partners of equal type weigh the same, so the
    mass-weighted COM is the geometric centre the partners are taken about."""
    out: dict[tuple, None] = {}
    for key in level:
        for cell, sym in _symmetric_pairs(tuple(c for c, _ in key)):
            for t in range(n_types):
                grown = key + ((cell, t), (sym, t))
                typed = normalise_typed((c for c, _ in grown), (u for _, u in grown))
                out.setdefault(typed, None)
    return list(out)


def greedy_search(
    task,
    n_max: int = 7,
    f_max: float | None = None,
    module: ModuleType | None = None,
    *,
    modules: Sequence[ModuleType] | None = None,
    kind: str | None = None,
) -> SearchResult:
    """Baseline: from one module, repeatedly attach the module that most increases the fraction
    of satisfied wrenches, ties broken by the larger total margin (sum of exact margins clipped
    to [-1, 1]), then by cell order. Stops at the first feasible structure or at ``n_max``.

    Children that are the same structure up to translation are evaluated and counted once, at
    their first cell in sorted order; equal structures score equally, so results are unchanged.
    With ``modules`` the first module is the best-scoring type and every child is a (cell,
    type) pair (ties by cell order, then palette order)."""
    problem = SearchProblem.build(task, n_max, f_max, module, modules=modules, kind=kind)
    run = SearchRun("greedy", problem)
    if (done := _impossible(run, MAX_MODULES)) is not None:
        return done
    f, checker, palette = problem.f_max, run.checker, problem.palette

    def score(s: Structure) -> tuple[bool, tuple[float, float]]:
        W = problem.rotor_wrenches(s)
        z = Zonotope(s.configuration_matrix(), f)
        checker.evaluated += 1
        checker.oracle_calls += len(W)
        ok = z.decide_certified(W)
        if ok.all():
            return True, (1.0, 0.0)
        total = float(np.clip(margin(z.A, W, f, method="daqp"), -1.0, 1.0).sum())
        return False, (float(ok.mean()), total)

    if len(palette) == 1:
        current = Structure([(0, 0)], problem.module)
        checker.evaluated += 1
        W = problem.rotor_wrenches(current)
        checker.oracle_calls += len(W)
        if Zonotope(current.configuration_matrix(), f).decide_certified(W).all():
            return _done(run, current)
    else:
        current, best_score = None, None
        for m in palette:
            s = Structure([(0, 0)], module=m)
            done, sc = score(s)
            if done:
                return _done(run, s)
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
                seen.add(child)
                done, sc = score(child)
                if done:
                    return _done(run, child)
                if best_score is None or sc > best_score:
                    best, best_score = child, sc
        current = best
    return _done(run, None)


def random_search(
    task,
    n_max: int = 7,
    f_max: float | None = None,
    module: ModuleType | None = None,
    seed: int | None = 0,
    restarts: int = 1,
    *,
    modules: Sequence[ModuleType] | None = None,
    kind: str | None = None,
) -> SearchResult:
    """Baseline: attach modules at uniformly random free cells until the task is satisfied or
    ``n_max`` is reached, ``restarts`` times; returns the smallest feasible structure seen.
    With several ``modules`` each module's type is drawn uniformly too."""
    problem = SearchProblem.build(task, n_max, f_max, module, modules=modules, kind=kind)
    run = SearchRun("random", problem)
    if (done := _impossible(run, MAX_MODULES)) is not None:
        return done
    rng = np.random.default_rng(None if seed is None else check_int(seed, "seed", low=0))
    K = len(problem.palette)
    best: Structure | None = None
    for _ in range(max(1, int(restarts))):
        cells: list[Cell] = [(0, 0)]
        types: list[int] = [int(rng.integers(K))] if K > 1 else [0]
        while True:
            if K > 1:
                s = _typed(run, cells, types)
            else:
                s = Structure.from_trusted(tuple(cells), problem.module)
            if best is not None and s.n_modules >= best.n_modules:
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
    return _done(run, best)
