"""What the prune post-pass is worth: each constructive method with and without it, same tasks.

    python -m benchmarks.prune [--bands 16 32 64 96 128] [--families ...] [--per-family 1]
        [--methods greedy beam ppo] [--time-limit 30] [--workers 2] [--validation] [--out DIR]

Runs ``benchmarks.scale`` on its tasks (the held-out scale suites, or ``--validation`` draws)
with every method plain and as ``METHOD+prune`` (``prune=True``: :mod:`modquad_gym.search.prune`),
each (method, band) in a fresh process after an untimed warm-up, and reports per method what
pruning removed and cost, and each learned method (``ppo``, ``ppo-guided``), plain and pruned,
against each other method, plain and pruned, over every task and per family and band: the mean
module difference on the tasks both answer with a 95 % percentile-bootstrap interval over
those tasks.
"""

from __future__ import annotations

import argparse

import numpy as np

from benchmarks import scale
from benchmarks.common import (
    Distinct,
    bench_args,
    check_task_rows,
    load_average,
    machine_description,
    markdown_table,
    write_csv,
)
from benchmarks.scale_models import shown, summary, versus_greedy
from modquad_gym.core.options import path_option
from modquad_gym.core.outputs import claim_output_dir, write_text
from modquad_gym.core.resources import cap_workers

OUTPUTS = ("report.md", "rows.csv", "methods.csv", "versus.csv")
LEARNED = ("ppo", "ppo-guided")
"""The learned methods, compared with every other method run (each plain and pruned)."""


def found(rows: list[dict], method: str) -> dict[str, int]:
    """task -> modules of ``method``'s verified answers."""
    return {r["task"]: int(r["found"]) for r in rows
            if r["method"] == method and r["found"] != "none" and r["verified"]}  # fmt: skip


def method_rows(rows: list[dict], methods) -> list[dict]:
    """Per method: tasks answered plain and pruned, mean modules of each on the tasks both
    answer, tasks where pruning removed modules, and total seconds pruned over plain."""
    out = []
    for m in methods:
        plain, pruned = found(rows, m), found(rows, f"{m}+prune")
        both = sorted(set(plain) & set(pruned))
        seconds = {k: sum(r["seconds"] for r in rows if r["method"] == k)
                   for k in (m, f"{m}+prune")}  # fmt: skip
        out.append({
            "method": m, "tasks": len({r["task"] for r in rows if r["method"] == m}),
            "answered": len(plain), "answered_pruned": len(pruned),
            "modules": _mean([plain[t] for t in both]),
            "modules_pruned": _mean([pruned[t] for t in both]),
            "tasks_pruned": sum(pruned[t] < plain[t] for t in both),
            "seconds_ratio": round(seconds[f"{m}+prune"] / max(seconds[m], 1e-9), 2),
        })  # fmt: skip
    return out


def versus_rows(rows: list[dict], mine: str, rivals, bands, families) -> list[dict]:
    """``mine`` against each of ``rivals`` over everything, per band, then per band and family
    (:func:`benchmarks.scale_models.versus_greedy` on the verified answers): rival's answers it
    misses, its mean modules minus the rival's on the tasks both answer (95 % interval), its
    total seconds over the rival's."""
    answers = [{**r, "found": int(r["found"]) if r["found"] != "none" and r["verified"] else None}
               for r in rows]  # fmt: skip
    out = []
    for rival in rivals:
        per_band = [versus_greedy(answers, mine, band, "all", rival) for band in bands]
        everything, *cells = summary(answers, [mine], bands, families, rival)
        for v in [everything, *per_band, *cells]:
            out.append({"method": mine, "rival": rival, "band": v["band"], "family": v["family"],
                        "missed": v["greedy_solved"] - v["solves_of_greedys"],
                        "both": v["solves_of_greedys"], "difference": v["minus_greedy_modules"],
                        "low": v["low"], "high": v["high"],
                        "seconds_ratio": v["over_greedy_seconds"]})  # fmt: skip
    return out


def _mean(values: list) -> float | str:
    return round(float(np.mean(values)), 2) if values else ""


def report(rows: list[dict], per_method: list[dict], against: list[dict], args) -> str:
    """The report page: how it was made, what pruning did per method, the learned methods
    against the constructive ones, and the issue's goal judged on this run."""
    lines = [
        "# The prune post-pass",
        "",
        f"Command: `{command_line(args)}`"
        + (f" (this page re-rendered from its `{args.rows}`)" if args.rows else "")
        + f". Machine: {machine_description()}; load average {load_average()} at the end"
        + (" of the re-rendering" if args.rows else "")
        + ". Tasks: "
        + ("validation draws" if args.validation else "the held-out scale suites")
        + f", {args.per_family} per family and band; every method with the same "
        f"{args.time_limit:g} s limit (the post-pass inside it), each (method, band) in a fresh "
        "process after an untimed warm-up; every answer re-verified by the exact LP.",
        "",
        "## What pruning removed, per method",
        "",
        "`modules` and `modules_pruned`: mean on the tasks both answer; `tasks_pruned`: tasks "
        "where it removed at least one module; `seconds_ratio`: total seconds with the "
        "post-pass over without.",
        "",
        markdown_table(per_method),
    ]
    if against:
        lines += [
            "",
            "## The learned methods, plain and pruned, against the constructive ones",
            "",
            "Over every task and per band (per family and band: `versus.csv`). `difference`: "
            "mean modules of "
            "the method minus the rival's on the `both` tasks both answer, with its 95 % "
            "bootstrap interval [`low`, `high`] over them; `missed`: tasks the rival answers "
            "and it does not; `seconds_ratio`: its total seconds over the rival's.",
            "",
            markdown_table(shown([v for v in against if v["family"] == "all"], "both")),
            "",
            "## Goal (never worse than the rival, per family and band)",
            "",
            *goal_lines(against),
        ]
    else:
        lines += [
            "",
            "No comparison (no `versus.csv`): `--methods` names no learned method "
            f"({', '.join(LEARNED)}) beside another method to compare it with.",
        ]
    return "\n".join([*lines, ""])


def goal_lines(against: list[dict]) -> list[str]:
    """Per learned method and plain rival: the family and band cells where it misses a task
    the rival answers or its interval's upper end is above 0 (met: none); a cell of one task
    both answer has no interval and is judged on that task's difference."""
    cells = [v for v in against if v["family"] != "all" and "+" not in v["rival"]]
    cells = [v for v in cells if v["both"] + v["missed"]]
    out = []
    for pair in dict.fromkeys((v["method"], v["rival"]) for v in cells):
        mine = [v for v in cells if (v["method"], v["rival"]) == pair]
        worse = [v for v in mine if v["missed"] or _upper(v) > 0]
        out.append(f"- `{pair[0]}` against {pair[1]}: cells where it misses a task {pair[1]} "
                   f"answers or the interval's upper end is above 0: {len(worse)} of "
                   f"{len(mine)}{_listed(worse)}: {'met' if not worse else 'NOT met'}")  # fmt: skip
    return out


def _upper(v: dict) -> float:
    """The cell's interval's upper end; its one difference where one task has none."""
    return v["difference"] if v["both"] == 1 else v["high"]


def _listed(cells: list[dict]) -> str:
    """``: family-band (difference [low, high], missed n), ...`` of ``cells`` (no difference
    where no task was answered by both)."""

    def one(v: dict) -> str:
        bounds = "n/a (1 task)" if v["both"] == 1 else f"[{v['low']:+g}, {v['high']:+g}]"
        both = f"{v['difference']:+g} {bounds}, " if v["both"] else ""
        return f"{v['family']}-{v['band']} ({both}missed {v['missed']})"

    return "".join(f"{', ' if i else ': '}{one(v)}" for i, v in enumerate(cells))


def command_line(args) -> str:
    return (f"python -m benchmarks.prune --bands {' '.join(map(str, args.bands))} --families "
            f"{' '.join(args.families)} --per-family {args.per_family} --methods "
            f"{' '.join(args.base_methods)} --time-limit {args.time_limit:g} --workers "
            f"{args.workers} --seed {args.seed}" + (" --validation" if args.validation else "")
            + f" --out {args.out}")  # fmt: skip


def parse_args(argv: list[str] | None) -> argparse.Namespace:
    options = {
        **scale.task_options(bands=(16, 32, 64, 96, 128), workers=2),
        "--methods": dict(nargs="+", action=Distinct,
                          choices=("greedy", "beam", "random", "genetic", "ppo", "ppo-guided"),
                          default=["greedy", "beam", "ppo"],
                          help="methods, each run plain and pruned; the learned ones (ppo, "
                               "ppo-guided) are compared with the others (default greedy beam "
                               "ppo)"),
        "--rows": dict(type=path_option, default=None, metavar="CSV",
                       help="re-render the report from an earlier run's rows.csv (no solving; "
                            "give the options it used)"),
    }  # fmt: skip
    args = bench_args(argv, "python -m benchmarks.prune", "Each constructive method with and "
                      "without the prune post-pass on the scale tasks; write results/prune/.",
                      options, seed_help="seed of the seeded methods (default 0)",
                      out="results/prune", outputs=OUTPUTS)  # fmt: skip
    args.base_methods = list(dict.fromkeys(args.methods))
    args.methods = [n for m in args.base_methods for n in (m, f"{m}+prune")]
    args.model, args.workers = None, cap_workers(args.workers)
    return args


def main(argv: list[str] | None = None) -> list[dict]:
    args = parse_args(argv)
    scale.check_task_args(args)
    earlier = scale.read_runs([args.rows]) if args.rows else None  # before --force clears --out
    if earlier is not None:  # every task of the run with a row of each method, plain and pruned
        check_task_rows(earlier, args.methods, f"--rows {args.rows}")
    with claim_output_dir(args.out, OUTPUTS, args.force) as claim:
        rows = earlier or scale.measure(args, scale.keep_rows(claim.path("rows.csv")))
        per_method = method_rows(rows, args.base_methods)
        learned = [m for m in args.base_methods if m in LEARNED]
        rivals = [m for m in args.base_methods if m not in LEARNED]
        against = [v for mine in learned for plus in ("", "+prune")
                   for v in versus_rows(rows, mine + plus, [r + p for r in rivals
                                                            for p in ("", "+prune")],
                                        args.bands, args.families)]  # fmt: skip
        write_csv(rows, claim.path("rows.csv"))
        write_csv(per_method, claim.path("methods.csv"))
        if against:  # a learned method and a rival were run
            write_csv(against, claim.path("versus.csv"))
        write_text(claim.path("report.md"), report(rows, per_method, against, args))
    print(markdown_table(per_method))
    return rows


if __name__ == "__main__":
    raise SystemExit(scale.run_main(main, "prune"))
