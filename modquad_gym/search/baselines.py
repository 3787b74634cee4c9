"""The paper's centrosymmetric heuristic (Sec. V-B) and two seeded baselines.

* :func:`centrosymmetric_search` (Algorithm 2 with errata 3 fixed): each level grows every
  structure of the previous level by a module and its centrosymmetric partner.
* :func:`greedy_search`: attach the module that most increases the satisfied share.
* :func:`random_search`: attach modules at random free cells.

None is certified minimal; each returns at once when the exact force bound proves the task
impossible up to ``n_max``.
"""

from __future__ import annotations

from collections.abc import Iterable

import numpy as np

from ..module import ModuleType
from ..oracle import Zonotope, margin
from ..structure import Cell, Key, Structure, free_neighbours, normalise
from .bounds import NO_SIZE, force_lower_bound
from .result import SearchResult, SearchRun

MAX_MODULES = 64
"""Module limit of the constructive baselines (each step decides O(n) children of 4n rotors)."""

MAX_CENTROSYMMETRIC_MODULES = 21
"""Module limit of the centrosymmetric search: its levels grow about 3.9 times per two modules
(249,283 structures at 21 modules, about 3.7 million at 25), and each level is held in memory."""


def _impossible(run: SearchRun) -> SearchResult | None:
    """The result at once when the force bound rules out every size up to n_max."""
    n_lb = force_lower_bound(run.W, run.module, run.f_max)
    if n_lb == NO_SIZE:
        proof = "force bound: no number of modules can exert the task's forces"
        return run.finish(None, False, proof=proof)
    if n_lb > run.n_max:
        return run.finish(None, False, proof=f"force bound: needs at least {n_lb} modules")
    run.check_budget(n_lb)
    return None


def centrosymmetric_search(
    task,
    n_max: int = 7,
    f_max: float | None = None,
    module: ModuleType | None = None,
    block_seed: bool = False,
) -> SearchResult:
    """Paper Algorithm 2: grow structures by a module *and* its centrosymmetric partner about
    the COM, so the COM never moves and every structure is torque-balanced by symmetry.

    Seeds: one module (odd counts 1, 3, 5, ...) and, with ``block_seed=True``, also a 2 x 2
    block (even counts 4, 6, ...). Levels are visited by increasing module count and the first
    feasible structure is returned; it is minimal among centrosymmetric structures reachable
    this way, not certified minimal overall.
    """
    run = SearchRun("centrosymmetric", task, n_max, f_max, module, MAX_CENTROSYMMETRIC_MODULES)
    if (done := _impossible(run)) is not None:
        return done
    fronts: dict[int, list[Key]] = {1: [((0, 0),)]}
    if block_seed and run.n_max >= 4:
        fronts[4] = [((0, 0), (0, 1), (1, 0), (1, 1))]
    for n in range(1, run.n_max + 1):
        level = fronts.get(n, [])
        for key in level:
            s = Structure.from_trusted(key, run.module)
            if run.checker.check(s):
                return run.finish(s, False)
        if level and n + 2 <= run.n_max:
            grown = fronts.setdefault(n + 2, []) + grow_symmetric(level)
            fronts[n + 2] = list(dict.fromkeys(grown))
    return run.finish(None, False)


def grow_symmetric(level: Iterable[Key]) -> list[Key]:
    """Errata 3 fixed: every structure of the level, grown by each attachable cell s together
    with the cell s_sym centrosymmetric to s about the COM (when s_sym is also attachable)."""
    out: dict[Key, None] = {}
    for key in level:
        s = Structure.from_trusted(key)
        cells = set(key)
        for cell in free_neighbours(key):
            sym = s.centrosymmetric_partner(cell)
            if sym is None or sym == cell or sym in cells:
                continue
            out.setdefault(normalise(key + (cell, sym)), None)
    return list(out)


def greedy_search(
    task, n_max: int = 7, f_max: float | None = None, module: ModuleType | None = None
) -> SearchResult:
    """Baseline: from one module, repeatedly attach the module that most increases the fraction
    of satisfied wrenches, ties broken by the larger total margin (sum of exact margins clipped
    to [-1, 1]), then by cell order. Stops at the first feasible structure or at ``n_max``.

    Children that are the same structure up to translation are evaluated and counted once, at
    their first cell in sorted order; equal structures score equally, so results are unchanged."""
    run = SearchRun("greedy", task, n_max, f_max, module, MAX_MODULES)
    if (done := _impossible(run)) is not None:
        return done
    W, f, checker = run.W, run.f_max, run.checker
    current = Structure([(0, 0)], run.module)
    checker.evaluated += 1
    checker.oracle_calls += len(W)
    if Zonotope(current.configuration_matrix(), f).decide_certified(W).all():
        return run.finish(current, False)
    while current.n_modules < run.n_max:
        best, best_score = None, None
        seen: set[Key] = set()
        for cell in current.attachable_cells():  # sorted: ties go to the first cell
            child = current.with_cells(cell)
            if child.key in seen:  # the same structure up to translation: already scored
                continue
            seen.add(child.key)
            z = Zonotope(child.configuration_matrix(), f)
            checker.evaluated += 1
            checker.oracle_calls += len(W)
            ok = z.decide_certified(W)
            if ok.all():
                return run.finish(child, False)
            total = float(np.clip(margin(z.A, W, f, method="daqp"), -1.0, 1.0).sum())
            score = (float(ok.mean()), total)
            if best_score is None or score > best_score:
                best, best_score = child, score
        current = best
    return run.finish(None, False)


def random_search(
    task,
    n_max: int = 7,
    f_max: float | None = None,
    module: ModuleType | None = None,
    seed: int | None = 0,
    restarts: int = 1,
) -> SearchResult:
    """Baseline: attach modules at uniformly random free cells until the task is satisfied or
    ``n_max`` is reached, ``restarts`` times; returns the smallest feasible structure seen."""
    run = SearchRun("random", task, n_max, f_max, module, MAX_MODULES)
    if (done := _impossible(run)) is not None:
        return done
    rng = np.random.default_rng(seed)
    best: Structure | None = None
    for _ in range(max(1, int(restarts))):
        cells: list[Cell] = [(0, 0)]
        while True:
            s = Structure.from_trusted(tuple(cells), run.module)
            if best is not None and s.n_modules >= best.n_modules:
                break
            if run.checker.check(s):
                best = s
                break
            if s.n_modules >= run.n_max:
                break
            options = free_neighbours(cells)
            cells.append(options[int(rng.integers(len(options)))])
    if best is not None:
        best = Structure(best.cells, run.module)
    return run.finish(best, False)
