"""Pictures: a structure from above, its feasible forces and torques (projections of the 6-D
feasible set, :mod:`modquad_gym.viz.zonotope`), rotor inputs, and a fast RGB render.

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

import os
from typing import TYPE_CHECKING

import numpy as np

from modquad_gym.core.outputs import save_figure
from modquad_gym.geometry.structure import Structure
from modquad_gym.oracle import check_f_max
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
from modquad_gym.viz.titles import TITLE_WIDTH, figure_title, short_name
from modquad_gym.viz.zonotope import (
    FEASIBLE_COLOUR,
    INFEASIBLE_COLOUR,
    SPACES,
    drawn_vertices,
    hull_faces,
    projection_vertices,
    task_wrenches,
    units,
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
    "draw_projection",
    "draw_rotor_inputs",
    "draw_structure",
    "force_zonotope_vertices",
    "draw_torque_projection",
    "figure_title",
    "save_structure_figure",
    "top_view_inches",
    "short_name",
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
    radius = side / 8
    spins = s.rotor_spins
    for p, d, spin in zip(s.rotor_positions, s.rotor_directions, spins, strict=True):
        colour = SPIN_COLOURS[1 if spin > 0 else -1]
        ax.add_patch(Circle(p[:2], radius, facecolor=colour, edgecolor="k", lw=0.6, zorder=3))
        h = d[:2] * (0.4 * side)
        if np.linalg.norm(h) > 1e-9:  # under the rotor disc: its spin colour stays visible
            ax.add_patch(
                FancyArrow(
                    p[0], p[1], h[0], h[1], width=side / 90, head_width=side / 20,
                    length_includes_head=True, color=ARROW_COLOUR, lw=0, zorder=2,
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
        Line2D(
            [],
            [],
            marker=r"$\rightarrow$",
            ls="",
            color=ARROW_COLOUR,
            markersize=10,
            label="thrust, horizontal part",
        ),
        Line2D([], [], marker="+", ls="", color="k", mew=2, label="COM"),
    ]
    from matplotlib.patches import Patch

    if highlight_first and not mixed:
        handles.append(Patch(facecolor=FIRST_COLOUR, edgecolor="#3a3a3a", label="first module"))
    if mixed:
        handles += [
            Patch(facecolor=type_colour(m, k), edgecolor="#3a3a3a", label=f"module {m.name}")
            for k, m in enumerate(s.palette)
        ]
    # beside the top view, never over a module (a large structure fills its axes)
    ax.legend(handles=handles, loc="upper left", bbox_to_anchor=(1.02, 1.0), borderaxespad=0.0,
              fontsize="x-small", framealpha=0.8)  # fmt: skip
    n = s.n_modules
    ax.set_title(title if title is not None else f"{n} module{'s' if n > 1 else ''}")
    return ax


# --------------------------------------------------------------------------------------------
# torque-space projection of the feasible wrenches (paper Fig. 3b)
# --------------------------------------------------------------------------------------------

HULL_COLOUR, VERTEX_COLOUR = "#4c72b0", "#2b4570"
"""The feasible set's projection (translucent) and its vertices."""

MAX_MARKED_VERTICES = 300
"""Most vertices a projection marks with dots (more merge into a dark blob over the hull)."""

MAX_DRAWN_MODULES = 256
"""Most modules a top view draws (a larger one is unreadable and slow to draw); the torque
projection beside a task has its own limit (:data:`~.zonotope.MAX_PROJECTED_ROTORS`)."""


def check_drawable(structure: Structure) -> None:
    """Refuse before drawing a structure too large for a figure."""
    if structure.n_modules > MAX_DRAWN_MODULES:
        raise ValueError(
            f"a structure of {structure.n_modules:,} modules is too large to draw: the top view "
            f"draws at most {MAX_DRAWN_MODULES} modules"
        )


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
    ax = ax if ax is not None else _new_axes(projection="3d")
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
                   depthshade=False, zorder=2)  # fmt: skip
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
        ax.legend(loc="upper left", fontsize="x-small")
        pts.append(W[:, first : first + 3])
    allp = np.vstack(pts)
    lo, hi = allp.min(axis=0), allp.max(axis=0)
    pad = 0.05 * max(float((hi - lo).max()), 1e-6)
    ax.set_xlim(lo[0] - pad, hi[0] + pad)
    ax.set_ylim(lo[1] - pad, hi[1] + pad)
    ax.set_zlim(lo[2] - pad, hi[2] + pad)
    from matplotlib.ticker import MaxNLocator

    for axis in (ax.xaxis, ax.yaxis, ax.zaxis):  # few, short tick labels: the labels stay inside
        axis.set_major_locator(MaxNLocator(4, steps=[1, 2, 2.5, 5, 10]))
        axis.labelpad = 7  # the axis title clear of its tick labels
    ax.tick_params(labelsize="small", pad=1)
    unit = units(task, f_max)[0 if space == "force" else 1]
    symbol = "f" if space == "force" else r"\tau"
    ax.set_xlabel(rf"${symbol}_x$ [{unit}]")
    ax.set_ylabel(rf"${symbol}_y$ [{unit}]")
    ax.set_zlabel(rf"${symbol}_z$ [{unit}]")
    ax.set_title(f"feasible {space}s: projection of the 6-D set", fontsize="medium")
    return ax


def draw_torque_projection(
    structure: Structure,
    f_max: float = 1.0,
    ax: Axes | None = None,
    wrenches: np.ndarray | None = None,
) -> Axes:
    """:func:`draw_projection` onto torque space (``wrenches`` (t, 6) scattered if given)."""
    return draw_projection(structure, "torque", f_max, ax, wrenches)


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
INCHES_PER_MODULE = 0.45
"""Width of a module in a saved top view (54 px at 120 dpi: rotors about 14 px across, their
spin colours readable); the view grows with the structure between :data:`TOP_VIEW_INCHES`."""

TOP_VIEW_INCHES = (4.0, 12.0)
"""Least and most width or height of the top view's axes, in inches."""


def top_view_inches(structure: Structure) -> tuple[float, float]:
    """(width, height) in inches of a top view's axes: :data:`INCHES_PER_MODULE` per module
    side of the structure's extent (plus the margin), shrunk together to fit
    :data:`TOP_VIEW_INCHES` (equal scales)."""
    c = structure.module_centres[:, :2] / structure.side
    span = c.max(axis=0) - c.min(axis=0) + 1.5  # the margin of draw_structure's limits
    inches = INCHES_PER_MODULE * span
    lo, hi = TOP_VIEW_INCHES
    inches *= min(1.0, hi / inches.max())
    inches *= max(1.0, lo / inches.max())
    return float(inches[0]), float(inches[1])


LAYOUTS = ("row", "grid")
"""How a figure with a task arranges its three views: ``row`` side by side (a wide figure for a
screen), ``grid`` the top view above the two projections (about 8 inches wide: readable where a
page shows it 700 pixels wide, as the documentation does)."""


def save_structure_figure(
    structure: Structure,
    path: str | os.PathLike,
    task: TaskRequirement | np.ndarray | None = None,
    dpi: int = 120,
    layout: str = "row",
) -> str:
    """Save a PNG with the top view (sized with the structure: :func:`top_view_inches`) and, if
    ``task`` (a TaskRequirement or (t, 6) wrenches) is given, the force and torque projections
    of the feasible set with the task's wrenches beside it (6-D feasibility of the rotor
    wrenches: an ``external`` task's plus the structure's weight), arranged as ``layout``
    (:data:`LAYOUTS`). Returns the path."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    if layout not in LAYOUTS:
        raise ValueError(f"layout must be one of {LAYOUTS}, got {layout!r}")
    s = check_structure(structure)
    check_drawable(s)
    w, h = top_view_inches(s)
    legend, label, projection = 2.0, 0.8, 4.6  # inches: the legend beside, the axis labels
    if task is None:
        fig = Figure(figsize=(w + legend + label, h + label), layout="constrained")
        FigureCanvasAgg(fig)
        draw_structure(s, ax=fig.add_subplot(1, 1, 1))
        save_figure(fig, os.fspath(path), dpi=dpi)
        return os.fspath(path)
    if layout == "row":
        height = max(h + label, projection) + 0.6  # the title above
        fig = Figure(figsize=(w + legend + label + 2 * projection, height), layout="constrained")
        grid = fig.add_gridspec(1, 3, width_ratios=[w + legend + label, projection, projection])
        cells = grid[0], grid[1], grid[2]
    else:
        projection = 4.0  # two side by side: 8 inches, 960 px at 120 dpi
        width = max(w + legend + label, 2 * projection)
        fig = Figure(figsize=(width, h + label + projection + 1.0), layout="constrained")
        grid = fig.add_gridspec(2, 2, height_ratios=[h + label, projection])
        cells = grid[0, :], grid[1, 0], grid[1, 1]
    FigureCanvasAgg(fig)
    top = draw_structure(s, ax=fig.add_subplot(cells[0]))
    top.set_anchor("N")  # a wide structure's top view under its title, x label in the figure
    for i, space in enumerate(("force", "torque")):
        ax = fig.add_subplot(cells[1 + i], projection="3d")
        draw_projection(s, space, ax=ax, task=task)
        ax.set_anchor("N")
    width = TITLE_WIDTH if layout == "row" else int(TITLE_WIDTH * fig.get_figwidth() / 15)
    fig.suptitle(figure_title(getattr(task, "name", None), width))
    save_figure(fig, os.fspath(path), dpi=dpi)
    return os.fspath(path)
