"""An interactive page of a structure: one self-contained HTML file (plotly, its JavaScript inline,
nothing fetched from the network) with three 3-D views to turn and zoom:

* the structure: module boxes (filled as in the top view: the first module green, or by type
  with the first module outlined), rotors (coloured by spin) and cones along the
  rotors' thrust directions, in {S} (metres, origin at the COM);
* the feasible forces and the feasible torques: the projections of the 6-D feasible set onto
  force and torque space (:mod:`modquad_gym.viz.zonotope`), with the task's wrenches, green where
  the structure can exert the whole 6-D wrench and red where not (a red point may lie inside a
  projection: it fails in the other three coordinates).

Plotly is imported only here (the ``viz`` extra).
"""

from __future__ import annotations

import base64
import gzip
import html
import json
import os
from functools import lru_cache

import numpy as np

from modquad_gym.core.extras import import_optional
from modquad_gym.core.outputs import check_output_file, write_text
from modquad_gym.geometry.structure import Structure
from modquad_gym.viz.raster import FIRST_COLOUR, SPIN_COLOURS, check_structure, module_fill
from modquad_gym.viz.zonotope import (
    FEASIBLE_COLOUR,
    INFEASIBLE_COLOUR,
    SPACES,
    drawn_vertices,
    hull_faces,
    marked_up,
    task_wrenches,
    units,
)

_BOX = np.array([[x, y, z] for z in (-1, 1) for y in (-1, 1) for x in (-1, 1)], dtype=float)
_BOX_TRIANGLES = np.array([
    [0, 1, 3], [0, 3, 2], [4, 6, 7], [4, 7, 5], [0, 4, 5], [0, 5, 1],
    [2, 3, 7], [2, 7, 6], [0, 2, 6], [0, 6, 4], [1, 5, 7], [1, 7, 3],
])  # fmt: skip
_THICKNESS = 0.05  # module box height in metres, as in the MuJoCo model

DIGITS = 4
"""Decimals of the coordinates written into the page (a tenth of a millimetre of a structure
in metres; far below a pixel of the views, and short in the page's JSON)."""


def _rounded(a) -> list:
    """Coordinates as a short list of floats (plotly writes numpy arrays as float64 base64)."""
    return np.round(np.asarray(a, dtype=float), DIGITS).tolist()


def structure_traces(structure: Structure) -> list:
    """Plotly traces of the structure in {S}: module boxes (filled as in the top view,
    :func:`~modquad_gym.viz.raster.module_fill`: the first module green, or with several types
    each type's fill and the first module outlined), rotors, thrust-direction cones. Hover text
    numbers modules and rotors from 1, as the command line's words do."""
    go = import_optional("plotly.graph_objects")

    s = check_structure(structure)
    traces = _module_traces(go, s)
    P, D = s.rotor_positions, s.rotor_directions
    owner = np.repeat(np.arange(s.n_modules), [m.n_rotors for m in s.modules])
    lift = _THICKNESS / 2
    for spin in (1.0, -1.0):
        k = np.flatnonzero(s.rotor_spins == spin)
        if not len(k):
            continue
        text = [f"rotor {j + 1} (module {owner[j] + 1}): spin {spin:+.0f}, thrust "
                f"{np.round(D[j], 2).tolist()}" for j in k]  # fmt: skip
        traces.append(go.Scatter3d(
            x=_rounded(P[k, 0]), y=_rounded(P[k, 1]), z=_rounded(P[k, 2] + lift),
            mode="markers", text=text, hoverinfo="text",
            marker={"size": 6, "color": SPIN_COLOURS[spin]}, name=f"rotor, spin {spin:+.0f}",
        ))  # fmt: skip
    length = 0.4 * s.side
    traces.append(go.Cone(
        x=_rounded(P[:, 0]), y=_rounded(P[:, 1]), z=_rounded(P[:, 2] + lift),
        u=_rounded(D[:, 0] * length), v=_rounded(D[:, 1] * length), w=_rounded(D[:, 2] * length),
        anchor="tail", sizemode="raw", sizeref=0.35, showscale=False,
        colorscale=[[0, "#8b1a1a"], [1, "#8b1a1a"]], name="thrust direction",
        hoverinfo="name", showlegend=True,
    ))  # fmt: skip
    traces.append(go.Scatter3d(
        x=[0.0], y=[0.0], z=[0.0], mode="markers", marker={"size": 5, "color": "black",
        "symbol": "cross"}, name="COM (origin of {S})",
    ))  # fmt: skip
    return traces


def _module_traces(go, s: Structure) -> list:
    """One box mesh per fill (one box geometry repeated), named in the legend, and with
    several types the first module's outline."""
    traces = []
    half = np.array([s.side / 2 * 0.97, s.side / 2 * 0.97, _THICKNESS / 2])
    fills = [module_fill(s, i) for i in range(s.n_modules)]
    for fill in dict.fromkeys(fills):
        idx = np.flatnonzero(np.asarray(fills) == fill)
        V = (s.module_centres[idx, None, :] + _BOX * half).reshape(-1, 3)
        F = (_BOX_TRIANGLES[None] + len(_BOX) * np.arange(len(idx))[:, None, None]).reshape(-1, 3)
        text = [f"module {i + 1} ({s.modules[i].name}), cell {tuple(s.cells[i])}"
                for i in idx for _ in _BOX]  # fmt: skip
        name = f"module {s.modules[idx[0]].name}" if s.is_mixed else (
            "first module" if fill == FIRST_COLOUR else "module")  # fmt: skip
        traces.append(go.Mesh3d(
            x=_rounded(V[:, 0]), y=_rounded(V[:, 1]), z=_rounded(V[:, 2]), i=F[:, 0], j=F[:, 1],
            k=F[:, 2], color=fill, opacity=0.55, flatshading=True, text=text,
            hoverinfo="text", name=name, showlegend=s.is_mixed or s.n_modules > 1,
        ))  # fmt: skip
    if s.is_mixed:  # the top view's thick outline of the first module
        c = s.module_centres[0]
        ring = np.array([[-1, -1], [1, -1], [1, 1], [-1, 1], [-1, -1]]) * half[:2] + c[:2]
        traces.append(go.Scatter3d(
            x=_rounded(ring[:, 0]), y=_rounded(ring[:, 1]), z=[c[2] + half[2]] * len(ring),
            mode="lines", line={"color": "#3a3a3a", "width": 8}, hoverinfo="skip",
            name="first module (thick outline)",
        ))  # fmt: skip
    return traces


def projection_traces(structure: Structure, space: str, task=None, f_max: float = 1.0) -> list:
    """Plotly traces of the feasible set's projection onto ``space`` ("force" or "torque") and
    of the task's wrenches there, coloured by their 6-D feasibility."""
    go = import_optional("plotly.graph_objects")

    s = check_structure(structure)
    first, names = SPACES[space]
    f_max = float(getattr(task, "f_max", f_max))
    V, exact = drawn_vertices(s.configuration_matrix(), space, f_max)  # sampled past 8 modules
    faces = hull_faces(V)
    traces = []
    if faces is not None:
        traces.append(go.Mesh3d(
            x=_rounded(V[:, 0]), y=_rounded(V[:, 1]), z=_rounded(V[:, 2]), i=faces[:, 0],
            j=faces[:, 1], k=faces[:, 2],
            color="#4c72b0", opacity=0.25, name=f"feasible {space}s (projection)",
            hoverinfo="name", showlegend=False,
        ))  # fmt: skip
    if exact or faces is None:  # sampled vertices mark nothing a reader needs
        traces.append(go.Scatter3d(
            x=_rounded(V[:, 0]), y=_rounded(V[:, 1]), z=_rounded(V[:, 2]), mode="markers",
            marker={"size": 2, "color": "#2b4570"}, name=f"vertices of the {space} projection",
            hoverinfo="skip", showlegend=False,
        ))  # fmt: skip
    if task is not None:
        W, ok, _ = task_wrenches(s, task)
        for mask, colour, label in ((ok, FEASIBLE_COLOUR, "feasible"),
                                    (~ok, INFEASIBLE_COLOUR, "infeasible")):  # fmt: skip
            idx = np.flatnonzero(mask)
            if not len(idx):
                continue
            Q = W[idx, first : first + 3]
            text = [f"wrench {i + 1}: {np.round(W[i], 4).tolist()} ({label} in 6-D)" for i in idx]
            traces.append(go.Scatter3d(
                x=_rounded(Q[:, 0]), y=_rounded(Q[:, 1]), z=_rounded(Q[:, 2]), mode="markers",
                text=text, hoverinfo="text",
                marker={"size": 4, "color": colour}, name=f"task wrench, {label} (6-D)",
                legendgroup=label, showlegend=space == "force",
            ))  # fmt: skip
    return traces


def structure_figure(structure: Structure, task=None, f_max: float = 1.0):
    """A plotly figure: the structure, and its feasible forces and torques with the task."""
    make_subplots = import_optional("plotly.subplots").make_subplots

    s = check_structure(structure)
    f_max = float(getattr(task, "f_max", f_max))
    force_unit, torque_unit = (marked_up(u, "html") for u in units(task, f_max))
    fig = make_subplots(
        rows=1, cols=3, specs=[[{"type": "scene"}] * 3], horizontal_spacing=0.02,
        subplot_titles=(
            f"structure: {s.n_modules} modules, {s.mass:g} kg (metres, {{S}})",
            f"feasible forces [{force_unit}]: projection of the 6-D set",
            f"feasible torques [{torque_unit}]: projection of the 6-D set",
        ),
    )  # fmt: skip
    for trace in structure_traces(s):
        fig.add_trace(trace, row=1, col=1)
    for col, space in ((2, "force"), (3, "torque")):
        for trace in projection_traces(s, space, task, f_max):
            fig.add_trace(trace, row=1, col=col)
    axes = {space: tuple(f"{'f' if space == 'force' else 'τ'}<sub>{a}</sub>" for a in "xyz")
            for space in ("force", "torque")}  # fmt: skip
    fig.update_layout(
        scene=_structure_scene(s),
        scene2=_projection_scene(axes["force"], force_unit),
        scene3=_projection_scene(axes["torque"], torque_unit),
        legend={"orientation": "h", "y": -0.05},
        margin={"l": 10, "r": 10, "t": 60, "b": 10}, height=620,
    )  # fmt: skip
    return fig


PROJECTION_EYE = {"x": 1.7, "y": -1.7, "z": 1.1}
"""Camera of the projection views, drawn as cubes (a tall force projection would squeeze its
x and y ticks together): far enough that the axis titles stay inside a third of the page
(plotly's default eye, 1.25 on each axis, clips them)."""


def _projection_scene(names: tuple[str, str, str], unit: str) -> dict:
    """Axes of a projection view: titled with units, at most :data:`PROJECTION_TICKS` ticks
    each (plotly's own choice of nine ran into each other), seen from :data:`PROJECTION_EYE`."""
    axes = {f"{a}axis": {"title": f"{n} [{unit}]", "nticks": PROJECTION_TICKS}
            for a, n in zip("xyz", names)}  # fmt: skip
    return {**axes, "aspectmode": "cube", "camera": {"eye": PROJECTION_EYE}}


PROJECTION_TICKS = 6
"""Most ticks on an axis of a projection view."""


TICKS_PER_VIEW = 7
"""Most ticks along the longest axis of the structure view; a shorter axis gets fewer, in
proportion to its drawn length (plotly's 3-D axes choose ticks by range, not length, and a
10 m x 3.6 m structure's y labels ran into each other)."""


def _ticks(ratio: float) -> int:
    """Most ticks of a structure-view axis drawn ``ratio`` times the longest one's length."""
    return max(2, round(TICKS_PER_VIEW * float(ratio)))


def _structure_scene(s: Structure) -> dict:
    """Axes of the structure view: metres, equal scales, a little room above and below."""
    lo = s.module_centres.min(axis=0) - s.side
    hi = s.module_centres.max(axis=0) + s.side
    lo[2], hi[2] = -s.side, s.side
    ratio = (hi - lo) / (hi - lo).max()
    axes = {
        f"{a}axis": {"range": [lo[i], hi[i]], "title": f"{a} [m]", "nticks": _ticks(ratio[i])}
        for i, a in enumerate("xyz")
    }
    return {
        "aspectmode": "manual",
        "aspectratio": dict(zip("xyz", ratio)),
        **axes,
        "camera": {"eye": {"x": 1.1, "y": -1.6, "z": 1.1}},  # the axis titles inside the view
    }


KIND_NOTES = {
    "external": " The task is external: the points are its wrenches plus the structure's weight.",
    "dynamic": " The task is dynamic: the points are the wrenches along its trajectory for this "
    "structure's mass and inertia.",
}
"""What the page adds about the points of a task of each kind (a total task: nothing)."""


def structure_page(structure: Structure, task=None, f_max: float = 1.0) -> str:
    """The self-contained HTML page of :func:`structure_figure` with a short explanation."""
    s = check_structure(structure)
    fig = structure_figure(s, task, f_max)
    name = getattr(task, "name", None)
    title = f"modquad_gym: {s.n_modules}-module structure" + (f" for task {name}" if name else "")
    note = (
        "Drag to turn a view, scroll to zoom, hover for values. The feasible set of wrenches "
        "[f; τ] is 6-dimensional: the middle and right views are its projections onto force and "
        "torque space. A task wrench is green when the structure can exert the whole 6-D wrench "
        "and red when not, so a red point may lie inside both projections."
    )
    note += KIND_NOTES.get(getattr(task, "kind", "total"), "")
    body = _plot_html(fig, config={"displaylogo": False, "responsive": True})
    cells = html.escape(", ".join(f"({x}, {y})" for x, y in s.cells))
    types = html.escape(", ".join(m.name for m in s.modules))
    return (
        '<!DOCTYPE html>\n<html lang="en">\n<head>\n<meta charset="utf-8">\n'
        f'<title>{html.escape(title)}</title>\n</head>\n<body style="font-family: sans-serif">\n'
        f"<h2>{html.escape(title)}</h2>\n<p>{html.escape(structure_summary(s))}</p>\n"
        f"<details><summary>cells and module types, in order</summary>\n<p>cells {cells}</p>\n"
        f"<p>types {types}</p>\n</details>\n<p>{html.escape(note)}</p>\n{body}\n</body>\n</html>\n"
    )


_LOADER = """<div id="figure" style="height: {height}px; width: 100%"></div>
<script type="application/json" id="figure-data">{figure}</script>
<script>
(async () => {{
  const packed = Uint8Array.from(atob("{packed}"), (c) => c.charCodeAt(0));
  const stream = new Blob([packed]).stream().pipeThrough(new DecompressionStream("gzip"));
  const plotly = document.createElement("script");
  plotly.text = await new Response(stream).text();
  document.head.appendChild(plotly);
  const fig = JSON.parse(document.getElementById("figure-data").textContent);
  const box = document.getElementById("figure");
  const fit = () => {{  // the box's height from its width; the views fill the box
    const height = Math.min({height}, Math.max({least}, {per_width} * box.clientWidth + {margins}));
    box.style.height = Math.round(height) + "px";
  }};
  fit();
  delete fig.layout.height;
  await Plotly.newPlot(box, fig.data, fig.layout, {config});
  window.addEventListener("resize", () => {{ fit(); Plotly.Plots.resize(box); }});
}})();
</script>"""

HEIGHT_PER_WIDTH = 0.31
"""Height of the views' row per pixel of the page's width: a 3-D view fills its height, so one
taller than its third of the width is cut at the sides (the z axis titles at 1400 px, whole
views at 1000 px); the page sets its height from its width, at load and on resizing."""

LEAST_HEIGHT = 320
"""Least height in pixels of the views (a narrow window scrolls rather than shrink them more)."""


@lru_cache(maxsize=1)
def _packed_plotlyjs() -> str:
    """plotly.js, gzipped and base64-encoded: 1.96 MB instead of 4.8 MB in the page."""
    get_plotlyjs = import_optional("plotly.offline").get_plotlyjs

    return base64.b64encode(gzip.compress(get_plotlyjs().encode(), 9, mtime=0)).decode()


def _plot_html(fig, config: dict) -> str:
    """The figure and plotly.js in one block of HTML: plotly.js travels gzipped and the
    browser unpacks it (``DecompressionStream``, in every current browser), so the page stays
    self-contained at less than half the size of plotly's own inline copy. The views' height
    follows the page's width (:data:`HEIGHT_PER_WIDTH`), at most the figure's own."""
    figure = fig.to_json().replace("</", "<\\/")  # nothing in the data closes the <script>
    height = fig.layout.height or 620
    margins = fig.layout.margin.t + fig.layout.margin.b
    return _LOADER.format(
        height=height, least=LEAST_HEIGHT, per_width=HEIGHT_PER_WIDTH, margins=margins,
        figure=figure, packed=_packed_plotlyjs(), config=json.dumps(config),
    )  # fmt: skip


def structure_summary(structure: Structure) -> str:
    """One line about a structure: module count, types with counts, mass and bounding box
    (the cells themselves are long at 64 modules: the page folds them away)."""
    from collections import Counter

    s = check_structure(structure)
    counts = Counter(m.name for m in s.modules)
    types = ", ".join(f"{n} x {name}" for name, n in counts.items())
    cells = np.asarray(s.cells)
    nx, ny = cells.max(axis=0) - cells.min(axis=0) + 1
    return (
        f"{s.n_modules} module{'s' if s.n_modules > 1 else ''} ({types}), {s.mass:g} kg; "
        f"bounding box {nx} x {ny} cells ({nx * s.side:g} m x {ny * s.side:g} m)"
    )


def save_structure_page(
    structure: Structure, path: str | os.PathLike, task=None, force: bool = False, *,
    what: str = "path",
) -> str:  # fmt: skip
    """Write :func:`structure_page` to ``path`` (an existing file only with ``force``; ``what``
    names ``path`` in that refusal: a command's option gets the advice ``--force``)."""
    text = structure_page(structure, task)
    path = check_output_file(path, force=force, what=what)
    write_text(path, text)
    return os.fspath(path)
