"""Structure-dependent task wrenches in the searches: one *wrench values* interface for every task.

A task's wrench model (:class:`~modquad_gym.dynamics.LinearWrenches`) becomes, for a checker,
one of two objects with the same interface (:func:`wrench_values`): :class:`UniformLiftValues`
when every wrench gains the same ``c M e_z`` for a structure of M kg (a ``total`` task, c = 0;
an ``external`` one, c = g; a level motion), whose values are exact for every structure and
cached per direction; :class:`DynamicValues` otherwise. Both give ``wrenches(mass, inertia)``
(one structure's own), ``values(D, mass, n)`` (the task's value per direction, a lower bound
for the second), ``order_wrenches(module)`` (what orders the wrenches hardest first),
``set_pool(pool)``, ``reject(...)`` (the cached directions' test, in compiled code) and
``inertial``. Every separation must exceed the oracle's off-range grant ``RESIDUAL_TOL (f_max +
|w|)`` (:func:`off_range_grant`: |w| bounded over the structures a test covers).

A dynamic task (:class:`~modquad_gym.dynamics.DynamicTask`) asks the rotors of a structure S of
mass M and inertia vector j for ``w_i(S) = base_i + M s_i + P_i j`` at each trajectory sample i
(:class:`~modquad_gym.dynamics.LinearWrenches`): ``s_i`` the specific force (force rows only),
``P_i`` the inertia's torque terms (zero for a level trajectory). A task of kind ``external`` is
the special case ``s_i = g e_z`` for every i, ``P_i = 0``; the searches handle both the same way:

* deciding one structure: the oracle on ``w_i(S)`` (its own M and j);
* a separating direction d (the checker's cache, the level bounds) rules out S when a *lower
  bound* of ``max_i d . w_i(S)`` exceeds S's support in d. :class:`DynamicValues` gives one that
  depends only on M and the module count n: exact when the task has no inertia term; otherwise
  ``max_i min_{j in B_n} d . w_i(M, j)`` with B_n a box holding the inertia vector of every
  n-module structure (:func:`inertia_box`). It is a lower bound because for the true j of S,
  ``max_i d . w_i(M, j) >= d . w_i(M, j) >= min_{j' in B_n} d . w_i(M, j')`` for every i;
* forces alone (the count bound, :func:`force_needs`): the force rows do not depend on j, so
  ``max_i N . (f_base_i + M s_i)`` is exact for each count vector (its M).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from modquad_gym.dynamics import LinearWrenches
from modquad_gym.geometry.inertia import to_vector
from modquad_gym.geometry.module import ModuleType
from modquad_gym.oracle.tolerance import RESIDUAL_TOL

CHUNK = 64
"""Directions handled together by :meth:`DynamicValues.values` (bounds the memory)."""


def inertia_box(palette: Sequence[ModuleType], n: int, mass: float) -> tuple[np.ndarray, ...]:
    """(lo (6,), hi (6,)): bounds on the inertia vector (Jxx, Jyy, Jzz, Jxy, Jxz, Jyz) of every
    structure of ``n`` modules of ``palette`` types weighing ``mass`` kg. Own inertias: n times
    the types' extremes. Parallel-axis sums sxx = sum m_i x_i^2 (x_i from the COM) and syy: the
    module centres span at most L = (n - 1) side along each axis, so by Popoviciu's inequality
    0 <= sxx, syy <= M L^2 / 4, and |sxy| <= sqrt(sxx syy) <= M L^2 / 4."""
    own = to_vector(np.stack([m.inertia for m in palette]))  # (K, 6)
    L = (n - 1) * palette[0].side
    s = mass * L * L / 4
    lo = n * own.min(axis=0) + np.array([0.0, 0.0, 0.0, -s, 0.0, 0.0])
    hi = n * own.max(axis=0) + np.array([s, s, 2 * s, s, 0.0, 0.0])
    return lo, hi


def off_range_grant(
    model: LinearWrenches, palette: Sequence[ModuleType], f_max: float, n: int, mass: float
) -> float:
    """How far a task wrench may lie off a structure's reach along a unit direction and stay
    feasible by the oracle's rule, ``RESIDUAL_TOL (f_max + |w|)``, for every structure of at
    most ``n`` modules of ``palette`` types and at most ``mass`` kg: |w_i(S)| <= |base_i| +
    M |s_i| + |P_i j|, each inertia component |j_c| at most n times the types' largest plus
    the parallel-axis sums' bound of :func:`inertia_box`."""
    size = np.linalg.norm(model.base, axis=1) + mass * np.linalg.norm(model.per_mass, axis=1)
    if model.uses_inertia and n >= 1:
        own = np.abs(to_vector(np.stack([m.inertia for m in palette]))).max(axis=0)
        s = mass * ((n - 1) * palette[0].side) ** 2 / 4
        J = n * own + s * np.array([1.0, 1.0, 2.0, 1.0, 0.0, 0.0])
        size = size + np.linalg.norm(model.per_inertia, axis=1) @ J
    return RESIDUAL_TOL * (f_max + float(size.max(initial=0.0)))


def force_needs(model: LinearWrenches, N: np.ndarray, masses: np.ndarray) -> np.ndarray:
    """(C, q): ``max_i N_q . (f_base_i + M_c s_i)`` for each structure mass M_c (the force
    demand of a dynamic task along each direction N_q, exact: forces do not depend on j)."""
    masses = np.asarray(masses, dtype=float)
    a = model.base[:, :3] @ N.T  # (k, q)
    b = model.per_mass[:, :3] @ N.T
    unique, where = np.unique(masses, return_inverse=True)
    out = np.stack([(a + M * b).max(axis=0) for M in unique]) if len(unique) else a[:0]
    return out[where.reshape(-1)] if len(unique) else np.zeros((0, N.shape[0]))


def wrench_values(model: LinearWrenches, palette: Sequence[ModuleType]):
    """The wrench values of ``model`` for structures of ``palette`` types (module docstring):
    :class:`UniformLiftValues` when every wrench gains the same ``c M e_z``, else
    :class:`DynamicValues`."""
    lift = model.lift_per_kg if not model.uses_inertia else None
    if lift is None:
        return DynamicValues(model, palette)
    return UniformLiftValues(model, palette, lift)


def _weights(palette: Sequence[ModuleType]) -> np.ndarray:
    """The types' weights in a structure's COM: equal masses weigh the cells equally (the COM
    is the plain mean of the cells)."""
    masses = np.array([m.mass for m in palette])
    return np.ones(len(masses)) if np.all(masses == masses[0]) else masses


class UniformLiftValues:
    """The values of a task whose every wrench gains the same ``lift M e_z`` for a structure
    of M kg (the weight, or nothing): ``max_i d . w_i + lift M d_z``, exact; the first term is
    cached per direction of the pool and the weight is added in compiled code."""

    inertial = False

    def __init__(self, model: LinearWrenches, palette: Sequence[ModuleType], lift: float):
        self.model = model
        self.palette = list(palette)
        self.lift_per_kg = lift
        self.lift = np.array([m.mass for m in self.palette]) * (lift or 0.0)  # per type
        self.heaviest = max(m.mass for m in self.palette)  # kg, the heaviest type
        self.weights = _weights(self.palette)
        self._values = np.zeros(0)  # max_i d . w_i over the task, per pool direction

    def order_wrenches(self, module: ModuleType) -> np.ndarray:
        """(k, 6) the wrenches whose norms order the task, hardest first: the task's own."""
        return self.model.base

    def set_pool(self, pool: np.ndarray) -> None:
        """Cache the task's value of each pool direction."""
        self._values = (pool @ self.model.base.T).max(axis=1)

    def values(self, D: np.ndarray, mass: float, n: int) -> np.ndarray:
        """(P,) the exact values of the directions D (P, 6) for a structure of ``mass`` kg."""
        D = np.asarray(D, dtype=float).reshape(-1, 6)
        if not len(D):
            return np.zeros(0)
        return (D @ self.model.base.T).max(axis=1) + self.lift_per_kg * mass * D[:, 2]

    def wrenches(self, mass: float, inertia: np.ndarray | None) -> np.ndarray:
        """(k, 6) the wrenches of one structure (its mass; the inertia is not used)."""
        return self.model.at(mass)

    def reject(self, cells, types, pool, terms, dz, f_max: float, half_tol: float, alive, lose=0):
        """Clear ``alive`` for the structures (cells (L, n, 2), types (L, n)) that one of the
        first ``len(pool)`` cached directions (their support ``terms``) separates from the
        task (after the worst failure of kind ``lose``, :data:`.supports.LOSSES`), in one
        compiled pass."""
        from modquad_gym.search import supports

        b, alpha, beta = terms
        side = float(self.palette[0].side)
        n = cells.shape[1]
        grant = off_range_grant(self.model, self.palette, f_max, n, n * self.heaviest)
        values = self._values[: len(pool)] - grant
        supports.reject(cells, types, self.weights, side, b, alpha, beta, values, f_max,
                        half_tol, alive, self.lift, dz, lose)  # fmt: skip


class DynamicValues:
    """Lower bounds of ``max_i d . w_i(S)`` per direction d for the structures of n modules of
    a given mass (module docstring), for a dynamic task's wrench model and palette."""

    def __init__(self, model: LinearWrenches, palette: Sequence[ModuleType]) -> None:
        self.model = model.compact()
        self.palette = list(palette)
        self.inertial = self.model.uses_inertia
        self.weights = _weights(self.palette)
        self.type_masses = np.array([m.mass for m in self.palette])

    def order_wrenches(self, module: ModuleType) -> np.ndarray:
        """(k, 6) the wrenches whose norms order the task, hardest first: those of one
        ``module``."""
        return self.model.base + module.mass * self.model.per_mass

    def set_pool(self, pool: np.ndarray) -> None:
        """Nothing to cache: the values depend on each structure's mass and size."""

    def reject(self, cells, types, pool, terms, dz, f_max: float, half_tol: float, alive, lose=0):
        """The cache test: structures grouped by mass, each group against the lower bounds of
        the task's values for its mass and size (module docstring)."""
        from modquad_gym.search import supports

        b, alpha, beta = (np.ascontiguousarray(t) for t in terms)
        side = float(self.palette[0].side)
        masses = self.type_masses[types].sum(axis=1)
        zero = np.zeros(len(self.palette))
        for mass in np.unique(masses):
            idx = np.flatnonzero(masses == mass)
            n = cells.shape[1]
            grant = off_range_grant(self.model, self.palette, f_max, n, float(mass))
            values = self.values(pool, float(mass), n) - grant
            sub = alive[idx]
            group = np.ascontiguousarray(cells[idx]), np.ascontiguousarray(types[idx])
            supports.reject(*group, self.weights, side, b, alpha, beta, values, f_max,
                            half_tol, sub, zero, dz, lose)  # fmt: skip
            alive[idx] = sub

    def values(self, D: np.ndarray, mass: float, n: int) -> np.ndarray:
        """(P,) the lower bounds for the directions D (P, 6), structures of ``n`` modules
        weighing ``mass`` kg."""
        D = np.asarray(D, dtype=float).reshape(-1, 6)
        m = self.model
        W = m.base + mass * m.per_mass  # (k, 6)
        if not self.inertial:
            return (D @ W.T).max(axis=1) if len(D) else np.zeros(0)
        lo, hi = inertia_box(self.palette, n, mass)
        mid, rad = (lo + hi) / 2, (hi - lo) / 2
        W = W + m.per_inertia @ mid
        out = np.empty(len(D))
        for start in range(0, len(D), CHUNK):
            d = D[start : start + CHUNK]
            Q = np.einsum("pr,krc->pkc", d[:, 3:], m.per_inertia[:, 3:, :])  # (p, k, 6)
            out[start : start + CHUNK] = (d @ W.T - np.abs(Q) @ rad).max(axis=1)
        return out

    def wrenches(self, mass: float, inertia: np.ndarray | None) -> np.ndarray:
        """(k, 6) the exact wrenches of one structure (``inertia`` (3, 3) or (6,); ignored when
        the task has no inertia term)."""
        return self.model.at(mass, inertia if self.inertial else None)
