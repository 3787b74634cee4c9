"""The leaderboard's figures (:mod:`benchmarks.leaderboard_entries` reads the data): optimal share
against seconds per task, each label joined to its point, and the share of tasks answered
optimally within a time budget, against the budget."""

from __future__ import annotations

import math
from pathlib import Path

COLOURS = {"search": "#555555", "learned": "#4c72b0", "outside": "#dd8452"}
MARKERS = {"search": "o", "learned": "s", "outside": "D"}
KIND_NAMES = {"search": "search (one run)",
              "learned": "learned (mean of 5 seeds, 95 % interval)",
              "outside": "outside agent"}  # fmt: skip


def _panels(n: int):
    """A figure of ``n`` tier panels and one more for the legend (two columns)."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    cols = 2
    rows = -(-(n + 1) // cols)
    fig = Figure(figsize=(6.4 * cols, 4.4 * rows), layout="constrained")
    FigureCanvasAgg(fig)
    axes = [fig.add_subplot(rows, cols, i + 1) for i in range(rows * cols)]
    for ax in axes[n + 1 :]:
        ax.set_visible(False)
    return fig, axes[:n], axes[n]


CROSSING = 5
"""What a leader line crossing one placed before costs a label's place: more than an overlap
(1), less than leaving the axes (10)."""


NEARER = 0.5
"""What a label costs whose centre lies nearer another point than its own (a reader pairs it
with that point): less than an overlap, so that it only breaks ties."""


def _crosses(a: tuple, b: tuple) -> bool:
    """Whether the segments ``a`` and ``b`` ((x, y) ends, display coordinates) cross: each
    one's ends strictly on both sides of the other's line."""

    def side(p, q, r) -> float:
        return (q[0] - p[0]) * (r[1] - p[1]) - (q[1] - p[1]) * (r[0] - p[0])

    (p, q), (r, t) = a, b
    return side(p, q, r) * side(p, q, t) < 0 and side(r, t, p) * side(r, t, q) < 0


def _passes_over(line: tuple, dot, reach: float = 8.0) -> bool:
    """Whether the segment ``line`` passes within ``reach`` pixels of ``dot`` (not its ends)."""
    (x0, y0), (x1, y1) = line
    dx, dy = x1 - x0, y1 - y0
    length2 = dx * dx + dy * dy
    if length2 == 0:
        return False
    u = ((dot[0] - x0) * dx + (dot[1] - y0) * dy) / length2
    if not 0.0 < u < 1.0:
        return False
    return math.hypot(x0 + u * dx - dot[0], y0 + u * dy - dot[1]) <= reach


def _place_labels(ax, points: list[tuple[float, float, str, str]]) -> None:
    """Each label beside its point, joined to it by a thin line, at the nearest of a few offsets
    where it stays inside the axes and overlaps no label placed before and no point, and its
    line crosses no line placed before (:data:`CROSSING`) nor passes over another point, and it
    lies nearer its own point than any other (:data:`NEARER`; the figure's layout must be
    final: display coordinates are compared)."""
    from matplotlib.text import Text

    renderer = ax.figure.canvas.get_renderer()
    frame = ax.get_window_extent(renderer)
    dots = [tuple(ax.transData.transform((x, y))) for x, y, _, _ in points]
    placed, lines = [], []
    offsets = [(10, 8), (10, -14), (-10, 8), (-10, -14), (14, 22), (14, -28), (-14, 22),
               (-14, -28), (24, 0), (-24, 0), (30, 38), (30, -42), (-30, 38), (-30, -42),
               (40, 56), (40, -60), (-40, 56), (-40, -60)]  # fmt: skip
    for x, y, text, colour in sorted(points, key=lambda p: (-p[1], p[0])):
        dot = tuple(ax.transData.transform((x, y)))
        best = None
        for dx, dy in offsets:
            ann = ax.annotate(text, (x, y), textcoords="offset points", xytext=(dx, dy),
                              ha="left" if dx > 0 else "right", va="center", fontsize=8,
                              color=colour,
                              arrowprops=dict(arrowstyle="-", color=colour, lw=0.6,
                                              shrinkA=0, shrinkB=3))  # fmt: skip
            ann.update_positions(renderer)
            box = Text.get_window_extent(ann, renderer).expanded(1.05, 1.15)  # no arrow
            line = (dot, ((box.x0 + box.x1) / 2, (box.y0 + box.y1) / 2))
            clash = sum(box.overlaps(b) for b in placed) + sum(
                box.contains(px, py) for px, py in dots
            )
            clash += CROSSING * sum(_crosses(line, other) for other in lines)
            clash += sum(_passes_over(line, d) for d in dots if d != dot)
            near = math.dist(line[1], dot)
            clash += NEARER * any(math.dist(line[1], d) < near for d in dots if d != dot)
            inside = frame.x0 <= box.x0 and box.x1 <= frame.x1 and frame.y0 <= box.y0 <= frame.y1
            clash += 0 if inside and box.y1 <= frame.y1 else 10
            if best is None or clash < best[0]:
                if best is not None:
                    best[1].remove()
                best = (clash, ann, box, line)
            else:
                ann.remove()
            if clash == 0:
                break
        placed.append(best[2])
        lines.append(best[3])


def plot(entries: list, tiers: list[str], path: Path) -> Path:
    """Per tier: optimal share against seconds per task (log), learned methods with their 95 %
    intervals over seeds; each label joined to its point; a legend of the kinds."""
    from matplotlib.lines import Line2D

    from modquad_gym.core.outputs import save_figure

    fig, axes, legend_ax = _panels(len(tiers))
    labels = []
    for ax, t in zip(axes, tiers):
        mine = [e for e in entries if e.tier == t and not e.status]
        points = []
        for e in mine:
            x, y = e.seconds[0], 100 * e.optimal[0]
            xerr = [[x - e.seconds[1]], [e.seconds[2] - x]]
            yerr = [[y - 100 * e.optimal[1]], [100 * e.optimal[2] - y]]
            ax.errorbar(x, y, xerr=xerr, yerr=yerr, fmt=MARKERS[e.kind], color=COLOURS[e.kind],
                        ms=5, capsize=2, lw=0.8)  # fmt: skip
            points.append((x, y, e.method.rpartition(":")[2], COLOURS[e.kind]))
        ax.set_xscale("log")
        lo = min(e.seconds[1] for e in mine)
        hi = max(e.seconds[2] for e in mine)
        ax.set_xlim(lo / 3, hi * 3)
        ax.set_ylim(-5, 112)
        ax.set_title(f"tier {t}")
        ax.set_xlabel("seconds per task (log scale)")
        ax.set_ylabel("optimal module count (% of tasks)")
        ax.grid(alpha=0.3)
        labels.append((ax, points))
    handles = [Line2D([], [], ls="", marker=MARKERS[k], color=COLOURS[k], label=KIND_NAMES[k])
               for k in COLOURS if any(e.kind == k for e in entries)]  # fmt: skip
    legend_ax.axis("off")
    legend_ax.legend(handles=handles, loc="center", title="method kind", frameon=False)
    fig.canvas.draw()  # the layout, final before the labels are placed in display coordinates
    fig.set_layout_engine("none")
    for ax, points in labels:
        _place_labels(ax, points)
    return save_figure(fig, path, dpi=100)


def _style(method: str) -> str:
    """Line style of a curve: the anytime history dashed, learned methods dash-dotted."""
    return "--" if "history" in method else "-." if method.startswith("ppo") else "-"


def plot_curves(series: dict[str, list[tuple[str, list[float]]]], budget: float,
                path: Path) -> Path:  # fmt: skip
    """Per tier (``series``: tier -> (method, sorted seconds at which each task was answered
    optimally, inf for never)), the share of tasks answered with the optimal count within t
    seconds, against t (log); the budget as a vertical line."""
    from matplotlib import colormaps
    from matplotlib.lines import Line2D

    from modquad_gym.core.outputs import save_figure

    fig, axes, legend_ax = _panels(len(series))
    colours: dict[str, tuple] = {}
    palette = colormaps["tab20"]
    for ax, (name, lines) in zip(axes, series.items()):
        for method, times in lines:
            k = len(colours) % 20  # the ten dark colours first, then their light pairs
            colour = colours.setdefault(method, palette(2 * k % 20 + (k >= 10)))
            n = len(times)
            finite = [t for t in times if math.isfinite(t)]
            xs = [1e-3, *finite, 1e3]
            ys = [0.0, *[100 * (i + 1) / n for i in range(len(finite))], 100 * len(finite) / n]
            style = _style(method)
            ax.step(xs, ys, where="post", color=colour, lw=1.3, ls=style)
        ax.axvline(budget, color="k", lw=0.8, ls=":")
        ax.set_xscale("log")
        ax.set_xlim(1e-3, 1e2)
        ax.set_ylim(-3, 103)
        ax.set_title(f"tier {name}")
        ax.set_xlabel("time budget per task, seconds (log scale)")
        ax.set_ylabel("answered optimally within it (% of tasks)")
        ax.grid(alpha=0.3)
    handles = [Line2D([], [], color=c, lw=1.5, ls=_style(m), label=m)
               for m, c in colours.items()]  # fmt: skip
    handles.append(Line2D([], [], color="k", lw=0.8, ls=":", label=f"budget {budget:g} s"))
    legend_ax.axis("off")
    legend_ax.legend(handles=handles, loc="center", ncols=2, frameon=False, fontsize=9)
    return save_figure(fig, path, dpi=100)


if __name__ == "__main__":
    from benchmarks.common import refuse_as_script

    raise SystemExit(refuse_as_script("leaderboard_figures"))
