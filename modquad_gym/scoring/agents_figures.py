"""The agent benchmark's figures: summary bars, the learning curve, example structures."""

from __future__ import annotations

from pathlib import Path

from modquad_gym.core.outputs import save_figure
from modquad_gym.scoring.fine_tuning import read_evaluations
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


KINDS = {"#999999": "search", "#4c72b0": "learned (ppo and variants)", "#dd8452": "outside agent"}
"""The bar colours of :func:`colour` and what they mean (the figures' legend)."""


def plot_bars(summary: list[dict], path: Path) -> Path:
    """Success, optimal share, configurations and seconds per task of every method (means
    over the tier's tasks), coloured by kind with a legend."""
    from matplotlib.patches import Patch

    fig = _new_figure(max(13, 1.2 * len(summary) * 4 / 3), 4.0)
    names = [short(s["method"]) for s in summary]
    n = summary[0]["tasks"] if summary else 0
    panels = [
        ("success_rate", "success rate", "tasks solved (%)", False),
        ("optimal_share", "optimal module count", "tasks solved with the optimum (%)", False),
        ("mean_evaluated", "configurations evaluated", "mean per task (log scale)", True),
        ("mean_seconds", "wall time", "mean seconds per task (log scale)", True),
    ]  # fmt: skip
    colours = [colour(s["method"]) for s in summary]
    for i, (key, title, ylabel, log) in enumerate(panels):
        ax = fig.add_subplot(1, 4, i + 1)
        vals = [s[key] * (1 if log else 100) for s in summary]
        ax.bar(range(len(names)), vals, color=colours)
        ax.set_xticks(range(len(names)), names, rotation=45, ha="right", rotation_mode="anchor")
        ax.set_title(title)
        ax.set_ylabel(ylabel)
        if log:
            ax.set_yscale("log")
        else:
            ax.set_ylim(0, 105)
        ax.grid(axis="y", alpha=0.3)
    kinds = [Patch(color=c, label=label) for c, label in KINDS.items() if c in colours]
    fig.legend(handles=kinds, loc="outside lower center", ncols=len(kinds), frameon=False,
               title=f"{n} held-out tasks per method; bars: means over the tasks")  # fmt: skip
    save_figure(fig, path, dpi=110)
    return path


def plot_learning_curve(evals: Path, path: Path) -> Path | None:
    """Validation return and success rate (and optimal share, when recorded) over PPO steps
    (step 0: the cloned policy, when the run cloned an expert first). The success rate keeps
    its full 0-100 % axis; the return's axis is fitted to the data and the title says how much
    PPO changed either after step 0 (a policy cloned from an expert often starts near its final
    score)."""
    if not evals.is_file():
        return None
    from matplotlib.ticker import FuncFormatter

    data = read_evaluations(evals)
    steps = data["timesteps"]
    thousands = FuncFormatter(lambda x, _: f"{x / 1000:g}k")
    fig = _new_figure(10, 3.8)
    ax = fig.add_subplot(1, 2, 1)
    mean, std = data["results"].mean(axis=1), data["results"].std(axis=1)
    ax.plot(steps, mean, marker="o", label="mean over the validation tasks")
    ax.fill_between(steps, mean - std, mean + std, alpha=0.2, label="± one std over the tasks")
    ax.set_ylabel("episode return")
    change = float(mean[-1] - mean[0])
    ax.set_title(f"validation return\n{mean[0]:.2f} at step 0, {change:+.2f} by the end",
                 fontsize="medium")  # fmt: skip
    ax.legend(loc="lower right", fontsize="small")
    ax = fig.add_subplot(1, 2, 2)
    if "successes" in data and data["successes"].size:
        success = 100 * data["successes"].mean(axis=1)
        ax.plot(steps, success, marker="o", color="#2a9d8f", label="success")
        title = f"{success[0]:.1f} % at step 0, {success.min():.1f}-{success.max():.1f} %"
        head = "validation success"
        if "optimal" in data and data["optimal"].size:  # certified validation tasks
            optimal = 100 * data["optimal"].mean(axis=1)
            ax.plot(steps, optimal, marker="s", color="#e76f51", label="optimal")
            head = "validation tasks"
            title = (f"success {title}\noptimal {optimal[0]:.1f} % at step 0, "
                     f"{optimal.min():.1f}-{optimal.max():.1f} %")  # fmt: skip
            ax.legend(loc="lower right", fontsize="small")
        ax.set_title(f"{head}\n{title} over the run", fontsize="medium")
    else:
        ax.set_title("validation success rate (not recorded)")
    ax.set_ylim(0, 105)
    ax.set_ylabel("tasks solved (%)")
    for ax in fig.axes:
        ax.xaxis.set_major_formatter(thousands)
        ax.set_xlabel("PPO steps (0: before PPO)")
        ax.grid(alpha=0.3)
    save_figure(fig, path, dpi=110)
    return path


def row_structure(row: Row, modules=None):
    """The structure of ``row``'s answer: its cells, each of its type when the cells carry a
    type index ([x, y, k], k into ``modules``: the tier's palette of module types)."""
    from modquad_gym.geometry.structure import Structure

    cells = [tuple(c[:2]) for c in row.cells]
    if modules is None or not all(len(c) == 3 for c in row.cells):
        return Structure(cells)
    try:
        return Structure(cells, modules=[modules[int(c[2])] for c in row.cells])
    except IndexError:
        raise ValueError(f"{row.task}, {row.method}: a cell's type index is beyond the tier's "
                         f"{len(modules)} module types") from None  # fmt: skip


def cells_from_csv(text: str) -> list | None:
    """The cells of a ``benchmark.csv`` row (``x,y`` or ``x,y,k`` joined by ``;``, as
    :meth:`Row.as_csv` writes them); None when empty (no answer)."""
    if not text:
        return None
    return [[int(v) for v in cell.split(",")] for cell in text.split(";")]


def plot_structures(rows: list[Row], path: Path, n_tasks: int = 4, modules=None) -> Path | None:
    """A few tasks, one row each: every outside agent and learned method scored (``ppo`` and
    its variants, at most three of them) beside the exhaustive and centrosymmetric searches.
    Tasks where every method answered come first; a method without an answer on a task says
    so in its panel. ``modules``: the tier's palette; with several types each module is drawn
    as its type (its fill and thrust arrows) on every panel, or, where the rows' cells carry no
    type (a CSV of an older run), each answer's shape without thrust arrows, as the legend's
    title says. One legend under the panels explains the colours (spins, thrust arrows, COM,
    first module, the types)."""
    from modquad_gym.viz.drawing import draw_structure, legend_handles

    scored = list(dict.fromkeys(r.method for r in rows))
    outside = [m for m in scored if ":" in m]
    learned = [m for m in scored if m.startswith("ppo")][: max(1, 3 - len(outside))]
    methods = [*outside, *learned, *(m for m in ("exhaustive", "centrosymmetric") if m in scored)]
    if not methods:
        return None
    by = {(r.suite, r.task, r.method): r for r in rows}
    picked = _picked_tasks(rows, methods, by, n_tasks)
    if not picked:
        return None
    mixed = modules is not None and len(modules) > 1
    answers = [r for r in rows if r.success and r.cells]
    typed = mixed and all(len(c) == 3 for r in answers for c in r.cells)
    note = None
    if mixed and not typed:
        note = (f"module types ({', '.join(m.name for m in modules)}) not recorded in these "
                "rows: shapes only, without thrust arrows")  # fmt: skip
    fig = _new_figure(3.2 * len(methods), 3.2 * len(picked) + 0.6)
    for i, key in enumerate(picked):
        for j, m in enumerate(methods):
            ax = fig.add_subplot(len(picked), len(methods), i * len(methods) + j + 1)
            r = by.get((*key, m))
            if r is None or not r.success:
                ax.text(0.5, 0.5, "no answer", ha="center", va="center", transform=ax.transAxes)
                ax.set_title(f"{short(m)}: - (opt {r.optimum if r else '-'})\n{key[1]}")
                ax.set_axis_off()
                continue
            title = f"{short(m)}: {r.n_modules} (opt {r.optimum})\n{key[1]}"
            draw_structure(row_structure(r, modules if typed else None), ax=ax, title=title,
                           types=typed, legend=False, arrows=note is None)  # fmt: skip
    handles = legend_handles(list(modules) if typed else None, arrows=note is None)
    fig.legend(handles=handles, loc="outside lower center", ncols=min(len(handles), 8),
               fontsize="small", frameon=False, title=note, title_fontsize="small")  # fmt: skip
    save_figure(fig, path, dpi=90)
    return path


def _picked_tasks(rows: list[Row], methods: list[str], by: dict, n_tasks: int) -> list:
    """The (suite, task) pairs of :func:`plot_structures`: tasks where all methods succeeded,
    spread over the suites; then any task the reference (the exhaustive search, else the first
    method) answered."""
    tasks = list(dict.fromkeys((r.suite, r.task) for r in rows))

    def answered(t, ms) -> bool:
        return all(by[(*t, m)].success for m in ms if (*t, m) in by)

    reference = ["exhaustive"] if "exhaustive" in methods else methods[:1]
    picked = []
    for good in (
        [t for t in tasks if answered(t, methods)],
        [t for t in tasks if answered(t, reference)],
    ):
        for suite in dict.fromkeys(s for s, _ in good):
            picked += [t for t in good if t[0] == suite and t not in picked][: max(1, n_tasks // 2)]
    return picked[:n_tasks]
