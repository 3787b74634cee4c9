"""The exhaustive search as it was before the streaming engine (levels materialised from
the previous one), kept as the reference the new searches are compared against.

Searches for the smallest structure whose feasible wrenches contain a task (paper Sec. V).

* :func:`exhaustive_search` (Sec. V-A): every connected structure up to translation, level by
  level; the first level holding a feasible structure is the certified minimum. Nothing is
  pruned except by exact bounds (below).
* :func:`centrosymmetric_search` (Sec. V-B, Algorithm 2 with errata 3 fixed): each level grows
  every structure of the previous level by a module and its centrosymmetric partner.
* :func:`greedy_search` and :func:`random_search`: simple seeded baselines.

Every returned structure is re-verified by the exact DAQP LP oracle, independently of the path
that found it. Counts follow the paper: ``evaluated`` is the number of configurations whose
feasibility against the task was decided; ``oracle_calls`` the number of wrench-structure tests
(a rejection by a cached separating direction counts as one).

Exact pruning in the exhaustive search:
* a *force bound*: the force part of W for n modules is exactly n times the force zonotope of
  one module (forces do not depend on where modules sit), so a wrench whose force lies outside
  n * Z_F(module) rules out every structure of n modules. Levels below the smallest n that
  contains every task force are skipped as a whole (reported in ``skipped_levels``).
* *cached separating directions*: a direction d that separated a task wrench w from an earlier
  structure (d . w > h_S(d)) is tried first on every later structure S'; if d . w > h_S'(d)
  the structure is rejected with that certificate. Exact, not a heuristic.
"""

from __future__ import annotations

import math
import threading
import time
from collections.abc import Iterable
from dataclasses import dataclass, field

import numpy as np

from modquad_gym.module import ModuleType
from modquad_gym.oracle import TOL, Zonotope, check_f_max, check_wrenches
from modquad_gym.structure import (
    Cell,
    Key,
    Structure,
    configuration_matrices,
    free_neighbours,
    normalise,
)

_DEFAULT_MODULE = Structure([(0, 0)]).module
_POOL_SIZE = 48


@dataclass
class SearchResult:
    """What a search found.

    Attributes:
        structure: the structure found (verified feasible), or None.
        n_modules: its module count, or None.
        evaluated: configurations evaluated (feasibility against the whole task decided).
        oracle_calls: wrench-structure membership tests made.
        seconds: wall time.
        certified: True when ``n_modules`` is proven minimal (exhaustive search), or when the
            search proved that no structure up to ``n_max`` modules is feasible.
        method: the search's name.
        n_max: the module budget searched.
        skipped_levels: module counts ruled out as a whole by the exact force bound.
    """

    structure: Structure | None
    n_modules: int | None
    evaluated: int
    oracle_calls: int
    seconds: float
    certified: bool
    method: str
    n_max: int
    skipped_levels: list[int] = field(default_factory=list)

    @property
    def feasible(self) -> bool:
        return self.structure is not None

    def to_dict(self) -> dict:
        return {
            "cells": [list(c) for c in self.structure.cells] if self.structure else None,
            "n_modules": self.n_modules,
            "evaluated": self.evaluated,
            "oracle_calls": self.oracle_calls,
            "feasible": self.feasible,
            "certified": self.certified,
            "seconds": self.seconds,
            "method": self.method,
            "n_max": self.n_max,
        }


def _task_arrays(task, f_max: float | None) -> tuple[np.ndarray, float]:
    """Accept a (t, 6) array or anything with ``wrenches`` (and ``f_max``) attributes."""
    if hasattr(task, "wrenches"):
        W = check_wrenches(task.wrenches)
        f = f_max if f_max is not None else getattr(task, "f_max", 1.0)
    else:
        W = check_wrenches(task)
        f = 1.0 if f_max is None else f_max
    return W, check_f_max(f)


def _check_n_max(n_max: int) -> int:
    if not isinstance(n_max, (int, np.integer)) or n_max < 1:
        raise ValueError(f"n_max must be a positive integer, got {n_max!r}")
    return int(n_max)


def force_lower_bound(W: np.ndarray, module: ModuleType, f_max: float = 1.0) -> int:
    """Smallest n such that every task force lies in n * Z_F, with Z_F the force zonotope of
    one module {sum_j u_j d_j : 0 <= u_j <= f_max}. Exact: no structure of fewer modules can
    exert the task's forces, whatever its shape. Returns a huge number if no n works."""
    dirs = module.directions
    normals = [
        np.cross(dirs[i], dirs[j]) for i in range(len(dirs)) for j in range(i + 1, len(dirs))
    ]
    normals = [n / np.linalg.norm(n) for n in normals if np.linalg.norm(n) > 1e-12]
    normals += [np.eye(3)[k] for k in range(3)]  # harmless extra directions for degenerate types
    N = np.array(normals + [-n for n in normals])
    h1 = np.maximum(N @ dirs.T, 0.0).sum(axis=1) * f_max  # support of one module's force set
    proj = W[:, :3] @ N.T  # (t, k)
    need = np.where(
        h1 > 1e-12, proj / np.where(h1 > 1e-12, h1, 1.0), np.where(proj > 1e-12, np.inf, 0)
    )
    worst = float(need.max())
    if not math.isfinite(worst):
        return 10**9
    return max(1, math.ceil(worst - TOL))


def grow(keys: Iterable[Key]) -> list[Key]:
    """Every structure made by docking one module to one of ``keys``, deduplicated up to
    translation, in a deterministic order."""
    seen: set[Key] = set()
    out: list[Key] = []
    for key in keys:
        for cell in free_neighbours(key):
            child = normalise(key + (cell,))
            if child not in seen:
                seen.add(child)
                out.append(child)
    return out


_LEVELS: list[tuple[Key, ...]] = [(((0, 0),),)]
"""Cache of the levels built so far: ``_LEVELS[n - 1]`` holds every structure of n modules."""
_LEVELS_LOCK = threading.Lock()


def _level(n: int) -> tuple[Key, ...]:
    """Every connected structure of ``n`` modules (keys, up to translation), in the order of
    :func:`~modquad_gym.structure.structure_levels`. Levels are built lazily, one at a time
    from the previous one, and cached for the whole process: a search that stops at level n
    never builds level n + 1 (level 11 alone holds 135,268 structures)."""
    if n < 1:
        raise ValueError(f"a level needs at least one module, got {n!r}")
    if n > len(_LEVELS):
        with _LEVELS_LOCK:
            while len(_LEVELS) < n:
                _LEVELS.append(tuple(grow(_LEVELS[-1])))
    return _LEVELS[n - 1]


def _levels(n_max: int) -> tuple[tuple[Key, ...], ...]:
    """Levels 1..n_max, all built now (from the cache of :func:`_level`). Searches that may
    stop early should call :func:`_level` level by level instead."""
    return tuple(_level(n) for n in range(1, n_max + 1))


class _TaskChecker:
    """Decides whole tasks against structures, sharing separating directions between them."""

    def __init__(self, W: np.ndarray, f_max: float, module: ModuleType) -> None:
        self.W = W
        self.f_max = f_max
        self.module = module
        self.evaluated = 0
        self.oracle_calls = 0
        # hardest wrenches first: by decreasing Euclidean norm of the whole 6-vector (ties
        # keep the task's order), so an infeasible structure usually fails on an early batch
        self.order = np.argsort(-np.linalg.norm(W, axis=1), kind="stable")
        self.pool_d = np.zeros((0, 6))  # separating directions in wrench space
        self.pool_v = np.zeros(0)  # max_i d . w_i over the task, per direction

    def _remember(self, d6: np.ndarray) -> None:
        d6 = d6 / np.linalg.norm(d6)
        self.pool_d = np.vstack([d6[None], self.pool_d])[:_POOL_SIZE]
        self.pool_v = (self.pool_d @ self.W.T).max(axis=1)

    def _pool_rejects(self, As: np.ndarray) -> np.ndarray:
        """bool (L,): structures (configuration matrices (L, 6, m)) that a cached separating
        direction rules out: d . w above the support of W widened by the oracle's tolerance
        (thrusts within TOL * f_max / 2 outside [0, f_max], i.e. gamma <= 1 + TOL),
        f_max * sum_j max(0, d . a_j) + TOL * f_max / 2 * sum_j |d . a_j|."""
        if not len(self.pool_d):
            return np.zeros(len(As), dtype=bool)
        P = np.einsum("pk,lkm->lpm", self.pool_d, As)
        supp = np.maximum(P, 0.0).sum(axis=2) + 0.5 * TOL * np.abs(P).sum(axis=2)
        return (self.pool_v > supp * self.f_max + 1e-12).any(axis=1)

    def first_feasible(self, keys: list[Key], chunk: int = 512) -> Key | None:
        """The first key (in order) whose structure satisfies the task, or None. Every key up
        to it is evaluated: by a cached separating direction (vectorised over a chunk) or by
        the certified oracle, whose rejections teach the pool new directions."""
        for start in range(0, len(keys), chunk):
            block = keys[start : start + chunk]
            As = configuration_matrices(block, self.module)
            alive = ~self._pool_rejects(As)
            for i in range(len(block)):
                if not alive[i]:
                    self.evaluated += 1
                    self.oracle_calls += 1
                    continue
                n_pool = len(self.pool_d)
                if self._check_matrix(As[i]):
                    return block[i]
                if len(self.pool_d) != n_pool and i + 1 < len(block):  # a new direction
                    rest = slice(i + 1, len(block))
                    alive[rest] &= ~self._pool_rejects(As[rest])
        return None

    def check(self, structure: Structure) -> bool:
        """True when the structure satisfies every task wrench (exact)."""
        A = structure.configuration_matrix()
        if self._pool_rejects(A[None])[0]:
            self.evaluated += 1
            self.oracle_calls += 1
            return False
        return self._check_matrix(A)

    def _check_matrix(self, A: np.ndarray) -> bool:
        self.evaluated += 1
        z = Zonotope(A, self.f_max)
        W = self.W[self.order]
        start = 0
        for size in (4, 16, len(W)):  # small batches first: most structures fail early
            batch = W[start:size]
            if not len(batch):
                continue
            self.oracle_calls += len(batch)
            ok = z.decide_certified(batch)
            if not ok.all():
                self._learn(z, batch[int(np.argmin(ok))])
                return False
            start = size
        return True

    def _learn(self, z: Zonotope, w: np.ndarray) -> None:
        R, off = z.reduce(w[None])
        if off[0]:  # the wrench leaves range(A): the residual direction separates it
            d6 = w - z.Q @ (z.Q.T @ w)
        else:
            gamma, d = z.separating_direction(R[0])
            if gamma <= 1.0 + TOL or not np.any(d):
                return
            d6 = z.Q @ d
        if np.linalg.norm(d6) > 0:
            self._remember(d6)


def _verified(structure: Structure, W: np.ndarray, f_max: float) -> bool:
    """Independent re-check with the exact DAQP LP on every wrench."""
    from modquad_gym.oracle import feasible

    return bool(feasible(structure.configuration_matrix(), W, f_max, method="daqp").all())


def _result(structure, checker, t0, certified, method, n_max, W, f_max, skipped=()):
    if structure is not None and not _verified(structure, W, f_max):
        raise RuntimeError(  # pragma: no cover - would be an oracle bug, never a silent success
            f"{method} search found {structure!r} but the exact LP rejects it"
        )
    return SearchResult(
        structure=structure,
        n_modules=structure.n_modules if structure is not None else None,
        evaluated=checker.evaluated,
        oracle_calls=checker.oracle_calls,
        seconds=time.perf_counter() - t0,
        certified=certified,
        method=method,
        n_max=n_max,
        skipped_levels=list(skipped),
    )


def exhaustive_search(
    task, n_max: int = 7, f_max: float | None = None, module: ModuleType | None = None
) -> SearchResult:
    """Certified minimum-module structure for ``task`` (a (t, 6) wrench array or a
    TaskRequirement), searching every connected structure of up to ``n_max`` modules.

    ``certified`` is always True: either the structure is minimal, or no structure of up to
    ``n_max`` modules can satisfy the task.
    """
    t0 = time.perf_counter()
    W, f = _task_arrays(task, f_max)
    n_max = _check_n_max(n_max)
    module = module or _DEFAULT_MODULE
    checker = _TaskChecker(W, f, module)
    n_lb = force_lower_bound(W, module, f)
    skipped = list(range(1, min(n_lb, n_max + 1)))
    for n in range(n_lb, n_max + 1):  # empty when the force bound exceeds n_max
        key = checker.first_feasible(list(_level(n)))  # built only when reached
        if key is not None:
            s = Structure.from_trusted(key, module)
            return _result(s, checker, t0, True, "exhaustive", n_max, W, f, skipped)
    return _result(None, checker, t0, True, "exhaustive", n_max, W, f, skipped)


def optimal_structures(
    task, n_max: int = 7, f_max: float | None = None, module: ModuleType | None = None
) -> tuple[int | None, list[Key]]:
    """Every minimum-module structure of ``task``: (n*, keys of all feasible structures of n*
    modules, up to translation), or (None, []) when none of up to ``n_max`` modules works.

    Certified like :func:`exhaustive_search`, which stops at the first feasible structure;
    this one decides the whole minimal level (the expert targets of
    :mod:`modquad_gym.agents.imitation`).
    """
    W, f = _task_arrays(task, f_max)
    n_max = _check_n_max(n_max)
    module = module or _DEFAULT_MODULE
    checker = _TaskChecker(W, f, module)
    n_lb = force_lower_bound(W, module, f)
    for n in range(n_lb, n_max + 1):
        found: list[Key] = []
        rest = list(_level(n))
        while rest:
            key = checker.first_feasible(rest)
            if key is None:
                break
            found.append(key)
            rest = rest[rest.index(key) + 1 :]
        if found:
            return n, found
    return None, []


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
    t0 = time.perf_counter()
    W, f = _task_arrays(task, f_max)
    n_max = _check_n_max(n_max)
    module = module or _DEFAULT_MODULE
    checker = _TaskChecker(W, f, module)
    fronts: dict[int, list[Key]] = {1: [((0, 0),)]}
    if block_seed and n_max >= 4:
        fronts[4] = [((0, 0), (0, 1), (1, 0), (1, 1))]
    for n in range(1, n_max + 1):
        level = fronts.get(n, [])
        for key in level:
            if checker.check(Structure.from_trusted(key, module)):
                return _result(
                    Structure.from_trusted(key, module),
                    checker,
                    t0,
                    False,
                    "centrosymmetric",
                    n_max,
                    W,
                    f,
                )
        if level and n + 2 <= n_max:
            fronts.setdefault(n + 2, []).extend(_grow_symmetric(level))
            fronts[n + 2] = list(dict.fromkeys(fronts[n + 2]))
    return _result(None, checker, t0, False, "centrosymmetric", n_max, W, f)


def _grow_symmetric(level: Iterable[Key]) -> list[Key]:
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

    Children that are the same structure up to translation (from one module, cells (1, 0) and
    (-1, 0) both give the horizontal pair) are evaluated and counted once, at their first cell
    in sorted order; since equal structures score equally, this changes counts, not results."""
    from modquad_gym.oracle import margin_with

    t0 = time.perf_counter()
    W, f = _task_arrays(task, f_max)
    n_max = _check_n_max(n_max)
    module = module or _DEFAULT_MODULE
    checker = _TaskChecker(W, f, module)
    current = Structure([(0, 0)], module)
    checker.evaluated += 1
    checker.oracle_calls += len(W)
    if Zonotope(current.configuration_matrix(), f).decide_certified(W).all():
        return _result(current, checker, t0, False, "greedy", n_max, W, f)
    while current.n_modules < n_max:
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
                return _result(child, checker, t0, False, "greedy", n_max, W, f)
            score = (float(ok.mean()), float(np.clip(margin_with(z, W, "daqp"), -1.0, 1.0).sum()))
            if best_score is None or score > best_score:
                best, best_score = child, score
        current = best
    return _result(None, checker, t0, False, "greedy", n_max, W, f)


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
    t0 = time.perf_counter()
    W, f = _task_arrays(task, f_max)
    n_max = _check_n_max(n_max)
    module = module or _DEFAULT_MODULE
    rng = np.random.default_rng(seed)
    checker = _TaskChecker(W, f, module)
    best: Structure | None = None
    for _ in range(max(1, int(restarts))):
        cells: list[Cell] = [(0, 0)]
        while True:
            s = Structure.from_trusted(tuple(cells), module)
            if best is not None and s.n_modules >= best.n_modules:
                break
            if checker.check(s):
                best = s
                break
            if s.n_modules >= n_max:
                break
            options = free_neighbours(cells)
            cells.append(options[int(rng.integers(len(options)))])
    if best is not None:
        best = Structure(best.cells, module)
    return _result(best, checker, t0, False, "random", n_max, W, f)


SEARCHES = {
    "exhaustive": exhaustive_search,
    "centrosymmetric": centrosymmetric_search,
    "greedy": greedy_search,
    "random": random_search,
}
"""The searches by name (the CLI's ``--method``)."""
