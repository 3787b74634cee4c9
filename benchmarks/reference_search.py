"""The exhaustive search as it was before the streaming engine, kept frozen as the plain
reference the fast search (:mod:`modquad_gym.search`) is cross-checked against
(``tests/test_search_scale.py``) and timed against (``python -m benchmarks.scaling``).

:func:`exhaustive_search` (paper Sec. V-A) walks every connected structure up to translation,
level by level, and returns the first feasible one of the first level holding one: the
certified minimum. :func:`optimal_structures` decides the whole minimal level. Levels below the
exact force bound are skipped as a whole (reported in ``skipped_levels``).

What is the reference, and stays frozen here: the enumeration (each level materialised in
memory by docking one module to every structure of the previous level, :func:`grow`, against
the fast search's streamed canonical polyomino order) and the task checker (separating
directions cached in a small pool and tested in numpy on configuration matrices, against the
fast checker's compiled support tests from cells, its larger pool and its typed and external
cases). A change to either of the fast parts that rejects a feasible structure or skips one
shows as a different minimum or a different optimal set; sharing them would hide it. The
checker's certified step (:meth:`_TaskChecker._check_matrix` and ``_learn``) reads like the
fast one's on purpose: it is the code the fast checker started from, kept as it was.

Imported, not copied, because they are not the search: the result record
(:class:`~modquad_gym.search.SearchResult`), reading the task
(:func:`task_arrays`), and the force bound
(:func:`~modquad_gym.search.force_lower_bound`, checked on its own in ``tests/test_search.py``:
no structure below it is feasible). Every returned structure is re-verified by the exact DAQP LP.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Iterable

import numpy as np

from modquad_gym.core.validation import check_f_max, check_int
from modquad_gym.geometry.module import ModuleType
from modquad_gym.geometry.structure import (
    Key,
    Structure,
    configuration_matrices,
    free_neighbours,
    normalise,
)
from modquad_gym.oracle import TOL, Zonotope, feasible
from modquad_gym.search.bounds import force_lower_bound
from modquad_gym.search.problem import DEFAULT_MODULE
from modquad_gym.search.result import SearchResult
from modquad_gym.tasks import as_task

_POOL_SIZE = 48


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
    :func:`~modquad_gym.geometry.structure.structure_levels`. Levels are built lazily, one at a time
    from the previous one, and cached for the whole process: a search that stops at level n
    never builds level n + 1 (level 11 alone holds 135,268 structures)."""
    if n < 1:
        raise ValueError(f"a level needs at least one module, got {n!r}")
    if n > len(_LEVELS):
        with _LEVELS_LOCK:
            while len(_LEVELS) < n:
                _LEVELS.append(tuple(grow(_LEVELS[-1])))
    return _LEVELS[n - 1]


def task_arrays(task, f_max):
    """(W, f_max) of a search's task argument (the product's ``as_task``)."""
    task = as_task(task)
    return task.wrenches, task.f_max if f_max is None else check_f_max(f_max)


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


def _result(structure, checker, t0, n_max, W, f_max, skipped=()) -> SearchResult:
    """The exhaustive search's result, its structure re-verified by the exact DAQP LP."""
    if structure is not None:
        A = structure.configuration_matrix()
        if not feasible(A, W, f_max, method="daqp").all():
            raise RuntimeError(  # pragma: no cover - an oracle bug, never a silent success
                f"exhaustive search found {structure!r} but the exact LP rejects it"
            )
    return SearchResult(
        structure=structure,
        n_modules=structure.n_modules if structure is not None else None,
        evaluated=checker.evaluated,
        oracle_calls=checker.oracle_calls,
        seconds=time.perf_counter() - t0,
        certified=True,
        method="exhaustive",
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
    W, f = task_arrays(task, f_max)
    n_max = check_int(n_max, "n_max", low=1)
    module = module or DEFAULT_MODULE
    checker = _TaskChecker(W, f, module)
    n_lb = force_lower_bound(W, module, f)
    skipped = list(range(1, min(n_lb, n_max + 1)))
    for n in range(n_lb, n_max + 1):  # empty when the force bound exceeds n_max
        key = checker.first_feasible(list(_level(n)))  # built only when reached
        if key is not None:
            s = Structure.from_trusted(key, module)
            return _result(s, checker, t0, n_max, W, f, skipped)
    return _result(None, checker, t0, n_max, W, f, skipped)


def optimal_structures(
    task, n_max: int = 7, f_max: float | None = None, module: ModuleType | None = None
) -> tuple[int | None, list[Key]]:
    """Every minimum-module structure of ``task``: (n*, keys of all feasible structures of n*
    modules, up to translation), or (None, []) when none of up to ``n_max`` modules works.

    Certified like :func:`exhaustive_search`, which stops at the first feasible structure;
    this one decides the whole minimal level (the expert targets of
    :mod:`agents.imitation`).
    """
    W, f = task_arrays(task, f_max)
    n_max = check_int(n_max, "n_max", low=1)
    module = module or DEFAULT_MODULE
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


if __name__ == "__main__":
    from benchmarks.common import refuse_as_script

    raise SystemExit(refuse_as_script("reference_search"))
