"""Deciding whole tasks against many structures, sharing what each rejection teaches.

A :class:`TaskChecker` holds one task. Structures come as cell arrays (L, n, 2) in a fixed
order; :meth:`TaskChecker.first_feasible` returns the first that satisfies every wrench. Most
are rejected by a *cached separating direction*: a direction d that separated a task wrench w
from an earlier structure (d . w > h_S(d)) is tried on every later one, in compiled code straight
from the cells (:mod:`.supports`). Exact, not a heuristic. The survivors go to the certified
oracle, whose rejections teach the cache new directions.

Structures may mix module types: ``types`` (L, n) holds each module's index into the checker's
palette. The task comes as its wrench model (:class:`~modquad_gym.dynamics.LinearWrenches`):
each structure is decided against its own rotor wrenches ``base + M per_mass + P j`` (its mass
M and inertia j). Where every wrench gains the same ``c M e_z`` (the structure's weight, or
nothing) a cached direction's task value is exact for every structure, the weight added in
compiled code; otherwise a cached direction rejects a structure only when a lower bound of the
task's value for its mass and size exceeds its support. One *wrench values* object holds which
(:func:`~modquad_gym.search.dynamic.wrench_values`): the checker asks it, whatever the task.

With a ``fault`` (:data:`~modquad_gym.oracle.faults.FAULTS`) a structure satisfies the task only
when it still does after any failure of that kind, with ``fault_margin`` to spare
(:mod:`modquad_gym.oracle.faults`). A tolerant
structure is feasible, so the intact decisions and the cached directions still rule structures
out exactly; a structure that passes them is then decided failure by failure. A ``deadline``
(a time on the search clock, :func:`~modquad_gym.core.compile_clock.now`, set by a search with
a time limit) interrupts such a decision: it raises
:class:`~modquad_gym.oracle.faults.DecisionInterruptedError` rather than answer. Structures it
decides tolerant are kept in ``confirmed`` (cells, palette indices).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from modquad_gym.core.compile_clock import to_perf_counter
from modquad_gym.dynamics import LinearWrenches
from modquad_gym.geometry.inertia import inertia_vectors
from modquad_gym.geometry.module import ModuleType
from modquad_gym.geometry.structure import (
    Structure,
    configuration_matrices,
    mixed_configuration_matrices,
)
from modquad_gym.oracle import TOL, Zonotope
from modquad_gym.oracle.backends import decide_with
from modquad_gym.oracle.faults import FaultTolerance, failure_sets
from modquad_gym.search.dynamic import wrench_values

POOL_SIZE = 512
"""How many separating directions are kept (most recent first)."""

COMPILED_AFTER = 2000
"""Wrench tests decided by the DAQP LP before the checker switches to the compiled certificates
(the oracle's ``"auto"`` method), for structures of at most :data:`LP_ROTORS` rotors: loading
numba and the cached kernels costs about 0.5 s, some 10,000 such LPs (0.05 ms each), so a small
search answers without it. The decisions are the same exact ones."""

LP_ROTORS = 32
"""Largest structure (rotors) decided by the LP first: the LP's time grows fast with the rotors
(0.3 ms at 64, 7 ms at 256), the certificates' hardly."""


class TaskChecker:
    """Decides a task (its wrench ``model``, f_max) against structures of the module types
    ``palette`` (one type, or a list of types of one side), counting the work.

    Attributes:
        evaluated: structures whose feasibility against the whole task was decided.
        oracle_calls: wrench-structure tests (a rejection by a cached direction counts one).
    """

    def __init__(
        self,
        model: LinearWrenches,
        f_max: float,
        palette: ModuleType | Sequence[ModuleType],
        fault: str | None = None,
        fault_margin: float = 0.0,
    ) -> None:
        self.model = model
        self.W = model.base
        self.fault = fault
        self.fault_margin = fault_margin
        self.f_max = f_max
        self.palette = [palette] if isinstance(palette, ModuleType) else list(palette)
        self.module = self.palette[0]
        self.values = wrench_values(model, self.palette)  # the task's wrenches, per structure
        self.evaluated = 0
        self.oracle_calls = 0
        self.type_masses = np.array([m.mass for m in self.palette])
        # hardest wrenches first: by decreasing Euclidean norm (ties keep the task's order), so
        # an infeasible structure usually fails on an early batch
        W = self.values.order_wrenches(self.module)
        self.order = np.argsort(-np.linalg.norm(W, axis=1), kind="stable")
        self.pool = np.zeros((0, 6))  # separating directions in wrench space, newest first
        self._terms_of: tuple | None = None  # the pool's (b, alpha, beta), made on demand
        self._dz = np.zeros(0)  # the directions' f_z components (the weight term)
        self.learned = 0  # directions remembered so far (the pool's length stops at POOL_SIZE)
        self.deadline: float | None = None  # fault decisions past it are interrupted
        self.confirmed: set[tuple] = set()  # (cells, types) of structures decided tolerant

    # --- the cache of separating directions ------------------------------------------------
    def remember(self, d6: np.ndarray) -> None:
        """Add a separating direction (normalised) at the front of the cache."""
        d6 = np.asarray(d6, dtype=float) / np.linalg.norm(d6)
        self.learned += 1
        self._set_pool(np.vstack([d6[None], self.pool]))

    def adopt(self, directions: np.ndarray) -> None:
        """Put separating directions (rows, newest first; e.g. learnt by other checkers of the
        same task) at the front of the cache, in one update."""
        directions = np.asarray(directions, dtype=float).reshape(-1, 6)
        norms = np.linalg.norm(directions, axis=1)
        self._set_pool(np.vstack([directions[norms > 0] / norms[norms > 0, None], self.pool]))

    def _set_pool(self, pool: np.ndarray) -> None:
        self.pool = pool[:POOL_SIZE]
        self._terms_of = None
        self.values.set_pool(self.pool)
        self._dz = np.ascontiguousarray(self.pool[:, 2])

    def _terms(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The pool's per-rotor support terms (:func:`~.supports.direction_terms`), cached."""
        if self._terms_of is None:
            from modquad_gym.search.supports import direction_terms

            self._terms_of = direction_terms(self.palette, self.pool)
        return self._terms_of

    def _types(self, cells: np.ndarray, types: np.ndarray | None) -> np.ndarray:
        if types is None:
            return np.zeros(cells.shape[:2], dtype=np.int8)
        return np.ascontiguousarray(types, dtype=np.int8)

    def alive(
        self, cells: np.ndarray, types: np.ndarray | None = None, newest_only: bool = False
    ) -> np.ndarray:
        """bool (L,): structures (cells (L, n, 2), palette indices ``types`` (L, n), default
        all the first type) that no cached direction rejects (only the newest direction with
        ``newest_only``); with a ``fault``, rejects by the support left after each structure's
        worst failure of that kind."""
        cells = np.ascontiguousarray(cells, dtype=np.int32)
        alive = np.ones(len(cells), dtype=bool)
        k = min(1, len(self.pool)) if newest_only else len(self.pool)
        if k:  # numba (supports): only once directions exist
            from modquad_gym.search.supports import LOSSES

            terms = tuple(t[:k] for t in self._terms())
            self.values.reject(cells, self._types(cells, types), self.pool[:k], terms,
                               self._dz[:k], self.f_max, 0.5 * TOL, alive,
                               LOSSES[self.fault])  # fmt: skip
        return alive

    # --- deciding ---------------------------------------------------------------------------
    def first_feasible(
        self, cells: np.ndarray, types: np.ndarray | None = None, seen=None
    ) -> int | None:
        """Index of the first structure of ``cells`` (L, n, 2) (with palette indices ``types``
        (L, n), default all the first type) that satisfies the task, or None. Every structure
        up to it counts as evaluated. ``seen(k)``, when given, is told after each structure
        the oracle decides that the first k are decided (a progress bar moves)."""
        types = self._types(cells, types)
        alive = self.alive(cells, types)
        survivors = np.flatnonzero(alive)
        while len(survivors):
            i = int(survivors[0])
            survivors = survivors[1:]
            learned = self.learned
            A, mass = self.matrix(cells[i], types[i])
            if self.check_matrix(A, mass, self._inertia(cells[i], types[i])):
                self._count_rejected(i - int(alive[:i].sum()))
                return i
            if seen is not None:
                seen(i + 1)
            if self.learned != learned and i + 1 < len(cells):  # one new direction
                alive[i + 1 :] &= self.alive(cells[i + 1 :], types[i + 1 :], newest_only=True)
                survivors = i + 1 + np.flatnonzero(alive[i + 1 :])
        self._count_rejected(len(cells) - int(alive.sum()))
        return None

    def matrix(self, cells: np.ndarray, types: np.ndarray) -> tuple[np.ndarray, float]:
        """(A, total mass in kg) of one structure: cells (n, 2), palette indices (n,)."""
        mass = float(self.type_masses[types].sum())
        if len(self.palette) == 1 or np.all(types == types[0]):
            return configuration_matrices(cells[None], self.palette[int(types[0])])[0], mass
        A = mixed_configuration_matrices(cells[None], types[None], self.palette)[0]
        return A, mass

    def _inertia(self, cells: np.ndarray, types: np.ndarray) -> np.ndarray | None:
        """The inertia vector of one structure when the task's wrenches need it, else None."""
        if not self.values.inertial:
            return None
        return inertia_vectors(cells[None], types[None], self.palette)[1][0]

    def _count_rejected(self, k: int) -> None:
        self.evaluated += k
        self.oracle_calls += k

    def type_indices(self, structure: Structure) -> np.ndarray:
        """(n,) palette indices of the structure's modules (ValueError for a foreign type)."""
        index = {id(m): k for k, m in enumerate(self.palette)}
        try:
            return np.array([index[id(m)] for m in structure.modules], dtype=np.int8)
        except KeyError:
            raise ValueError("the structure has a module type outside the palette") from None

    def check(self, structure: Structure) -> bool:
        """True when the structure satisfies every task wrench (exact)."""
        cells = np.asarray(structure.cells, dtype=np.int32)[None]
        types = self.type_indices(structure)[None]
        if not self.alive(cells, types)[0]:
            self._count_rejected(1)
            return False
        A = structure.configuration_matrix()
        ok = self.check_matrix(A, structure.mass, structure.inertia)
        if ok and self.fault is not None:
            self.confirmed.add(self.key(structure))
        return ok

    def key(self, structure: Structure) -> tuple:
        """(cells, palette indices) of a structure, as :attr:`confirmed` holds them."""
        return tuple(map(tuple, structure.cells)), tuple(self.type_indices(structure).tolist())

    def check_matrix(self, A: np.ndarray, mass: float = 0.0, inertia=None) -> bool:
        """Decide the task on one configuration matrix (of a structure of ``mass`` kg and
        ``inertia`` (3, 3) or (6,), which matter for ``external`` and ``dynamic`` tasks) with
        the certified oracle, small batches of the hardest wrenches first; a rejection teaches
        the cache a direction."""
        self.evaluated += 1
        z = Zonotope(A, self.f_max)
        W = self.values.wrenches(mass, inertia)[self.order]
        start = 0
        for size in (4, 16, len(W)):  # small batches first: most structures fail early
            batch = W[start:size]
            if not len(batch):
                continue
            ok = self.decide(z, batch)
            if not ok.all():
                self._learn(z, batch[int(np.argmin(ok))])
                return False
            start = size
        if self.fault is not None:
            part = {"rotor2": "rotor", "rotor+module": "module"}.get(self.fault)
            if part is not None:  # what a larger failure leaves lies in what each of its parts
                # leaves: single rotors or modules (fewer) rule out most structures first
                sets = failure_sets(A.shape[1], part, self.module.n_rotors)
                single = FaultTolerance(A, self.f_max, sets, z, deadline=self._cut())
                ok = single.decide(W, self.method(z), stop_early=True)
                self.oracle_calls += single.tests
                if not ok:
                    self._learn_failure(single, W)
                    return False
            tolerance = self.tolerance(A, z)
            ok = tolerance.decide(W, self.method(z), stop_early=True)
            self.oracle_calls += tolerance.tests
            if not ok:
                self._learn_failure(tolerance, W)
            return ok
        return True

    def _learn_failure(self, tolerance: FaultTolerance, W: np.ndarray) -> None:
        """Remember a direction separating the wrench that broke a fault decision from what its
        failure leaves: the cache then rejects later structures whose support after their own
        worst failure of the kind (:data:`.supports.LOSSES`) it exceeds (that support is at
        most what any one failure leaves, so the test stays exact)."""
        if tolerance.breaker is not None:
            row, failure = tolerance.breaker
            z = tolerance.failed(failure)
            if z is not None:
                self._learn(z, W[row])

    def tolerance(self, A: np.ndarray, z: Zonotope | None = None) -> FaultTolerance:
        """The fault tolerance of a structure's matrix A (columns by module) for this task's
        ``fault`` and ``fault_margin`` (a margin also after the smaller failures: ``nested``)."""
        rotors = self.module.n_rotors
        failures = failure_sets(A.shape[1], self.fault, rotors, nested=self.fault_margin > 0.0)
        return FaultTolerance(A, self.f_max, failures, z, self.fault_margin, self._cut())

    def _cut(self) -> float | None:
        """:attr:`deadline` as the :func:`time.perf_counter` time a fault decision takes (it
        moves that later by what compiles during the decision)."""
        return None if self.deadline is None else to_perf_counter(self.deadline)

    def decide(self, z: Zonotope, W: np.ndarray) -> np.ndarray:
        """Exact decisions (t,) of wrenches W for the zonotope z, counted as ``len(W)`` oracle
        calls: by the DAQP LP while the work is small (:data:`COMPILED_AFTER`), then by the
        compiled certificates."""
        method = self.method(z)
        self.oracle_calls += len(W)
        return decide_with(z, W, method)

    def method(self, z: Zonotope) -> str:
        """The oracle's method for the next decisions on z: ``"daqp"`` while the work is small
        (structures of at most :data:`LP_ROTORS` rotors, fewer than :data:`COMPILED_AFTER`
        wrench tests so far), then ``"auto"``. Fault decisions follow it (the LP skips the
        compiled allocation certificate)."""
        small = z.m <= LP_ROTORS and self.oracle_calls < COMPILED_AFTER
        return "daqp" if small else "auto"

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
            self.remember(d6)
