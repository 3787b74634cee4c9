"""Heterogeneous-modules benchmark, the report: the figure of mixed against one-type optima and
the text of ``heterogeneous.md`` from the measured rows of :mod:`.heterogeneous_measure`.
"""

from __future__ import annotations

from pathlib import Path

from benchmarks.common import made_by, markdown_table
from benchmarks.heterogeneous_measure import EXTERNAL_F_MAX, PALETTE
from modquad_gym.geometry.module import STOCK_TYPES, palette
from modquad_gym.search import exhaustive_search


def figure(rows: list[dict], sets: dict, n_max: int, path: Path, k: int = 4) -> list[str]:
    """Mixed optimum beside the best one-type optimum for the ``k`` tasks where mixing saves
    the most (ties: task order); returns the captions."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    from modquad_gym.core.outputs import save_figure
    from modquad_gym.viz.drawing import draw_structure

    def gain(r):
        return r["saved"] if isinstance(r["saved"], int) else n_max + 1 - int(r["n_mixed"])

    chosen = sorted((r for r in rows if r["n_mixed"] != "none"), key=lambda r: -gain(r))[:k]
    fig = Figure(figsize=(12.5, 4.2 * max(len(chosen), 1)), layout="constrained")
    FigureCanvasAgg(fig)
    captions = []
    if not chosen:  # a figure of height 0 cannot be saved: say why it is empty
        ax = fig.add_subplot()
        ax.text(0.5, 0.5, f"no task is satisfied by a mix of up to {n_max} modules",
                ha="center", va="center")  # fmt: skip
        ax.set_axis_off()
    for i, r in enumerate(chosen):
        task = sets[r["workload"]][r["task"]]
        mixed = exhaustive_search(task, n_max=n_max, modules=palette(",".join(PALETTE)))
        draw_structure(
            mixed.structure,
            ax=fig.add_subplot(len(chosen), 2, 2 * i + 1),
            title=f"{r['workload']} #{r['task']}: mix, {mixed.n_modules} modules",
        )
        best = None
        for name in PALETTE:
            alone = exhaustive_search(task, n_max=n_max, modules=[STOCK_TYPES[name]])
            if alone.structure is not None and (best is None or alone.n_modules < best.n_modules):
                best = alone
        ax = fig.add_subplot(len(chosen), 2, 2 * i + 2)
        if best is None:
            ax.text(0.5, 0.5, f"no single type\nup to {n_max} modules", ha="center", va="center")
            ax.set_axis_off()
            captions.append(f"{r['workload']} #{r['task']}: mix {mixed.n_modules}, no type alone")
        else:
            name = best.structure.modules[0].name
            draw_structure(best.structure, ax=ax, title=f"best one type ({name}): "
                           f"{best.n_modules} modules")  # fmt: skip
            captions.append(
                f"{r['workload']} #{r['task']}: mix {mixed.n_modules}, {name} {best.n_modules}"
            )
    save_figure(fig, path, dpi=90)
    return captions


SAVINGS_COLUMNS = ("workload", "kind", "tasks", "mix_feasible", "best_type_feasible",
                   "mix_saves", "only_the_mix", "mean_saved", "max_saved", "pair_vs_t45_saves",
                   "mean_n_t45", "mean_n_best_type", "mean_n_mix")  # fmt: skip
COST_COLUMNS = ("workload", "median_s_t45", "median_s_pair", "median_s_mix", "max_s_mix",
                "median_eval_t45", "median_eval_pair", "median_eval_mix")  # fmt: skip


def _columns(rows: list[dict], keys: tuple[str, ...]) -> str:
    """A markdown table of ``keys`` of each row."""
    return markdown_table([{k: r[k] for k in keys} for r in rows])


def report(args, rows, summ, worst, sim, captions) -> str:
    """The text of ``heterogeneous.md`` (``args.command``: the command as run)."""
    lines = [
        "# Heterogeneous modules: mixing types, self-weight, search cost",
        "",
        made_by(args.command, "; one process") + " Per-task rows: `heterogeneous.csv`.",
        "",
        "Module types (`modquad_gym.geometry.module.STOCK_TYPES`, 0.3 kg each): `t45` the paper's "
        "T-module (eta = pi/4), `t45m` its mirrored tilts, `flat` an untilted quadrotor. "
        "The palette is {t45, t45m, flat}; the pair is {t45, t45m}. Every number is a "
        f"certified minimum of the exhaustive search with n_max = {args.n_max} "
        "(`none`: no structure of up to n_max modules).",
        "",
        "Task sets (each of `--tasks` tasks, 40 wrenches): `paper`: the paper's random wrenches "
        "(kind `total`, f_max = 1, `PaperTasks()`); `paper external`: the same generator with "
        f"f_z = 1 + 8 |u| N as wrenches on the environment (kind `external`, f_max = "
        f"{EXTERNAL_F_MAX:g} N: the rotors also lift 2.94 N per module); `planted` and "
        "`planted external`: wrenches inside a random mixed structure of 3-6 palette modules "
        "(its weight subtracted for `external`), so a mix of at most 6 modules works.",
        "",
        *_savings_section(summ, captions),
        *_cost_section(summ),
        *_worst_section(worst, args.n_max),
        *_mujoco_section(sim),
    ]
    return "\n".join(lines)


def _savings_section(summ: list[dict], captions: list[str]) -> list[str]:
    return [
        "## How often and by how much mixing saves modules",
        "",
        "`mix_saves`: tasks where the palette needs fewer modules than the best single type "
        "(including `only_the_mix`: no single type works up to n_max); `mean_saved`/"
        "`max_saved` over tasks where both work; `pair_vs_t45_saves`: tasks where {t45, t45m} "
        "beats t45 alone. By construction (and by a property test) the palette never needs "
        "more modules than its best type.",
        "",
        _columns(summ, SAVINGS_COLUMNS),
        "",
        "![mixed optima against the best single type](heterogeneous.png)",
        "",
        "Examples (left: the mixed optimum, modules filled by type; right: the best one-type "
        "optimum): " + "; ".join(captions) + ".",
        "",
    ]


def _cost_section(summ: list[dict]) -> list[str]:
    return [
        "## Search cost against the one-type search (same tasks)",
        "",
        "Median wall seconds and structures evaluated (LP-decided or rejected by a cached "
        "separating direction; pairs ruled out by the count and level bounds are not "
        "evaluated) per task, one-type (t45), 2-type and 3-type certified searches.",
        "",
        _columns(summ, COST_COLUMNS),
        "",
    ]


def _worst_section(worst: list[dict], n_max: int) -> list[str]:
    return [
        f"## Worst case: no structure of up to {n_max} modules (every level decided)",
        "",
        "A low-force task with the torques of a large hidden T-module structure (the force "
        "bounds skip no level): `pairs` = sum over n of (fixed polyominoes of n cells) x K^n, "
        "`skipped_by_bounds` = pairs ruled out by the count and level bounds before any "
        "evaluation, `seconds` = best of three runs in this process (numba compiled).",
        "",
        markdown_table(worst),
        "",
        "Goals of the issue (certified search to n_max = 7, 2 cores):",
        *[
            f"- {r['types']}: {r['seconds']:g} s (goal <= {r['goal_s']:g} s): "
            f"{'met' if r['seconds'] <= r['goal_s'] else 'NOT met'}"
            for r in worst
            if r["goal_s"] != ""
        ],
        "",
    ]


def _mujoco_section(sim: list[dict]) -> list[str]:
    if not sim:
        return []
    return [
        "## MuJoCo: mixed optima of external tasks with their real masses",
        "",
        "`modquad_gym.sim.validate(..., kind='external')`: bench on every task wrench "
        "(rotor wrench = w + m g e_z, exact allocation), hover under 5 of them (2 s each; "
        "load known, then unknown: observer + integral action, 1 s ramps). Goals: bench "
        "<= 1e-6, hover <= 1 cm.",
        "",
        markdown_table(sim),
        "",
    ]


if __name__ == "__main__":
    from benchmarks.common import refuse_as_script

    raise SystemExit(refuse_as_script("heterogeneous_report"))
