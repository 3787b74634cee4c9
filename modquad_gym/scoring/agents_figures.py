"""The agent benchmark's figures: summary bars, the learning curve, example structures."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from modquad_gym.core.outputs import save_figure
from modquad_gym.scoring.scores import Row


def _new_figure(w: float, h: float):
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=(w, h), layout="constrained")
    FigureCanvasAgg(fig)
    return fig


def short(method: str) -> str:
    """A method's label in a figure: an outside agent ``package.module:Name`` as ``Name``."""
    return method.rpartition(":")[2]


def colour(method: str) -> str:
    """Outside agents orange, the learned methods blue, the searches grey."""
    if ":" in method:
        return "#dd8452"
    return "#4c72b0" if method.startswith("ppo") else "#999999"


def plot_bars(summary: list[dict], path: Path) -> Path:
    """Success, optimal share, configurations and seconds per task of every method."""
    fig = _new_figure(max(13, 1.2 * len(summary) * 4 / 3), 3.6)
    names = [short(s["method"]) for s in summary]
    panels = [
        ("success_rate", "success rate", False), ("optimal_share", "optimal module count", False),
        ("mean_evaluated", "configurations evaluated / task", True),
        ("mean_seconds", "seconds / task", True),
    ]  # fmt: skip
    for i, (key, label, log) in enumerate(panels):
        ax = fig.add_subplot(1, 4, i + 1)
        vals = [s[key] for s in summary]
        ax.bar(range(len(names)), vals, color=[colour(s["method"]) for s in summary])
        ax.set_xticks(range(len(names)), names, rotation=45, ha="right", rotation_mode="anchor")
        ax.set_title(label)
        if log:
            ax.set_yscale("log")
        else:
            ax.set_ylim(0, 1.05)
    save_figure(fig, path, dpi=110)
    return path


def plot_learning_curve(evals: Path, path: Path) -> Path | None:
    """Validation return and success rate over PPO steps (step 0: the cloned policy, when the
    run cloned an expert first)."""
    if not evals.is_file():
        return None
    from matplotlib.ticker import FuncFormatter

    data = np.load(evals)
    steps = data["timesteps"]
    thousands = FuncFormatter(lambda x, _: f"{x / 1000:g}k")
    fig = _new_figure(9, 3.4)
    ax = fig.add_subplot(1, 2, 1)
    mean, std = data["results"].mean(axis=1), data["results"].std(axis=1)
    ax.plot(steps, mean, marker="o")
    ax.fill_between(steps, mean - std, mean + std, alpha=0.2)
    ax.set_title("validation return (mean ± std over tasks)")
    ax = fig.add_subplot(1, 2, 2)
    if "successes" in data and data["successes"].size:
        ax.plot(steps, data["successes"].mean(axis=1), marker="o", color="#2a9d8f")
    ax.set_ylim(0, 1.05)
    ax.set_title("validation success rate")
    for ax in fig.axes:
        ax.xaxis.set_major_formatter(thousands)
        ax.set_xlabel("PPO steps (0: before PPO)")
    save_figure(fig, path, dpi=110)
    return path


def plot_structures(rows: list[Row], path: Path, n_tasks: int = 4) -> Path | None:
    """A few tasks, one row each: every outside agent and learned method scored (``ppo`` and
    its variants, at most three of them) beside the exhaustive and centrosymmetric searches.
    Tasks where every method answered come first; a method without an answer on a task says
    so in its panel."""
    from modquad_gym.geometry.structure import Structure
    from modquad_gym.viz.drawing import draw_structure

    scored = list(dict.fromkeys(r.method for r in rows))
    outside = [m for m in scored if ":" in m]
    learned = [m for m in scored if m.startswith("ppo")][: max(1, 3 - len(outside))]
    methods = [*outside, *learned, *(m for m in ("exhaustive", "centrosymmetric") if m in scored)]
    if not methods:
        return None
    by = {(r.suite, r.task, r.method): r for r in rows}
    tasks = list(dict.fromkeys((r.suite, r.task) for r in rows))

    def answered(t, ms) -> bool:
        return all(by[(*t, m)].success for m in ms if (*t, m) in by)

    # prefer tasks where all methods succeeded, spread over the suites; then any task the
    # reference (the exhaustive search, else the first method) answered
    reference = ["exhaustive"] if "exhaustive" in methods else methods[:1]
    picked = []
    for good in (
        [t for t in tasks if answered(t, methods)],
        [t for t in tasks if answered(t, reference)],
    ):
        for suite in dict.fromkeys(s for s, _ in good):
            picked += [t for t in good if t[0] == suite and t not in picked][: max(1, n_tasks // 2)]
    picked = picked[:n_tasks]
    if not picked:
        return None
    fig = _new_figure(3.2 * len(methods), 3.2 * len(picked))
    for i, key in enumerate(picked):
        for j, m in enumerate(methods):
            ax = fig.add_subplot(len(picked), len(methods), i * len(methods) + j + 1)
            r = by.get((*key, m))
            if r is None or not r.success:
                ax.text(0.5, 0.5, "no answer", ha="center", va="center", transform=ax.transAxes)
                ax.set_title(f"{short(m)}: - (opt {r.optimum if r else '-'})\n{key[1]}")
                ax.set_axis_off()
                continue
            s = Structure([tuple(c) for c in r.cells])
            draw_structure(s, ax=ax, title=f"{short(m)}: {r.n_modules} (opt {r.optimum})\n{key[1]}")
            if ax.get_legend() is not None:
                ax.get_legend().remove()
    save_figure(fig, path, dpi=90)
    return path
