"""Pictures: a structure from above, its feasible forces and torques (projections of the 6-D
feasible set, drawn by :mod:`modquad_gym.viz.projections` and re-exported here), rotor inputs,
the figure file of them all, and a fast RGB render.

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

from modquad_gym.core.extras import import_optional
from modquad_gym.core.outputs import check_output_file, save_figure
from modquad_gym.core.validation import check_f_max, check_flag
from modquad_gym.geometry.structure import Structure
from modquad_gym.viz.projections import (
    CORNER_CLEARANCE,
    HULL_COLOUR,
    MAX_MARKED_VERTICES,
    VERTEX_COLOUR,
    draw_projection,
    draw_torque_projection,
    force_zonotope_vertices,
    new_axes,
    torque_zonotope_vertices,
)
from modquad_gym.viz.raster import (
    ARROW_COLOUR,
    FIRST_COLOUR,
    FIRST_OUTLINE,
    MODULE_COLOUR,
    SPIN_COLOURS,
    STOCK_FILLS,
    TYPE_COLOURS,
    check_structure,
    module_fill,
    structure_image,
    type_colour,
)
from modquad_gym.viz.titles import TITLE_WIDTH, figure_title, short_name

if TYPE_CHECKING:  # pragma: no cover
    from matplotlib.axes import Axes

    from modquad_gym.tasks import TaskRequirement

__all__ = [
    "ARROW_COLOUR",
    "CORNER_CLEARANCE",
    "FIRST_COLOUR",
    "HULL_COLOUR",
    "MAX_MARKED_VERTICES",
    "MODULE_COLOUR",
    "SPIN_COLOURS",
    "STOCK_FILLS",
    "TYPE_COLOURS",
    "VERTEX_COLOUR",
    "module_fill",
    "draw_projection",
    "draw_rotor_inputs",
    "draw_structure",
    "legend_handles",
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


# --------------------------------------------------------------------------------------------
# how large a figure can be
# --------------------------------------------------------------------------------------------
MAX_DRAWN_MODULES = 256
"""Most modules a top view draws (a larger one is unreadable and slow to draw); the projections
beside a task are sampled past :data:`~.zonotope.EXACT_DRAWN_ROTORS` and take any size."""


def check_drawable(structure: Structure) -> None:
    """Refuse before drawing a structure too large for a figure."""
    if structure.n_modules > MAX_DRAWN_MODULES:
        raise ValueError(
            f"a structure of {structure.n_modules:,} modules is too large to draw: the top view "
            f"draws at most {MAX_DRAWN_MODULES} modules"
        )


# --------------------------------------------------------------------------------------------
# top view
# --------------------------------------------------------------------------------------------
def draw_structure(
    structure: Structure,
    ax: Axes | None = None,
    title: str | None = None,
    highlight_first: bool = True,
    *,
    types: bool | None = None,
    legend: bool = True,
    arrows: bool = True,
) -> Axes:
    """Top view of ``structure`` in {S} (metres): module squares, rotors coloured by spin,
        horizontal thrust arrows, the COM, and the first module highlighted. Modules are filled by
        type when ``types`` (default: when the structure mixes types; a figure of several
        structures of a mixed palette asks for it on every panel, :func:`legend_handles` naming
        the palette once). ``legend``: the legend beside the axes. ``arrows``: the thrust arrows
    (off where the module types are not known, e.g. a shape read from cells alone: the arrows
    would show a type's tilts). Returns the axes."""
    from matplotlib.patches import Circle, Rectangle

    s = check_structure(structure)
    ax = ax if ax is not None else new_axes()
    side = s.side
    typed = s.is_mixed if types is None else bool(types)
    for i, (cx, cy, _) in enumerate(s.module_centres):
        first = highlight_first and i == 0
        fill = module_fill(s, i, typed) if typed or highlight_first else MODULE_COLOUR
        ax.add_patch(
            Rectangle(
                (cx - side / 2, cy - side / 2),
                side,
                side,
                facecolor=fill,
                edgecolor="#3a3a3a",
                linewidth=(FIRST_OUTLINE if typed else 1.5) if first else 1.0,
                zorder=1,
            )
        )
    radius = side / 8
    spins = s.rotor_spins
    for p, d, spin in zip(s.rotor_positions, s.rotor_directions, spins, strict=True):
        colour = SPIN_COLOURS[1 if spin > 0 else -1]
        ax.add_patch(Circle(p[:2], radius, facecolor=colour, edgecolor="k", lw=0.6, zorder=3))
        h = d[:2]
        if arrows and np.linalg.norm(h) > 1e-9:
            ax.add_patch(_thrust_arrow(p[:2], h, radius, side))
    ax.plot([0.0], [0.0], marker="+", color="k", markersize=14, mew=2.5, zorder=4)
    xs, ys = s.module_centres[:, 0], s.module_centres[:, 1]
    pad = side * 0.75
    ax.set_xlim(xs.min() - pad, xs.max() + pad)
    ax.set_ylim(ys.min() - pad, ys.max() + pad)
    ax.set_aspect("equal")
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    if legend:  # beside the top view, never over a module (a large structure fills its axes)
        handles = legend_handles(s.palette if typed else None, highlight_first, arrows)
        ax.legend(handles=handles, loc="upper left", bbox_to_anchor=(1.02, 1.0),
                  borderaxespad=0.0, fontsize="x-small", framealpha=0.8)  # fmt: skip
    n = s.n_modules
    ax.set_title(title if title is not None else f"{n} module{'s' if n > 1 else ''}")
    return ax


def legend_handles(palette=None, highlight_first: bool = True, arrows: bool = True) -> list:
    """The legend of :func:`draw_structure`: the rotors' spins, the thrust arrows (with
    ``arrows``), the COM, the first module, and with ``palette`` (module types, drawn filled by
    type) one entry per type. A figure of several top views draws it once (``legend=False`` on
    each)."""
    Line2D = import_optional("matplotlib.lines").Line2D
    from matplotlib.patches import Patch

    handles = [
        Line2D([], [], marker="o", ls="", color=SPIN_COLOURS[1], label="rotor, spin +1"),
        Line2D([], [], marker="o", ls="", color=SPIN_COLOURS[-1], label="rotor, spin -1"),
        *[
            Line2D(
                [],
                [],
                marker=r"$\rightarrow$",
                ls="",
                color=ARROW_COLOUR,
                markersize=10,
                label="thrust, horizontal part",
            )
        ]
        * arrows,  # fmt: skip
        Line2D([], [], marker="+", ls="", color="k", mew=2, label="COM"),
    ]
    if highlight_first and palette is None:
        handles.append(Patch(facecolor=FIRST_COLOUR, edgecolor="#3a3a3a", label="first module"))
    if highlight_first and palette is not None:
        handles.append(Patch(facecolor="white", edgecolor="#3a3a3a", linewidth=FIRST_OUTLINE,
                             label="first module (thick outline)"))  # fmt: skip
    for k, m in enumerate(palette or ()):
        handles.append(Patch(facecolor=type_colour(m, k), edgecolor="#3a3a3a",
                             label=f"module {m.name}"))  # fmt: skip
    return handles


def _thrust_arrow(p: np.ndarray, h: np.ndarray, radius: float, side: float):
    """The arrow of a rotor's horizontal thrust ``h`` (the thrust direction's x, y): from the
    edge of the rotor's disc (its spin colour stays whole) outward, as long as 0.25 module
    sides times ``|h|`` and wide enough to read where a module is 40 pixels across."""
    from matplotlib.patches import FancyArrow

    start = p + radius * h / np.linalg.norm(h)
    v = 0.25 * side * h
    return FancyArrow(
        start[0], start[1], v[0], v[1], width=side / 30, head_width=side / 9,
        head_length=side / 12, length_includes_head=True, color=ARROW_COLOUR, lw=0, zorder=2,
    )  # fmt: skip


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
    ax = ax if ax is not None else new_axes(figsize=(7.0, 3.5))
    idx = np.arange(1, U.shape[0] + 1)
    for k in range(U.shape[1]):
        ax.plot(idx, U[:, k], lw=1.0, marker="." if U.shape[0] < 3 else None)
    ax.axhline(f_max, ls=":", color="k", lw=1.5, label=r"$f_{max}$")
    ax.axhline(0.0, ls="-", color="0.6", lw=0.8)
    ax.set_xlabel("wrench index")
    ax.set_ylabel(f"rotor thrust [N] (f_max = {f_max:g} N)")
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
screen; beside a top view at least two projections tall, the projections stacked in a column
that fills its height), ``grid`` the top view above the two projections (about 8 inches wide:
readable where a page shows it 700 pixels wide, as the documentation does)."""

PROJECTION_INCHES = (4.6, 6.0)
"""Least and most side of a projection's axes in the row layout, in inches: they grow with the
top view's height, so a large structure's projections are not small beside it."""


def _figure_with_task(w: float, h: float, layout: str):
    """The figure (of the sizes of :func:`save_structure_figure`) and, for its top view, force
    and torque projections, each (the figure or subfigure to add it to, its grid cell), for a
    top view of ``w`` x ``h`` inches. The grid layout draws the top view and the projections
    in two subfigures, each laid out on its own: in one grid, the projections' margins widened
    the top view's cell, and a 16-module-wide top view lost its y label and legend at the
    figure's edges."""
    Figure = import_optional("matplotlib.figure").Figure

    legend, label = 2.0, 0.8  # inches: the legend beside the top view, the axis labels
    top_w, top_h = w + legend + label, h + label
    if layout == "grid":
        projection = 4.0  # two side by side: 8 inches, 960 px at 120 dpi
        fig = Figure(figsize=(max(top_w + 0.2, 2 * projection), top_h + projection + 1.0),
                     layout="constrained")  # fmt: skip
        upper, lower = fig.subfigures(2, 1, height_ratios=[top_h, projection])
        below = lower.add_gridspec(1, 2)
        return fig, ((upper, upper.add_gridspec(1, 1)[0]), (lower, below[0]), (lower, below[1]))
    least, most = PROJECTION_INCHES
    if top_h >= 2 * least:  # a tall top view: the projections one above the other beside it
        side = min(top_h / 2, most)
        fig = Figure(figsize=(top_w + side, max(top_h, 2 * side) + 0.6), layout="constrained")
        grid = fig.add_gridspec(2, 2, width_ratios=[top_w, side])
        return fig, ((fig, grid[:, 0]), (fig, grid[0, 1]), (fig, grid[1, 1]))
    side = min(max(top_h, least), most)
    fig = Figure(figsize=(top_w + 2 * side, max(top_h, side) + 0.6), layout="constrained")
    grid = fig.add_gridspec(1, 3, width_ratios=[top_w, side, side])
    return fig, tuple((fig, cell) for cell in grid)


def save_structure_figure(
    structure: Structure,
    path: str | os.PathLike,
    task: TaskRequirement | np.ndarray | None = None,
    dpi: int = 120,
    layout: str = "row",
    force: bool = False,
    *,
    what: str = "path",
) -> str:
    """Save a PNG with the top view (sized with the structure: :func:`top_view_inches`) and, if
    ``task`` (a TaskRequirement, a DynamicTask or (t, 6) wrenches) is given, the force and
    torque projections of the feasible set with the task's wrenches beside it (6-D
    feasibility of the rotor wrenches: an ``external`` task's plus the structure's weight, a
    dynamic task's for the structure's mass and inertia), arranged as ``layout``
    (:data:`LAYOUTS`). An existing file is replaced only with ``force`` (OutputError, as
    ``save_structure_page``; checked before drawing and again before writing, ``what`` naming
    ``path``: a command's option gets the advice ``--force``). Returns the path."""
    FigureCanvasAgg = import_optional("matplotlib.backends.backend_agg").FigureCanvasAgg
    from matplotlib.figure import Figure

    if layout not in LAYOUTS:
        raise ValueError(f"layout must be one of {LAYOUTS}, got {layout!r}")
    s = check_structure(structure)
    check_drawable(s)
    force = check_flag(force, "force")
    check_output_file(path, force=force, what=what)  # before drawing
    w, h = top_view_inches(s)
    if task is None:
        fig = Figure(figsize=(w + 2.8, h + 0.8), layout="constrained")  # legend, axis labels
        FigureCanvasAgg(fig)
        draw_structure(s, ax=fig.add_subplot(1, 1, 1))
        save_figure(fig, os.fspath(check_output_file(path, force=force, what=what)), dpi=dpi)
        return os.fspath(path)
    fig, cells = _figure_with_task(w, h, layout)
    FigureCanvasAgg(fig)
    (parent, cell), *projections = cells
    top = draw_structure(s, ax=parent.add_subplot(cell))
    top.set_anchor("N")  # a wide structure's top view under its title, x label in the figure
    for space, (parent, cell) in zip(("force", "torque"), projections, strict=True):
        ax = parent.add_subplot(cell, projection="3d")
        draw_projection(s, space, ax=ax, task=task)
        ax.set_anchor("N")
    width = min(TITLE_WIDTH, int(TITLE_WIDTH * fig.get_figwidth() / 15))
    fig.suptitle(figure_title(getattr(task, "name", None), width))
    save_figure(fig, os.fspath(check_output_file(path, force=force, what=what)), dpi=dpi)
    return os.fspath(path)
