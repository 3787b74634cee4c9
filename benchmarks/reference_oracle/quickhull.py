"""The ``"quickhull"`` method: the paper's Algorithm 1, as a cross-check only.

Divide-and-conquer Quickhull on the 0/f_max vertices, with joggled input (the 0/1 vertex sets are
highly degenerate in 6-d); exponential, allowed for up to 12 generators (3 modules).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from benchmarks.reference_oracle import cache

if TYPE_CHECKING:
    from modquad_gym.oracle.zonotope import Zonotope

QUICKHULL_MAX_COLUMNS = 12
"""Most generators (rotors) the exponential Quickhull is allowed for: 3 modules."""


def gamma_quickhull(z: Zonotope, R: np.ndarray) -> np.ndarray:
    """Gamma from the convex hull of the 0/f_max vertices (Algorithm 1), m <= 12 only."""
    if z.m > QUICKHULL_MAX_COLUMNS:
        raise ValueError(
            f"quickhull is exponential; it is allowed for at most {QUICKHULL_MAX_COLUMNS} "
            f"generators (3 modules), got {z.m}"
        )
    if "quickhull" not in cache(z):
        pts = _divide_and_conquer_vertices(2.0 * z.G)  # vertices of W - 0, reduced
        from scipy.spatial import ConvexHull

        # joggled input: the 0/1 vertex sets are highly degenerate in 6-d
        hull = ConvexHull(pts - z.G.sum(axis=1), qhull_options="QJ")  # centred at c
        eq = hull.equations  # n . x + off <= 0 inside, off < 0 since 0 is interior
        cache(z)["quickhull"] = (eq[:, :-1], -eq[:, -1])
    N, h = cache(z)["quickhull"]
    return (R @ N.T / h).max(axis=1)


def _divide_and_conquer_vertices(A: np.ndarray) -> np.ndarray:
    """Vertices of {A u : u in {0,1}^m} by the paper's recursion (hull of Minkowski sums)."""
    from scipy.spatial import ConvexHull, QhullError

    m = A.shape[1]
    if m == 1:
        return np.vstack([np.zeros(A.shape[0]), A[:, 0]])
    left = _divide_and_conquer_vertices(A[:, : (m + 1) // 2])
    right = _divide_and_conquer_vertices(A[:, (m + 1) // 2 :])
    pts = (left[:, None, :] + right[None, :, :]).reshape(-1, A.shape[0])
    pts = np.unique(np.round(pts, 12), axis=0)
    try:
        return pts[ConvexHull(pts, qhull_options="QJ").vertices]
    except (QhullError, ValueError):  # lower-dimensional so far: keep every point
        return pts
