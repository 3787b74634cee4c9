"""What the pictures of the feasible wrenches share: the set's projections onto force and torque
space, their hulls, a task's wrenches with their feasibility, and the units to write on the axes.

The feasible set W = {A u : 0 <= u <= f_max} is 6-dimensional. A picture shows its *projection*
onto the three force or the three torque coordinates: the set of forces (torques) that some
feasible wrench has, whatever its torque (force). A task wrench is coloured by its feasibility
as a whole, in 6-D: an infeasible wrench may well lie inside both projections.
"""

from __future__ import annotations

import math
from functools import lru_cache

import numpy as np

from modquad_gym.core.validation import check_f_max
from modquad_gym.oracle import feasible

SPACES = {"force": (0, ("f_x", "f_y", "f_z")), "torque": (3, ("tau_x", "tau_y", "tau_z"))}
"""The two projections: first row of A and the coordinate names."""

FEASIBLE_COLOUR, INFEASIBLE_COLOUR = "#2ca02c", "#d62728"
"""Task wrenches that the structure can (green) and cannot (red) exert, judged in 6-D."""


DIRECTIONS_PER_BLOCK = 8192
"""Support directions evaluated together (memory: one block times the rotor count)."""

MAX_PROJECTED_ROTORS = 256
"""Most rotors (64 four-rotor modules) whose projection :func:`projection_vertices` computes
exactly: its support directions grow as the square of the rotor count, the work as the cube
(256 rotors: 2 million directions). The pictures sample larger ones (:func:`drawn_vertices`)."""


def projection_vertices(A: np.ndarray, space: str, f_max: float = 1.0) -> np.ndarray:
    """Vertices (k, 3) of the projection of W onto force (``space="force"``) or torque space.

    The projection is the 3-d zonotope with generators ``A[rows] * f_max``. Every vertex is a
    support point ``sum_j f_max a_j [d . a_j > 0]``. Directions: the normals of all generator
    pairs (every facet of a 3-d zonotope is normal to some a_i x a_j), each tilted slightly
    around its normal to land in every neighbouring cell, plus a Fibonacci sphere. The hull of
    the support points is then exactly the zonotope (checked against its support function in
    the tests).
    """
    if space not in SPACES:
        raise ValueError(f"space must be one of {tuple(SPACES)}, got {space!r}")
    f_max = check_f_max(f_max)
    A = np.asarray(A, dtype=float)
    if A.ndim != 2 or A.shape[0] != 6:
        raise ValueError(f"A must be a 6 x m configuration matrix, got shape {np.shape(A)}")
    first = SPACES[space][0]
    G = A[first : first + 3] * f_max  # (3, m)
    m = G.shape[1]
    if m > MAX_PROJECTED_ROTORS:
        raise ValueError(
            f"a structure of {m:,} rotors is too large for its {space} projection: at most "
            f"{MAX_PROJECTED_ROTORS} rotors are drawn"
        )
    dirs = [_fibonacci_sphere(400)]
    i, j = np.triu_indices(m, k=1)
    N = np.cross(G[:, i].T, G[:, j].T)
    norm = np.linalg.norm(N, axis=1)
    N = N[norm > 1e-12 * max(1.0, float(np.abs(G).max()) ** 2)]
    if len(N):
        N /= np.linalg.norm(N, axis=1, keepdims=True)
        # two unit vectors orthogonal to each normal, for the tilts
        ref = np.where(np.abs(N[:, :1]) < 0.9, [[1.0, 0.0, 0.0]], [[0.0, 1.0, 0.0]])
        e1 = np.cross(N, ref)
        e1 /= np.linalg.norm(e1, axis=1, keepdims=True)
        e2 = np.cross(N, e1)
        eps = 1e-5
        for theta in np.linspace(0.0, 2 * math.pi, 16, endpoint=False):
            tilt = eps * (math.cos(theta) * e1 + math.sin(theta) * e2)
            dirs += [N + tilt, -N + tilt]
    D = np.vstack(dirs)
    points = []
    for start in range(0, len(D), DIRECTIONS_PER_BLOCK):  # memory: one block of supports
        P = (D[start : start + DIRECTIONS_PER_BLOCK] @ G > 0).astype(float) @ G.T
        points.append(np.unique(np.round(P, 12), axis=0))
    return np.unique(np.vstack(points), axis=0)


EXACT_DRAWN_ROTORS = 32
"""Most rotors (8 four-rotor modules) whose projections are drawn with every vertex; a larger
structure's surface is :func:`drawn_vertices`' hull of sampled vertices (a 64-module torque
projection has about 60,000 vertices and 120,000 triangles: slow to draw and, drawn
translucent, an opaque blob)."""

DRAWN_DIRECTIONS = 2000
"""Support directions (a Fibonacci sphere) whose support points a large structure's drawn
projection spans."""


def drawn_vertices(A: np.ndarray, space: str, f_max: float = 1.0) -> tuple[np.ndarray, bool]:
    """The vertices to draw of the projection of W onto ``space`` and whether they are all of
    them. Up to :data:`EXACT_DRAWN_ROTORS` rotors: :func:`projection_vertices` (exact).
    Beyond: the support points of :data:`DRAWN_DIRECTIONS` evenly spread directions, each a true
    vertex, so their hull lies inside the projection and touches it at every drawn vertex (at
    16 to 128 modules within 0.2 % of the projection's extent, measured by the support function
    in 20,000 directions; exact where the projection has few vertices, as the force projection
    of T-modules). Any size: the work grows only linearly with the rotors."""
    if space not in SPACES:
        raise ValueError(f"space must be one of {tuple(SPACES)}, got {space!r}")
    A = np.asarray(A, dtype=float)
    if A.ndim != 2 or A.shape[0] != 6 or A.shape[1] <= EXACT_DRAWN_ROTORS:
        return projection_vertices(A, space, f_max), True
    f_max = check_f_max(f_max)
    first = SPACES[space][0]
    G = A[first : first + 3] * f_max
    P = (_fibonacci_sphere(DRAWN_DIRECTIONS) @ G > 0).astype(float) @ G.T
    return np.unique(np.round(P, 12), axis=0), False


@lru_cache(maxsize=8)
def _fibonacci_sphere(k: int) -> np.ndarray:
    i = np.arange(k) + 0.5
    phi = np.arccos(1 - 2 * i / k)
    theta = math.pi * (1 + 5**0.5) * i
    out = np.stack([np.cos(theta) * np.sin(phi), np.sin(theta) * np.sin(phi), np.cos(phi)], 1)
    out.setflags(write=False)
    return out


def hull_faces(V: np.ndarray) -> np.ndarray | None:
    """Triangles (s, 3) of the convex hull of the points ``V`` (indices into V), or None when
    the points are flat (a rank-deficient projection): then only the points can be shown."""
    from scipy.spatial import ConvexHull, QhullError

    try:
        return ConvexHull(V).simplices
    except (QhullError, ValueError):
        return None


def task_wrenches(structure, task) -> tuple[np.ndarray, np.ndarray, float]:
    """The wrenches the rotors of ``structure`` must produce for ``task`` (a TaskRequirement:
    an ``external`` task's plus the structure's weight; a DynamicTask: along its trajectory,
    with the structure's mass and inertia; or a (t, 6) array), their 6-D feasibility, and
    f_max. Both task kinds take the structure itself (a dynamic task needs its inertia)."""
    W = task.rotor_wrenches(structure) if hasattr(task, "rotor_wrenches") else task
    W = np.atleast_2d(np.asarray(W, dtype=float))
    if W.ndim != 2 or W.shape[1] != 6:
        raise ValueError(f"wrenches must have shape (t, 6), got {np.shape(W)}")
    f_max = float(getattr(task, "f_max", 1.0))
    return W, feasible(structure.configuration_matrix(), W, f_max=f_max), f_max


def units(task=None, f_max: float = 1.0) -> tuple[str, str]:
    """Axis units of forces and torques: a task's own (``task.normalised_units``), else by
    ``f_max``: SI (N, N m) for ``external`` and dynamic tasks and for thrust
    limits other than 1; "f_max" and "f_max·m" for the paper's normalised tasks (f_max = 1)."""
    if getattr(task, "normalised_units", float(getattr(task, "f_max", f_max)) == 1.0):
        return "f_max", "f_max·m"
    return "N", "N m"


UNIT_MARKUP = {"mathtext": r"$f_\mathrm{max}$", "html": "f<sub>max</sub>"}
"""How each picture writes f_max with its subscript: matplotlib's mathtext, plotly's HTML."""


def marked_up(unit: str, markup: str) -> str:
    """A unit of :func:`units` as ``markup`` (a key of :data:`UNIT_MARKUP`) writes it: f_max
    with a subscript, not an underscore."""
    return unit.replace("f_max", UNIT_MARKUP[markup])
