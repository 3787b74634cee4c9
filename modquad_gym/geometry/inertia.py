"""Mass properties of structures: the inertia tensor about the centre of mass, one structure or
many at once (the searches' batches).

Each module is a rigid body of its type's mass and inertia (:attr:`ModuleType.inertia`, about
the module centre, module axes = {S} axes) centred at its module centre c_i in {S}. About the
COM (the origin of {S}), by the parallel-axis theorem,

    J = sum_i [ J_i + m_i (|c_i|^2 I - c_i c_i^T) ].

Module centres lie in the plane z = 0, so the sums reduce to those of x^2, y^2 and x y.
Inertia vectors ``(Jxx, Jyy, Jzz, Jxy, Jxz, Jyz)``, in this order, are what the searches
carry: a task's wrenches are linear in them (:mod:`modquad_gym.dynamics`).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from modquad_gym.geometry.module import ModuleType

_IDX = ((0, 0), (1, 1), (2, 2), (0, 1), (0, 2), (1, 2))


def inertia_about_com(
    centres: np.ndarray, masses: np.ndarray, inertias: Sequence[np.ndarray]
) -> np.ndarray:
    """(3, 3) inertia about the origin of bodies of ``masses`` (n,) and own ``inertias`` (n of
    (3, 3), about their centres) centred at ``centres`` (n, 3) (module docstring)."""
    c = np.asarray(centres, dtype=float)
    m = np.asarray(masses, dtype=float)
    J = np.sum(np.asarray(inertias, dtype=float), axis=0)
    J += np.eye(3) * float(m @ np.einsum("ij,ij->i", c, c)) - np.einsum("i,ij,ik->jk", m, c, c)
    return (J + J.T) / 2


def to_vector(J: np.ndarray) -> np.ndarray:
    """(..., 6) inertia vectors of (..., 3, 3) tensors (the order above)."""
    J = np.asarray(J, dtype=float)
    return np.stack([J[..., i, j] for i, j in _IDX], axis=-1)


def to_tensor(j: np.ndarray) -> np.ndarray:
    """(..., 3, 3) tensors of (..., 6) inertia vectors."""
    j = np.asarray(j, dtype=float)
    J = np.empty(j.shape[:-1] + (3, 3))
    for k, (a, b) in enumerate(_IDX):
        J[..., a, b] = J[..., b, a] = j[..., k]
    return J


def inertia_vectors(
    cells: np.ndarray, types: np.ndarray, palette: Sequence[ModuleType]
) -> tuple[np.ndarray, np.ndarray]:
    """(masses (L,), inertia vectors (L, 6)) of L structures of n modules: ``cells`` (L, n, 2)
    grid cells, ``types`` (L, n) indices into ``palette`` (types of one side). The same as
    :attr:`Structure.mass` and :attr:`Structure.inertia` of each, up to round-off."""
    cells = np.asarray(cells, dtype=float)
    types = np.asarray(types, dtype=np.intp)
    side = palette[0].side
    m = np.array([t.mass for t in palette])[types]  # (L, n)
    own = to_vector(np.stack([t.inertia for t in palette]))[types].sum(axis=1)  # (L, 6)
    M = m.sum(axis=1)
    com = np.einsum("ln,lnk->lk", m, cells) / M[:, None]
    c = (cells - com[:, None, :]) * side  # (L, n, 2)
    sxx = np.einsum("ln,ln->l", m, c[..., 0] ** 2)
    syy = np.einsum("ln,ln->l", m, c[..., 1] ** 2)
    sxy = np.einsum("ln,ln->l", m, c[..., 0] * c[..., 1])
    zero = np.zeros_like(M)
    return M, own + np.stack([syy, sxx, sxx + syy, -sxy, zero, zero], axis=1)
