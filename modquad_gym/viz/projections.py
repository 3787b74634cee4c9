"""The feasible set's projections drawn in 3-D with matplotlib (paper Fig. 3b): the force or
torque projection of W = {A u : 0 <= u <= f_max} as a translucent hull, a task's wrenches over
it coloured by their 6-D feasibility (:mod:`modquad_gym.viz.zonotope` computes both), and the
axes' limits and ticks. :mod:`modquad_gym.viz.drawing` re-exports everything public here.

Matplotlib is imported inside the functions, and figures are made on an Agg canvas, never
through pyplot (nothing touches the global backend or opens a window).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from modquad_gym.core.extras import import_optional
from modquad_gym.core.validation import check_f_max
from modquad_gym.geometry.structure import Structure
from modquad_gym.viz.raster import check_structure
from modquad_gym.viz.zonotope import (
    FEASIBLE_COLOUR,
    INFEASIBLE_COLOUR,
    SPACES,
    drawn_vertices,
    hull_faces,
    marked_up,
    projection_vertices,
    task_wrenches,
    units,
)

if TYPE_CHECKING:  # pragma: no cover
    from matplotlib.axes import Axes


def new_axes(projection: str | None = None, figsize: tuple[float, float] = (5.0, 5.0)) -> Axes:
    """One axes on a new constrained-layout figure with an Agg canvas (no pyplot)."""
    FigureCanvasAgg = import_optional("matplotlib.backends.backend_agg").FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=figsize, layout="constrained")
    FigureCanvasAgg(fig)
    return fig.add_subplot(1, 1, 1, projection=projection)


HULL_COLOUR, VERTEX_COLOUR = "#4c72b0", "#2b4570"
"""The feasible set's projection (translucent) and its vertices."""

MAX_MARKED_VERTICES = 300
"""Most vertices a projection marks with dots (more merge into a dark blob over the hull)."""


def torque_zonotope_vertices(A: np.ndarray, f_max: float = 1.0) -> np.ndarray:
    """Vertices (k, 3) of the projection of W = {A u : 0 <= u <= f_max} onto torque space
    (:func:`modquad_gym.viz.zonotope.projection_vertices`)."""
    return projection_vertices(A, "torque", f_max)


def force_zonotope_vertices(A: np.ndarray, f_max: float = 1.0) -> np.ndarray:
    """Vertices (k, 3) of the projection of W onto force space."""
    return projection_vertices(A, "force", f_max)


def draw_projection(
    structure: Structure,
    space: str = "torque",
    f_max: float = 1.0,
    ax: Axes | None = None,
    task=None,
) -> Axes:
    """The feasible wrenches projected onto force (``space="force"``) or torque space as a
    translucent convex hull (paper Fig. 3b) on a 3-d axes. ``task`` (a TaskRequirement, or
    (t, 6) wrenches), if given, is scattered by the same coordinates on top of the hull (dark
    outlines), green where the whole 6-D wrench is feasible and red where not (so a red point
    may lie inside the projection). Past :data:`~.zonotope.EXACT_DRAWN_ROTORS` rotors the hull
    is that of sampled vertices (:func:`~.zonotope.drawn_vertices`). Axis units follow
    :func:`modquad_gym.viz.zonotope.units`. Returns the axes."""
    from mpl_toolkits.mplot3d.art3d import Poly3DCollection

    s = check_structure(structure)
    first, names = SPACES[space]
    f_max = check_f_max(getattr(task, "f_max", f_max))
    V, exact = drawn_vertices(s.configuration_matrix(), space, f_max)
    ax = ax if ax is not None else new_axes(projection="3d")
    ax.computed_zorder = False  # draw order by zorder: the task's points over the hull
    ax.set_box_aspect(None, zoom=0.78)  # the axis labels inside the axes, not over a neighbour
    faces = hull_faces(V)
    if faces is not None:
        ax.add_collection3d(Poly3DCollection(
            [V[f] for f in faces], facecolor=HULL_COLOUR, edgecolor="none", linewidths=0.0,
            alpha=0.2, zorder=1,
        ))  # fmt: skip
    if faces is None or (exact and len(V) <= MAX_MARKED_VERTICES):
        ax.scatter(V[:, 0], V[:, 1], V[:, 2], s=2, color=VERTEX_COLOUR, alpha=0.5,
                   depthshade=False, zorder=2, label="vertex of the projection")  # fmt: skip
    pts = [V]
    if task is not None:
        W, ok, _ = task_wrenches(s, task)
        kinds = ((ok, FEASIBLE_COLOUR, "task wrench, feasible (6-D)"),
                 (~ok, INFEASIBLE_COLOUR, "task wrench, infeasible (6-D)"))  # fmt: skip
        for mask, colour, label in kinds:
            if mask.any():
                P = W[mask, first : first + 3]
                ax.scatter(P[:, 0], P[:, 1], P[:, 2], s=22, color=colour, label=label,
                           edgecolors="k", linewidths=0.5, depthshade=False, zorder=5)  # fmt: skip
        pts.append(W[:, first : first + 3])
    if ax.get_legend_handles_labels()[0]:  # the task's points, the marked vertices
        ax.legend(loc="upper left", fontsize="x-small", markerscale=1.5)
    _limits_and_ticks(ax, np.vstack(pts))
    unit = marked_up(units(task, f_max)[0 if space == "force" else 1], "mathtext")
    symbol = "f" if space == "force" else r"\tau"
    ax.set_xlabel(rf"${symbol}_x$ [{unit}]")
    ax.set_ylabel(rf"${symbol}_y$ [{unit}]")
    ax.set_zlabel(rf"${symbol}_z$ [{unit}]")
    ax.set_title(f"feasible {space}s: projection of the 6-D set", fontsize="medium")
    return ax


CORNER_CLEARANCE = 0.15
"""Share of the x axis's span kept free of ticks at its largest end, where its tick labels meet
the y axis's in the default 3-D view: labels there ran into each other ("50−200")."""


def _limits_and_ticks(ax, points: np.ndarray) -> None:
    """Limits of a projection's 3-D axes around ``points`` (k, 3) with a margin, and at most
    five short ticks per axis (the labels stay inside), no x tick by the corner the x and y
    tick labels share (:data:`CORNER_CLEARANCE`) while two or more are left."""
    from matplotlib.ticker import MaxNLocator

    lo, hi = points.min(axis=0), points.max(axis=0)
    pad = 0.05 * max(float((hi - lo).max()), 1e-6)
    lo, hi = lo - pad, hi + pad
    locator = MaxNLocator(4, steps=[1, 2, 2.5, 5, 10])
    axes = ((ax.xaxis, ax.set_xlim), (ax.yaxis, ax.set_ylim), (ax.zaxis, ax.set_zlim))
    for k, (axis, set_limits) in enumerate(axes):
        set_limits(lo[k], hi[k])
        ticks = locator.tick_values(lo[k], hi[k])
        ticks = ticks[(ticks >= lo[k]) & (ticks <= hi[k])]
        keep = ticks <= hi[k] - CORNER_CLEARANCE * (hi[k] - lo[k])
        if k == 0 and keep.sum() >= 2:
            ticks = ticks[keep]
        axis.set_ticks(ticks)
        axis.labelpad = 7  # the axis title clear of its tick labels
    ax.tick_params(labelsize="small", pad=1)


def draw_torque_projection(
    structure: Structure,
    f_max: float = 1.0,
    ax: Axes | None = None,
    wrenches: np.ndarray | None = None,
) -> Axes:
    """:func:`draw_projection` onto torque space (``wrenches`` (t, 6) scattered if given)."""
    return draw_projection(structure, "torque", f_max, ax, wrenches)
