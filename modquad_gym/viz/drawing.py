"""Pictures: a structure from above, its torque-space zonotope, rotor inputs, and a fast RGB render.

Matplotlib is imported inside the functions (``import modquad_gym`` stays light) and figures are
made with ``matplotlib.figure.Figure`` on an Agg canvas, never through pyplot, so nothing here
touches the global backend or opens windows. :func:`structure_image` (from
:mod:`modquad_gym.viz.raster`, re-exported here with the colours) does not use matplotlib at all: it
rasterises the top view with numpy (deterministic, about 10 ms), for Gymnasium's
``render_mode="rgb_array"``.

Colours: rotors with spin +1 blue, spin -1 orange; the first (initial) module is green, as in the
paper's Fig. 5; thrust arrows (dark red) show the horizontal part of each rotor's thrust
direction; the black cross is the COM, the origin of {S}. In a mixed structure modules are
filled by type (:func:`type_colour`: a fixed fill per stock type) with a legend naming each
type, and the first module keeps a thick outline instead of the green fill.
"""

from __future__ import annotations

import math
import os
from functools import lru_cache
from typing import TYPE_CHECKING

import numpy as np

from modquad_gym.core.outputs import save_figure
from modquad_gym.geometry.structure import Structure
from modquad_gym.oracle import check_f_max, feasible
from modquad_gym.viz.raster import (
    ARROW_COLOUR,
    FIRST_COLOUR,
    MODULE_COLOUR,
    SPIN_COLOURS,
    STOCK_FILLS,
    TYPE_COLOURS,
    check_structure,
    structure_image,
    type_colour,
)

if TYPE_CHECKING:  # pragma: no cover
    from matplotlib.axes import Axes

    from modquad_gym.tasks import TaskRequirement

__all__ = [
    "ARROW_COLOUR",
    "FIRST_COLOUR",
    "MODULE_COLOUR",
    "SPIN_COLOURS",
    "STOCK_FILLS",
    "TYPE_COLOURS",
    "draw_rotor_inputs",
    "draw_structure",
    "draw_torque_projection",
    "save_structure_figure",
    "structure_image",
    "torque_zonotope_vertices",
    "type_colour",
]


def _new_axes(projection: str | None = None, figsize: tuple[float, float] = (5.0, 5.0)) -> Axes:
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=figsize, layout="constrained")
    FigureCanvasAgg(fig)
    return fig.add_subplot(1, 1, 1, projection=projection)


# --------------------------------------------------------------------------------------------
# top view
# --------------------------------------------------------------------------------------------
def draw_structure(
    structure: Structure,
    ax: Axes | None = None,
    title: str | None = None,
    highlight_first: bool = True,
) -> Axes:
    """Top view of ``structure`` in {S} (metres): module squares, rotors coloured by spin,
    horizontal thrust arrows, the COM, and the first module highlighted. Returns the axes."""
    from matplotlib.lines import Line2D
    from matplotlib.patches import Circle, FancyArrow, Rectangle

    s = check_structure(structure)
    ax = ax if ax is not None else _new_axes()
    side = s.side
    mixed = s.is_mixed
    for i, ((cx, cy, _), t) in enumerate(zip(s.module_centres, s.type_indices)):
        first = highlight_first and i == 0
        fill = type_colour(s.modules[i], t) if mixed else FIRST_COLOUR if first else MODULE_COLOUR
        ax.add_patch(
            Rectangle(
                (cx - side / 2, cy - side / 2),
                side,
                side,
                facecolor=fill,
                edgecolor="#3a3a3a",
                linewidth=(2.5 if mixed else 1.5) if first else 1.0,
                zorder=1,
            )
        )
    radius = side / 9
    spins = s.rotor_spins
    for p, d, spin in zip(s.rotor_positions, s.rotor_directions, spins, strict=True):
        colour = SPIN_COLOURS[1 if spin > 0 else -1]
        ax.add_patch(Circle(p[:2], radius, facecolor=colour, edgecolor="k", alpha=0.85, zorder=2))
        h = d[:2] * (side / 3)
        if np.linalg.norm(h) > 1e-9:
            ax.add_patch(
                FancyArrow(
                    p[0], p[1], h[0], h[1], width=side / 60, head_width=side / 18,
                    length_includes_head=True, color=ARROW_COLOUR, zorder=3,
                )
            )  # fmt: skip
    ax.plot([0.0], [0.0], marker="+", color="k", markersize=14, mew=2.5, zorder=4)
    xs, ys = s.module_centres[:, 0], s.module_centres[:, 1]
    pad = side * 0.75
    ax.set_xlim(xs.min() - pad, xs.max() + pad)
    ax.set_ylim(ys.min() - pad, ys.max() + pad)
    ax.set_aspect("equal")
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    handles = [
        Line2D([], [], marker="o", ls="", color=SPIN_COLOURS[1], label="rotor, spin +1"),
        Line2D([], [], marker="o", ls="", color=SPIN_COLOURS[-1], label="rotor, spin -1"),
        Line2D([], [], marker="+", ls="", color="k", mew=2, label="COM"),
    ]
    if mixed:
        from matplotlib.patches import Patch

        handles += [
            Patch(facecolor=type_colour(m, k), edgecolor="#3a3a3a", label=f"module {m.name}")
            for k, m in enumerate(s.palette)
        ]
    ax.legend(handles=handles, loc="best", fontsize="x-small", framealpha=0.8)
    ax.set_title(title if title is not None else f"{s.n_modules} module(s)")
    return ax


# --------------------------------------------------------------------------------------------
# torque-space projection of the feasible wrenches (paper Fig. 3b)
# --------------------------------------------------------------------------------------------
_DIRECTIONS_PER_BLOCK = 8192

MAX_DRAWN_MODULES = 256
"""Most modules a top view draws (a larger one is unreadable and slow to draw)."""

MAX_PROJECTED_MODULES = 64
"""Most modules whose torque projection is drawn: its support directions grow as the square of
the rotor count, the work as the cube (64 modules: 2 million directions)."""


def check_drawable(structure: Structure, projection: bool = False) -> None:
    """Refuse before drawing a structure too large for a figure (the limits above)."""
    limit = MAX_PROJECTED_MODULES if projection else MAX_DRAWN_MODULES
    if structure.n_modules > limit:
        what = "torque projection beside the task" if projection else "top view"
        raise ValueError(
            f"a structure of {structure.n_modules:,} modules is too large to draw: the {what} "
            f"draws at most {limit} modules"
        )


def torque_zonotope_vertices(A: np.ndarray, f_max: float = 1.0) -> np.ndarray:
    """Vertices (k, 3) of the projection of W = {A u : 0 <= u <= f_max} onto torque space.

    The projection is the 3-d zonotope with generators ``A[3:] * f_max``. Every vertex is a
    support point ``sum_j f_max a_j [d . a_j > 0]``. Directions: the normals of all generator
    pairs (every facet of a 3-d zonotope is normal to some a_i x a_j), each tilted slightly
    around its normal to land in every neighbouring cell, plus a Fibonacci sphere. The hull of
    the support points is then exactly the zonotope (checked against its support function in
    the tests).
    """
    f_max = check_f_max(f_max)
    G = np.asarray(A, dtype=float)[3:] * f_max  # (3, m)
    if G.ndim != 2 or G.shape[0] != 3:
        raise ValueError(f"A must be a 6 x m configuration matrix, got shape {np.shape(A)}")
    m = G.shape[1]
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
    for start in range(0, len(D), _DIRECTIONS_PER_BLOCK):  # memory: one block of supports
        P = (D[start : start + _DIRECTIONS_PER_BLOCK] @ G > 0).astype(float) @ G.T
        points.append(np.unique(np.round(P, 12), axis=0))
    return np.unique(np.vstack(points), axis=0)


@lru_cache(maxsize=8)
def _fibonacci_sphere(k: int) -> np.ndarray:
    i = np.arange(k) + 0.5
    phi = np.arccos(1 - 2 * i / k)
    theta = math.pi * (1 + 5**0.5) * i
    out = np.stack([np.cos(theta) * np.sin(phi), np.sin(theta) * np.sin(phi), np.cos(phi)], 1)
    out.setflags(write=False)
    return out


def draw_torque_projection(
    structure: Structure,
    f_max: float = 1.0,
    ax: Axes | None = None,
    wrenches: np.ndarray | None = None,
) -> Axes:
    """The feasible wrenches projected onto (tau_x, tau_y, tau_z) as a translucent convex hull
    (paper Fig. 3b) on a 3-d axes; ``wrenches`` (t, 6), if given, are scattered by their
    torques, green where the whole wrench is feasible and red where not. Returns the axes."""
    from mpl_toolkits.mplot3d.art3d import Poly3DCollection
    from scipy.spatial import ConvexHull, QhullError

    s = check_structure(structure)
    A = s.configuration_matrix()
    V = torque_zonotope_vertices(A, f_max)
    ax = ax if ax is not None else _new_axes(projection="3d")
    try:
        hull = ConvexHull(V)
        faces = [V[simplex] for simplex in hull.simplices]
        ax.add_collection3d(
            Poly3DCollection(
                faces, facecolor="#4c72b0", edgecolor="none", linewidths=0.0, alpha=0.25
            )
        )
    except (QhullError, ValueError):  # a flat projection: show the points only
        pass
    ax.scatter(V[:, 0], V[:, 1], V[:, 2], s=2, color="#2b4570", alpha=0.5, depthshade=False)
    pts = [V]
    if wrenches is not None:
        W = np.atleast_2d(np.asarray(wrenches, dtype=float))
        if W.ndim != 2 or W.shape[1] != 6:
            raise ValueError(f"wrenches must have shape (t, 6), got {np.shape(wrenches)}")
        ok = feasible(A, W, f_max=f_max)
        for mask, colour, label in ((ok, "#2ca02c", "feasible"), (~ok, "#d62728", "infeasible")):
            if mask.any():
                T = W[mask, 3:]
                ax.scatter(T[:, 0], T[:, 1], T[:, 2], s=12, color=colour, label=label,
                           depthshade=False)  # fmt: skip
        ax.legend(loc="upper left", fontsize="x-small")
        pts.append(W[:, 3:])
    allp = np.vstack(pts)
    lo, hi = allp.min(axis=0), allp.max(axis=0)
    pad = 0.05 * max(float((hi - lo).max()), 1e-6)
    ax.set_xlim(lo[0] - pad, hi[0] + pad)
    ax.set_ylim(lo[1] - pad, hi[1] + pad)
    ax.set_zlim(lo[2] - pad, hi[2] + pad)
    ax.set_xlabel(r"$\tau_x$ [N m]")
    ax.set_ylabel(r"$\tau_y$ [N m]")
    ax.set_zlabel(r"$\tau_z$ [N m]")
    ax.set_title("feasible torques")
    return ax


# --------------------------------------------------------------------------------------------
# rotor inputs (paper Fig. 7)
# --------------------------------------------------------------------------------------------
def draw_rotor_inputs(U: np.ndarray, f_max: float = 1.0, ax: Axes | None = None) -> Axes:
    """Rotor thrusts over wrench index, one line per rotor, with f_max dotted (paper Fig. 7).

    ``U`` has shape (t, m): row i holds the m rotor inputs for wrench i. Returns the axes.
    """
    U = np.asarray(U, dtype=float)
    if U.ndim == 1:
        U = U[None, :]
    if U.ndim != 2 or U.size == 0:
        raise ValueError(f"U must have shape (t, m) with t, m >= 1, got {np.shape(U)}")
    f_max = check_f_max(f_max)
    ax = ax if ax is not None else _new_axes(figsize=(7.0, 3.5))
    idx = np.arange(1, U.shape[0] + 1)
    for k in range(U.shape[1]):
        ax.plot(idx, U[:, k], lw=1.0, marker="." if U.shape[0] < 3 else None)
    ax.axhline(f_max, ls=":", color="k", lw=1.5, label=r"$f_{max}$")
    ax.axhline(0.0, ls="-", color="0.6", lw=0.8)
    ax.set_xlabel("wrench index")
    ax.set_ylabel("rotor thrust")
    ax.set_ylim(min(0.0, float(U.min())) - 0.05 * f_max, max(f_max, float(U.max())) + 0.1 * f_max)
    ax.set_title(f"rotor inputs ({U.shape[1]} rotors)")
    ax.legend(loc="lower right", fontsize="x-small")
    return ax


# --------------------------------------------------------------------------------------------
# figure file
# --------------------------------------------------------------------------------------------
def save_structure_figure(
    structure: Structure,
    path: str | os.PathLike,
    task: TaskRequirement | np.ndarray | None = None,
    dpi: int = 120,
) -> str:
    """Save a PNG with the top view and, if ``task`` (a TaskRequirement or (t, 6) wrenches) is
    given, the torque projection with the task's torques beside it (feasibility of the rotor
    wrenches: an ``external`` task's plus the structure's weight). Returns the path."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    s = check_structure(structure)
    check_drawable(s, projection=task is not None)
    if task is None:
        fig = Figure(figsize=(5.0, 5.0), layout="constrained")
        FigureCanvasAgg(fig)
        draw_structure(s, ax=fig.add_subplot(1, 1, 1))
    else:
        W = task.rotor_wrenches(s.mass) if hasattr(task, "rotor_wrenches") else task
        f_max = float(getattr(task, "f_max", 1.0))
        fig = Figure(figsize=(10.5, 5.0), layout="constrained")
        FigureCanvasAgg(fig)
        name = getattr(task, "name", None)
        draw_structure(s, ax=fig.add_subplot(1, 2, 1))
        draw_torque_projection(s, f_max, ax=fig.add_subplot(1, 2, 2, projection="3d"), wrenches=W)
        if name:
            fig.suptitle(f"task: {name}")
    save_figure(fig, os.fspath(path), dpi=dpi)
    return os.fspath(path)
