"""What :mod:`benchmarks.scale` reports of its rows: per band and method, the issues' goals
judged on the run, the gap-against-size picture and the report page."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from benchmarks.common import load_average, machine_description, markdown_table
from modquad_gym.core.outputs import save_figure

BASELINES = ("greedy", "beam", "genetic", "centrosymmetric")
LEARNED = ("ppo", "ppo-guided")
GOALS = {"anytime_gap_pct": 5.0, "heuristic_gap_pct": 10.0, "seconds": 60.0,
         "certified_gap_pct": 10.0, "seconds_128": 120.0, "peak_MB_128": 2048.0}  # fmt: skip


def summary(rows: list[dict]) -> list[dict]:
    """Per band and method: tasks solved, and on those the mean modules and gap to the certified
    bound (read them beside ``solved``: a method that fails a hard task is not scored on it),
    mean seconds over all its tasks, peak memory."""
    out = []
    for band in sorted({r["band"] for r in rows}):
        mine = [r for r in rows if r["band"] == band]
        for method in dict.fromkeys(r["method"] for r in mine):
            rs = [r for r in mine if r["method"] == method]
            solved = [r for r in rs if r["found"] != "none"]
            out.append({
                "band": band, "method": method, "tasks": len(rs), "solved": len(solved),
                "mean_modules": _mean([r["found"] for r in solved]),
                "mean_gap_to_bound": _mean([r["gap_to_bound"] for r in solved]),
                "mean_seconds": _mean([r["seconds"] for r in rs]),
                "peak_MB": max(r["peak_MB"] for r in rs),
            })  # fmt: skip
    return out


def _mean(values: list) -> float | str:
    return round(float(np.mean(values)), 2) if values else ""


def versus(rows: list[dict], method: str, rival: str) -> dict:
    """``method`` against ``rival`` on the tasks both solved: mean modules and mean seconds of
    each, and how many tasks each solved."""
    by = {(r["method"], r["task"]): r for r in rows}
    tasks = [t for (m, t) in by if m == method and (rival, t) in by]
    both = [
        t for t in tasks if by[method, t]["found"] != "none" and by[rival, t]["found"] != "none"
    ]
    return {
        "both": len(both),
        "modules": _mean([by[method, t]["found"] for t in both]),
        "rival_modules": _mean([by[rival, t]["found"] for t in both]),
        "seconds": _mean([by[method, t]["seconds"] for t in tasks]),
        "rival_seconds": _mean([by[rival, t]["seconds"] for t in tasks]),
        "solved": sum(by[method, t]["found"] != "none" for t in tasks),
        "rival_solved": sum(by[rival, t]["found"] != "none" for t in tasks),
        "tasks": len(tasks),
    }


def goal_lines(rows: list[dict], methods, time_limit: float) -> list[str]:
    """The issues' goals, judged on this run (each line says met or NOT met), for the
    ``methods`` that have rows (a method that did not run is judged on nothing)."""
    ran = {r["method"] for r in rows}
    methods = [m for m in methods if m in ran]
    lines = []
    checks = ((64, "anytime", "anytime_gap_pct"), (64, "beam", "heuristic_gap_pct"),
              (64, "genetic", "heuristic_gap_pct"),
              (128, "anytime", "anytime_gap_pct"))  # fmt: skip
    for band, method, goal in checks:
        rs = [r for r in rows if (r["band"], r["family"], r["method"]) == (band, "planted", method)]
        if not rs:
            continue
        worst = max(r["gap_to_planted_pct"] if r["found"] != "none" else 1e9 for r in rs)
        slow, peak = max(r["seconds"] for r in rs), max(r["peak_MB"] for r in rs)
        limit = GOALS["seconds"] if band == 64 else GOALS["seconds_128"]
        ok = worst <= GOALS[goal] and slow <= min(limit, time_limit * 1.1)
        ok = ok and (band == 64 or peak <= GOALS["peak_MB_128"])
        lines.append(f"- {band}-module planted tasks, {method}: worst gap to the planted size "
                     f"{worst:g} % (goal <= {GOALS[goal]:g} %), slowest {slow:g} s (limit "
                     f"{min(limit, time_limit):g} s), peak {peak:g} MB"
                     + (f" (goal <= {GOALS['peak_MB_128']:g} MB)" if band == 128 else "")
                     + f": {'met' if ok else 'NOT met'}")  # fmt: skip
    for method in (m for m in methods if m.startswith("anytime")):
        lines += portfolio_goal_lines(rows, method)
    rivals = [m for m in BASELINES if m in methods]
    sizes = sizes_run(rows)
    for method in (m for m in LEARNED if m in methods):
        parts, beaten = [], []
        for rival in rivals:
            v = versus(rows, method, rival)
            fewer = v["modules"] != "" and v["modules"] < v["rival_modules"]
            wins = fewer and v["solved"] >= v["rival_solved"] and v["seconds"] <= v["rival_seconds"]
            beaten += [rival] if wins else []
            parts.append(f"vs {rival}: {_modules_both(v)}, solved {v['solved']} vs "
                         f"{v['rival_solved']} of {v['tasks']}, {v['seconds']} vs "
                         f"{v['rival_seconds']} s")  # fmt: skip
        if parts:
            lines.append(f"- learned `{method}` at {sizes} modules (fewer modules, at least as "
                         f"many solved, no more time): {'; '.join(parts)}. Beats "
                         f"{len(beaten)}/{len(rivals)} ({', '.join(beaten) or 'none'}): "
                         f"{'met' if len(beaten) == len(rivals) else 'NOT met'}")  # fmt: skip
    return lines


def sizes_run(rows: list[dict]) -> str:
    """The size bands the rows hold, in words: ``64`` for one band, ``16-128`` for several,
    ``no`` for none."""
    bands = sorted({int(r["band"]) for r in rows})
    if not bands:
        return "no"
    return str(bands[0]) if len(bands) == 1 else f"{bands[0]}-{bands[-1]}"


def _modules_both(v: dict) -> str:
    """A :func:`versus` comparison's modules on the tasks both solved, in words when there
    are none (no mean to print)."""
    if not v["both"]:
        return "no task both solved, so no modules to compare"
    return f"{v['modules']} vs {v['rival_modules']} modules on the {v['both']} tasks both solved"


def portfolio_goal_lines(rows: list[dict], method: str = "anytime") -> list[str]:
    """Issue 35's goals for the default search (``method``: ``anytime``, or ``anytime-wN`` on
    workers), on the tasks it ran: no method other than the default search answers with fewer
    modules (a method that answers where it finds nothing counts as fewer), and its certified
    gap (found - bound) / found is at most ``certified_gap_pct``."""
    by_task: dict[str, dict[str, dict]] = {}
    for r in rows:
        by_task.setdefault(r["task"], {})[r["method"]] = r
    beaten, gaps = [], []
    for task, methods in by_task.items():
        mine = methods.get(method)
        if mine is None:
            continue
        found = mine["found"] if mine["found"] != "none" else None
        for rival, r in methods.items():
            if not rival.startswith("anytime") and r["found"] != "none":
                if found is None or int(r["found"]) < int(found):
                    beaten.append(f"{task} ({rival} {r['found']} vs {found or 'none'})")
        bound = int(mine["lower_bound"])
        gaps.append((100.0 * (int(found) - bound) / int(found) if found else 100.0, task))
    if not gaps:
        return []
    worst, worst_task = max(gaps)
    goal = GOALS["certified_gap_pct"]
    within = sum(g <= goal for g, _ in gaps)
    name = "the portfolio" if method == "anytime" else "the portfolio on workers"
    return [
        f"- default search (`{method}`, {name}) never uses more modules than another "
        f"method on a task: {len(gaps) - len({b.split(' ')[0] for b in beaten})} of "
        f"{len(gaps)} tasks; " + (f"beaten on {'; '.join(beaten)}: NOT met" if beaten else "met"),
        f"- `{method}`'s certified gap (found - bound) / found <= {goal:g} % on every task: "
        f"{within} of {len(gaps)} tasks, worst {worst:.1f} % ({worst_task}): "
        f"{'met' if within == len(gaps) else 'NOT met'}",
    ]


MARKERS = "osD^v<>pPX*h"


def common_solved(rows: list[dict], methods: list[str]) -> dict[int, list[str]]:
    """Per band, the tasks that every one of ``methods`` solved (a fair subset to average a
    gap over: a method that fails a hard task is not scored on an easier set)."""
    out = {}
    for band in sorted({r["band"] for r in rows}):
        solved = [{r["task"] for r in rows if r["band"] == band and r["method"] == m
                   and r["found"] != "none"} for m in methods]  # fmt: skip
        out[band] = sorted(set.intersection(*solved)) if solved else []
    return out


def plot(rows: list[dict], path: Path) -> None:
    """Left: each method's gap to the certified lower bound, mean (marker) and range (bar) over
    the tasks that every plotted method solved in the band (the methods that solved at least
    half the tasks of every band; n per band under the axis); right: the share of tasks
    solved. Methods side by side within a band, each with its own marker, so none hides
    another; one legend under both panels, over no data."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    bands = sorted({r["band"] for r in rows})
    methods = list(dict.fromkeys(r["method"] for r in rows))

    def tasks(band, m):
        return [r for r in rows if r["band"] == band and r["method"] == m]

    def solved(band, m):
        return [r for r in tasks(band, m) if r["found"] != "none"]

    steady = [m for m in methods
              if all(2 * len(solved(b, m)) >= max(1, len(tasks(b, m))) for b in bands)]  # fmt: skip
    subset = common_solved(rows, steady)
    fig, (gap_ax, solved_ax) = plt.subplots(1, 2, figsize=(13, 5.2), layout="constrained")
    width = 0.8 / max(len(methods), 1)
    for k, m in enumerate(methods):
        style = {"marker": MARKERS[k % len(MARKERS)], "color": f"C{k % 10}", "label": m}
        dx = (k - (len(methods) - 1) / 2) * width
        if m in steady:
            xs, mid, lo, hi = [], [], [], []
            for i, b in enumerate(bands):
                gaps = [r["gap_to_bound"] for r in solved(b, m) if r["task"] in subset[b]]
                if gaps:
                    xs.append(i + dx)
                    mid.append(float(np.mean(gaps)))
                    lo.append(mid[-1] - min(gaps))
                    hi.append(max(gaps) - mid[-1])
            gap_ax.errorbar(xs, mid, yerr=[lo, hi], capsize=3, lw=1, **style)
        pts = [(i + dx, 100.0 * len(solved(b, m)) / len(tasks(b, m)))
               for i, b in enumerate(bands) if tasks(b, m)]  # fmt: skip
        solved_ax.plot(*zip(*pts, strict=True), ls="none", ms=7, **style)
    gap_ax.set_xticks(range(len(bands)),
                      [f"{b}\n(n={len(subset[b])})" for b in bands])  # fmt: skip
    gap_ax.set_ylabel("modules above the certified lower bound")
    gap_ax.set_title("Gap to the lower bound: mean and range over the tasks all of these "
                     "solved", fontsize="medium")  # fmt: skip
    gap_ax.set_ylim(bottom=0)
    solved_ax.set_xticks(range(len(bands)), [str(b) for b in bands])
    solved_ax.set_ylabel("tasks solved within the time limit (%)")
    solved_ax.set_ylim(-3, 105)
    solved_ax.set_title("Tasks solved (every method)", fontsize="medium")
    for ax in (gap_ax, solved_ax):
        ax.set_xlabel("planted size (modules)")
        ax.grid(alpha=0.3)
    # one legend under both panels: inside either it hid markers (milp's 0 % at 32 modules)
    handles, labels = solved_ax.get_legend_handles_labels()
    fig.legend(handles, labels, loc="outside lower center", ncols=len(labels), fontsize=8)
    save_figure(fig, path)
    plt.close(fig)


def report(rows: list[dict], summary_rows: list[dict], args) -> str:
    load = load_average()
    return "\n".join([
        f"# Every method at {sizes_run(rows)} modules",
        "",
        f"Made by `{command_line(args)}` on {machine_description()}; each (method, band) in a "
        f"fresh process, {args.workers} at a time; "
        + ("load average not recorded (re-rendered)." if args.rows else
           f"load average at the end {load}."),
        "",
        "Tasks: the held-out scale suites (`modquad_gym/data/suites/scale_N.json`; families "
        "`planted` one type, `mixed` palette t45/t45m/flat, `payload` heavy payload with "
        "self-weight, `torque` low force and high torque where no lift bound helps). "
        "`lower_bound`: certified (the largest proved by the suite's default search or by any "
        "method here). `gap_to_bound`: modules above it. `planted`: the hidden structure's size, "
        "an upper bound on the optimum. "
        + (f"Learned methods use the model {args.model}. " if args.model else
           "Learned methods use the shipped pair (`modquad_gym.policy.default_model`): "
           "`ppo_scale`, trained further on one-type tasks of 8-32 modules, for the one-type "
           "families, the default model with the mixed palette. ")
        + "Every structure is verified by the exact LP. "
        "Per band, `mean_modules` and `mean_gap_to_bound` are over the tasks the method solved "
        "(read them beside `solved`); `mean_seconds` over all its tasks.",
        "",
        "## Per band and method",
        "",
        markdown_table(summary_rows),
        "",
        "Goals:",
        *goal_lines(rows, args.methods, args.time_limit),
        "",
        "![gap vs size](gap_vs_size.png)",
        "",
        "## Every task",
        "",
        markdown_table(rows),
        "",
    ])  # fmt: skip


def command_line(args) -> str:
    line = (f"python -m benchmarks.scale --bands {' '.join(map(str, args.bands))} --families "
            f"{' '.join(args.families)} --per-family {args.per_family} --methods "
            f"{' '.join(args.methods)} --time-limit {args.time_limit:g} --workers {args.workers}"
            + (" --validation" if args.validation else "") + f" --seed {args.seed}"
            + (f" --model {args.model}" if args.model else ""))  # fmt: skip
    if args.rows:  # re-rendered: the measuring run's command, then the re-rendering
        line += (
            f"`, re-rendered by `... --rows {' '.join(map(str, args.rows))} --out {args.out} "
            "--force"
        )
    return line


if __name__ == "__main__":
    from benchmarks.common import refuse_as_script

    raise SystemExit(refuse_as_script("scale_report"))
