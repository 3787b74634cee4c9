"""Deciding the current structure against the episode's task, with the caches that make it fast.

A :class:`StructureEvaluator` depends on (module types, n_max, f_max, K) only and survives across
episodes: the exact oracle with its per-structure zonotope cache, the feature maker, and per
structure its configuration matrix, support values and task-independent features. Per task,
:class:`TaskMemos` keeps what was decided (a task that comes back costs no oracle call for the
structures seen before).

Each step's decisions are one call of :meth:`~modquad_gym.oracle.WrenchOracle.screened`: the
structure's support values screen the wrenches, the oracle decides the rest (with the default
method ``"auto"``, both in one compiled call).

A dynamic task (:mod:`.dynamic`) is decided the same way, each structure on its own rotor
wrenches (:meth:`StructureEvaluator.task_of`).

With a ``fault`` (``"rotor"`` or ``"module"``) a wrench counts as satisfied only when the
structure still exerts it after any single failure of that kind
(:class:`~modquad_gym.oracle.faults.FaultTolerance`, kept per structure); the screened call
still gives the features.

Structures of more than :data:`COMPILED_FROM` - 1 modules (beyond the grid env's old reach) build
their configuration matrix in one compiled call, the same matrix as
:meth:`~modquad_gym.geometry.structure.Structure.configuration_matrix` up to round-off; smaller
ones through it (so recorded episodes replay bit for bit).

Why not :class:`~modquad_gym.search.checker.TaskChecker`: the searches decide thousands of
structures per task in compiled batches and need only a yes/no; the env decides one structure
per step and needs the count of satisfied wrenches and the features, from the same exact oracle.
"""

from __future__ import annotations

from itertools import chain
from typing import Any

import numpy as np

from modquad_gym.core.jit import njit
from modquad_gym.envs.assembly.dynamic import own_arrays, start_arrays
from modquad_gym.envs.assembly.features import AssemblyFeatures
from modquad_gym.envs.assembly.types import TaskArrays
from modquad_gym.geometry.module import ModuleType
from modquad_gym.geometry.structure import (
    Key,
    Structure,
    configuration_matrices,
    mixed_configuration_matrices,
)
from modquad_gym.oracle import WrenchOracle, feasible
from modquad_gym.oracle.faults import FaultTolerance, failure_sets

CACHE_SIZE = 16384
"""Entries per cache before it is cleared (there are 1,067 structures of at most 7 modules)."""
CACHED_COLUMNS = 2**17
"""Configuration-matrix columns the per-structure caches (matrices, prepared zonotopes, fault
tolerance) hold at most, counted at n_max modules a structure: every structure up to 7 modules
fits, and at 128 modules (512 columns, ~150 kB a structure) 256 structures (~40 MB), not 16,384
(GBs): a single pass needs the few of each step."""
CACHED_CELLS = 2**18
"""Module cells the support cache's keys hold at most, counted at n_max modules a key (a key of
128 cells takes ~8 kB: 16,384 of them took 130 MB): 16,384 keys up to 16 modules, 2,048 at 128."""
MEMO_TASKS = 16
"""Tasks whose decisions are remembered."""
COMPILED_FROM = 17
"""Structures of at least this many modules build their matrix with :func:`_matrix`."""


@njit(cache=True)
def _matrix(cells, types, cols, masses, side):  # pragma: no cover - compiled
    """The configuration matrix (6, n r) of modules at grid ``cells`` (n, 2) of palette
    ``types`` (n,) with columns ``cols`` (K, 6, r) about their own centres and ``masses`` (K,):
    each module's columns plus c x d for its centre c from the (mass-weighted) centre of mass,
    as :func:`~modquad_gym.geometry.structure.configuration_matrices` computes them."""
    n, r = cells.shape[0], cols.shape[2]
    total = cx0 = cy0 = 0.0
    for i in range(n):
        w = masses[types[i]]
        total += w
        cx0 += w * cells[i, 0]
        cy0 += w * cells[i, 1]
    cx0 /= total
    cy0 /= total
    A = np.empty((6, n * r))
    for i in range(n):
        t = types[i]
        cx = (cells[i, 0] - cx0) * side
        cy = (cells[i, 1] - cy0) * side
        for j in range(r):
            k = i * r + j
            dx, dy, dz = cols[t, 0, j], cols[t, 1, j], cols[t, 2, j]
            A[0, k], A[1, k], A[2, k] = dx, dy, dz
            A[3, k] = cols[t, 3, j] + cy * dz
            A[4, k] = cols[t, 4, j] - cx * dz
            A[5, k] = cols[t, 5, j] + cx * dy - cy * dx
    return A


class Capability:
    """What is kept per structure (translation key), for any task: its configuration matrix,
    support values (:meth:`AssemblyFeatures.support`), rank and the task-independent part of its
    structure vector (:meth:`AssemblyFeatures.structure_head`)."""

    __slots__ = ("A", "h_Wn", "slack", "rank", "head")

    def __init__(
        self, A: np.ndarray, rank: int, n_modules: int, features: AssemblyFeatures
    ) -> None:
        self.A = A
        self.rank = rank
        self.h_Wn, self.slack = features.support(A)
        self.head = features.structure_head(self.h_Wn, rank, n_modules)


class StructureEvaluator:
    """Decides structures of one module type (keys from
    :func:`modquad_gym.geometry.structure.normalise`)
    against tasks, for one (n_max, f_max, K, oracle method).

    Attributes:
        tests: wrench-structure tests sent to the oracle so far (all episodes).
        cache_size: structures each per-structure cache holds (:data:`CACHED_COLUMNS`).
        fault: None, or the failure a satisfied wrench must survive (``"rotor"``,
            ``"module"``, ``"rotor2"``, ``"rotor+module"``); the environment sets it.
        fault_margin: the worst margin it must keep after that failure (default 0).
    """

    fault: str | None = None
    fault_margin: float = 0.0

    def __init__(
        self, module: ModuleType, n_max: int, f_max: float, n_directions: int, method: str
    ) -> None:
        self.module = module
        self.n_max = max(n_max, 1)
        self.cache_size = min(CACHE_SIZE, CACHED_COLUMNS // (module.n_rotors * max(n_max, 1)))
        self.oracle = WrenchOracle(f_max, method=method, cache_size=self.cache_size)
        self.features = AssemblyFeatures(module, n_max, f_max, n_directions)
        self.capability: dict[Key, Capability] = {}
        self.tolerance: dict[Key, FaultTolerance] = {}
        self.supports: dict[Key, tuple[np.ndarray, float]] = {}
        self.tests = 0
        self._cols = module.columns[None]  # (1, 6, r): the compiled matrix's type table
        self._masses = np.ones(1)  # one type: the plain mean of the cells

    # --- per structure ----------------------------------------------------------------------
    def structure_of(self, key: Any) -> Structure:
        """The structure of ``key``."""
        return Structure.from_trusted(key, module=self.module)

    def matrix_of(self, key: Any) -> np.ndarray:
        """The configuration matrix of the structure ``key`` (compiled for large ones)."""
        if len(key) < COMPILED_FROM:
            return self.structure_of(key).configuration_matrix()
        cells, types = self._cells_types(key)
        return _matrix(cells, types, self._cols, self._masses, self.module.side)

    def _cells_types(self, key: Any) -> tuple[np.ndarray, np.ndarray]:
        """(cells (n, 2) float, types (n,) int) of ``key``."""
        cells = np.fromiter(chain.from_iterable(key), dtype=np.float64, count=2 * len(key))
        return cells.reshape(-1, 2), np.zeros(len(key), dtype=np.int64)

    def capability_of(self, key: Any) -> Capability:
        """The :class:`Capability` of the structure ``key``, cached."""
        hit = self.capability.get(key)
        if hit is None:
            if len(self.capability) >= self.cache_size:
                self.capability.clear()
            z = self.oracle.cached(key)  # the exact lookahead's, with its matrix
            A = z.A if z is not None else self.matrix_of(key)
            rank = self.oracle.zonotope(A, key=key).rank
            hit = self.capability[key] = Capability(A, rank, len(key), self.features)
        return hit

    def matrices(self, keys: list) -> np.ndarray:
        """Configuration matrices (L, 6, m) of structures of one size."""
        return configuration_matrices(keys, self.module)

    def cell_matrices(self, cells: np.ndarray, types: np.ndarray) -> np.ndarray:
        """Configuration matrices (L, 6, m) of structures of grid ``cells`` (L, n, 2) and
        palette ``types`` (L, n), in that module order."""
        return configuration_matrices(cells, self.module)

    def supports_of(self, keys: list, centres: bool = False) -> tuple[np.ndarray, ...]:
        """(h_W / denom (L, K), slack (L,)) of the structures ``keys`` (all of one size), and
        with ``centres`` the projections of W's centre / denom (L, K), cached per key; misses
        in one batch from their configuration matrices (no oracle call)."""
        missing = [k for k in dict.fromkeys(keys) if k not in self.supports]
        if missing:
            if len(self.supports) + len(missing) > min(CACHE_SIZE, CACHED_CELLS // self.n_max):
                self.supports.clear()
                missing = list(dict.fromkeys(keys))  # the cached ones went too
            h, slack, centre = self.features.supports(self.matrices(missing))
            for k, hk, sk, ck in zip(missing, h, slack, centre):
                self.supports[k] = (hk, float(sk), ck)
        rows = [self.supports[k] for k in keys]
        h, slack = np.array([r[0] for r in rows]), np.array([r[1] for r in rows])
        return (h, slack, np.array([r[2] for r in rows])) if centres else (h, slack)

    # --- against a task ---------------------------------------------------------------------
    def task_arrays(self, task: Any, key: Any = None) -> TaskArrays:
        """The :class:`TaskArrays` of ``task`` (its wrench model decides how): its wrenches
        and, when every wrench gains the same ``c M e_z`` for a structure of M kg, that lift;
        otherwise (a task whose wrenches are each structure's own, ``task.per_structure``: a
        dynamic task) the arrays of the structure ``key``'s own wrenches."""
        model = task.wrench_model
        lift = model.lift_per_kg if not model.uses_inertia else None
        if lift is None or task.per_structure:
            return start_arrays(self, task, key)
        W = np.asarray(model.base, dtype=float)
        vec, h_Tn, WD = self.features.task(W)
        lift_n = lift * self.features.D[:, 2] / self.features.denom if lift else None
        return TaskArrays(task, str(task.name), W, vec, h_Tn, WD, task.kind, lift_n, lift)

    def task_of(self, task: TaskArrays, key: Any) -> TaskArrays:
        """The arrays that decide the structure ``key``: ``task`` itself, or, when its arrays
        are per structure, those of the structure's own wrenches (:func:`.dynamic.own_arrays`)."""
        return own_arrays(self, task, key) if task.per_structure else task

    @staticmethod
    def at_mass(task: TaskArrays, mass: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(rotor wrenches, h_T / denom, WD) of ``task`` for a structure of ``mass`` kg: the
        arrays themselves when nothing is added (or they are one structure's own, from
        :meth:`task_of`), else shifted by ``lift * mass`` (the weight)."""
        if task.lift_n is None:
            return task.W, task.h_Tn, task.WD
        W = task.W.copy()
        W[:, 2] += mass * task.lift
        WD = task.WD + mass * task.lift_n
        return W, WD.max(axis=0), WD

    def evaluate(
        self, key: Any, task: TaskArrays, mass: float, memo: dict, known: int | None = None
    ) -> tuple[int, np.ndarray, int]:
        """(satisfied wrenches, structure vector, oracle tests made) of structure ``key`` against
        ``task`` (for a dynamic task: ``task_of(task, key)``); ``memo`` is the task's memo from
        :class:`TaskMemos`. ``known``: the satisfied count the exact lookahead read off the
        gammas by the same rule (:func:`~.exact.exact_rows`; not with a fault), no oracle call."""
        hit = memo.get(key)
        if hit is not None:
            return hit[0], hit[1], 0
        W, h_Tn, WD = self.at_mass(task, mass)
        cap = self.capability.get(key) or self.capability_of(key)
        if known is not None and self.fault is None:
            per_wrench, tests, n_sat = np.maximum.reduce(WD - cap.h_Wn, axis=1), 0, known
        else:  # a wrench beyond the exact support of the structure in a feature direction (by
            # more than the oracle's tolerance, ``cap.slack``) is certainly infeasible: not tested
            per_wrench, tests, n_sat = self.oracle.screened(cap.A, W, WD, cap.h_Wn, cap.slack, key)
        if self.fault is not None and n_sat:
            n_sat, extra = self.tolerated(key, cap.A, W)
            tests += extra
        self.tests += tests
        vec = self.features.structure_against(
            cap.head, cap.h_Wn, h_Tn, per_wrench, n_sat / len(task.W)
        )
        memo[key] = (n_sat, vec)
        return n_sat, vec, tests

    def tolerated(self, key: Any, A: np.ndarray, W: np.ndarray) -> tuple[int, int]:
        """(wrenches the structure ``key`` still exerts after any single ``fault``, LPs on
        failed matrices this took)."""
        ft = self.fault_tolerance(key, A)
        before = ft.tests
        ok = ft.decide(W, self.oracle.method)
        return int(np.count_nonzero(ok)), ft.tests - before

    def fault_tolerance(self, key: Any, A: np.ndarray) -> FaultTolerance:
        """The :class:`~modquad_gym.oracle.faults.FaultTolerance` of the structure ``key``
        (matrix A) against the ``fault``, cached."""
        ft = self.tolerance.get(key)
        if ft is None:
            if len(self.tolerance) >= self.cache_size:
                self.tolerance.clear()
            rotors, nested = self.module.n_rotors, self.fault_margin > 0.0  # margin: nested
            failures = failure_sets(A.shape[1], self.fault, rotors, nested=nested)
            zonotope = self.oracle.zonotope(A, key=key)
            ft = self.tolerance[key] = FaultTolerance(
                A, zonotope.f_max, failures, zonotope, self.fault_margin
            )
        return ft

    def satisfied(self, key: Any, task: TaskArrays, mass: float) -> np.ndarray:
        """bool (t,): the wrenches of ``task`` that the structure ``key`` (of ``mass`` kg)
        satisfies, by the rule :meth:`evaluate` counts: with a ``fault``, those it still exerts
        after every failure. For pictures: no test counter or memo changes."""
        W = self.at_mass(task, mass)[0]
        A = self.capability_of(key).A
        ok = np.asarray(feasible(A, W, self.oracle.f_max, self.oracle.method), dtype=bool)
        if self.fault is not None and ok.any():  # as evaluate: intact first, then tolerance
            ok = np.asarray(self.fault_tolerance(key, A).decide(W, self.oracle.method), bool)
        return ok

    def candidate_rows(
        self, keys: list, task: TaskArrays, mass: float, memo: dict, supports: list | None = None
    ) -> list[np.ndarray]:
        """Lookahead rows of the child structures ``keys`` (one size, one mass) against
        ``task``, memoised per task in ``memo`` (support functions only, no oracle call); a
        dynamic task's child against its own wrenches. ``supports[i]``: key i's (h / denom,
        slack) where known (as :meth:`supports_of` gives them, up to round-off), else None."""
        missing = [k for k in dict.fromkeys(keys) if k not in memo]
        if missing and task.per_structure:
            h, slack = self.supports_of(missing)
            for k, hk, sk in zip(missing, h, slack):
                own = self.task_of(task, k)
                memo[k] = self.features.candidates(hk[None], sk[None], own.h_Tn, own.WD)[0]
        elif missing:
            _, h_Tn, WD = self.at_mass(task, mass)
            known = dict(zip(keys, supports or ()))
            if all(known.get(k) is not None for k in missing):
                h, slack = (np.array(field) for field in zip(*(known[k] for k in missing)))
            else:
                h, slack = self.supports_of(missing)
            memo.update(zip(missing, self.features.candidates(h, slack, h_Tn, WD)))
        return [memo[k] for k in keys]


class MixedStructureEvaluator(StructureEvaluator):
    """The evaluator for typed keys ``(((x, y), module), ...)`` of a palette (one side)."""

    def __init__(
        self, palette: list[ModuleType], n_max: int, f_max: float, n_directions: int, method: str
    ) -> None:
        super().__init__(palette[0], n_max, f_max, n_directions, method)
        self.palette = palette
        self.index = {id(m): k for k, m in enumerate(palette)}
        self._cols = np.stack([m.columns for m in palette])
        self._masses = np.array([m.mass for m in palette])

    def structure_of(self, key: Any) -> Structure:
        return Structure.from_trusted(tuple(c for c, _ in key), modules=tuple(m for _, m in key))

    def _cells_types(self, key: Any) -> tuple[np.ndarray, np.ndarray]:
        cells = np.array([c for c, _ in key], dtype=np.float64)
        return cells, np.array([self.index[id(m)] for _, m in key], dtype=np.int64)

    def cell_matrices(self, cells: np.ndarray, types: np.ndarray) -> np.ndarray:
        return mixed_configuration_matrices(cells, types, self.palette)

    def matrices(self, keys: list) -> np.ndarray:
        cells = np.array([[c for c, _ in k] for k in keys], dtype=float)
        types = np.array([[self.index[id(m)] for _, m in k] for k in keys])
        return mixed_configuration_matrices(cells, types, self.palette)


class TaskMemos:
    """Per task (by identity) and f_max: decisions (key -> (n_satisfied, structure vector)),
    support lookahead rows (child key -> row), exact lookahead entries (child key ->
    (share, margin)) and the optimal vertices of the current state's children's exact walks
    (the warm starts of the next step's); the last :data:`MEMO_TASKS` tasks are kept."""

    def __init__(self) -> None:
        self._memos: dict[tuple[int, float], tuple[Any, dict, dict, dict, dict]] = {}

    def of(self, task: Any, f_max: float) -> tuple[dict, dict, dict, dict]:
        """(decision memo, candidate memo, exact candidate memo, walk memo) of ``task`` at
        ``f_max``."""
        ident = (id(task), f_max)
        entry = self._memos.get(ident)
        if entry is None or entry[0] is not task:
            if len(self._memos) >= MEMO_TASKS:
                self._memos.clear()
            entry = self._memos[ident] = (task, {}, {}, {}, {})
        for memo in entry[1:]:
            if len(memo) >= CACHE_SIZE:
                memo.clear()
        return entry[1], entry[2], entry[3], entry[4]
