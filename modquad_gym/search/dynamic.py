"""Structure-dependent task wrenches in the searches: tasks of kind ``dynamic``.

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

CHUNK = 64
"""Directions handled together by :meth:`DynamicValues.values` (bounds the memory)."""


def compact(model: LinearWrenches) -> LinearWrenches:
    """The same wrench model with repeated samples (e.g. the hover holds) kept once: every
    search decision is a max or an all() over the samples, which repeats do not change."""
    k = len(model.base)
    rows = np.hstack([model.base, model.per_mass, model.per_inertia.reshape(k, -1)])
    _, first = np.unique(np.round(rows, 12), axis=0, return_index=True)
    keep = np.sort(first)
    if len(keep) == k:
        return model
    parts = [np.ascontiguousarray(a[keep]) for a in (model.base, model.per_mass, model.per_inertia)]
    for a in parts:
        a.setflags(write=False)
    return LinearWrenches(*parts)


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


def force_needs(model: LinearWrenches, N: np.ndarray, masses: np.ndarray) -> np.ndarray:
    """(C, q): ``max_i N_q . (f_base_i + M_c s_i)`` for each structure mass M_c (the force
    demand of a dynamic task along each direction N_q, exact: forces do not depend on j)."""
    masses = np.asarray(masses, dtype=float)
    a = model.base[:, :3] @ N.T  # (k, q)
    b = model.per_mass[:, :3] @ N.T
    unique, where = np.unique(masses, return_inverse=True)
    out = np.stack([(a + M * b).max(axis=0) for M in unique]) if len(unique) else a[:0]
    return out[where.reshape(-1)] if len(unique) else np.zeros((0, N.shape[0]))


class DynamicValues:
    """Lower bounds of ``max_i d . w_i(S)`` per direction d for the structures of n modules of
    a given mass (module docstring), for a dynamic task's wrench model and palette."""

    def __init__(self, model: LinearWrenches, palette: Sequence[ModuleType]) -> None:
        self.model = compact(model)
        self.palette = list(palette)
        self.inertial = self.model.uses_inertia

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
