"""The small tasks' optimal share of each decoding over several models: a variant's gain over the
first, paired task by task, pooled over the models.

    python -m benchmarks.fallback_seeds FOLDER [FOLDER ...] [--against FOLDER ...]
        [--out results/fallback_seeds]

Each FOLDER is one ``python -m benchmarks.fallback --bands --small N --model ZIP`` run (one
training seed's model) on the same small validation tasks. Per variant: its optimal and success
share per model and their mean; its gain over the first variant (the single pass), each task's
gain averaged over the models, with a 95 % percentile bootstrap interval over the tasks; and
its CPU seconds over the first's. The folders must hold the same tasks and variants.

``--against`` compares two recipes instead of two decodings: folders of models trained another
way (none of them a FOLDER); each variant's gain is then its mean over the FOLDER models minus
the same variant's mean over the ``--against`` models, task by task (paired by task; the models
of the two recipes are two samples, in no order).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from benchmarks.common import (
    Distinct,
    bench_args,
    check_task_rows,
    report_page,
    run_main,
    write_report,
)
from benchmarks.fallback import read_rows
from modquad_gym.core.options import path_option
from modquad_gym.scoring.stats import interval, mean

OUTPUTS = ("report.md", "report.csv")


def small_rows(folder: Path) -> dict[str, dict[str, dict]]:
    """variant -> task -> row of ``folder/rows.csv``'s small tasks: one row per task and
    variant, every task with a row of each (a one-line ValueError naming the file otherwise)."""
    path = folder / "rows.csv"
    rows = [r for r in read_rows(path, "FOLDER") if r["family"] == "small"]
    if not rows:
        raise ValueError(f"FOLDER {path}: no small tasks")
    check_task_rows(rows, list(dict.fromkeys(r["method"] for r in rows)), f"FOLDER {path}")
    out: dict[str, dict[str, dict]] = {}
    for row in rows:
        out.setdefault(row["method"], {})[row["task"]] = row
    return out


def optimal(row: dict) -> float:
    return float(row["found"] is not None and row["found"] == row["optimum"])


def summary(
    runs: dict[Path, dict[str, dict[str, dict]]],
    against: dict[Path, dict[str, dict[str, dict]]] | None = None,
) -> list[dict]:
    """A row per variant (module docstring); the baseline is the first variant, or with
    ``against`` (folders of other models) the same variant over those models."""
    first = next(iter(runs.values()))
    variants, tasks = list(first), sorted(next(iter(first.values())))
    optimum = {t: first[variants[0]][t]["optimum"] for t in tasks}
    for folder in sorted({f.resolve() for f in runs} & {f.resolve() for f in against or {}}):
        raise ValueError(f"--against {folder}: also a FOLDER; compare other models' runs")
    for folder, run in {**runs, **(against or {})}.items():
        if list(run) != variants or any(sorted(run[v]) != tasks for v in variants):
            raise ValueError(f"FOLDER {folder}: not the variants and tasks of the first folder")
        for variant in variants:
            for task, row in run[variant].items():
                if row["optimum"] != optimum[task]:
                    raise ValueError(f"FOLDER {folder}: task {task}'s optimum is "
                                     f"{row['optimum']}, not {optimum[task]} as in the first "
                                     "folder")  # fmt: skip

    def shares(variant: str, score, of=runs) -> np.ndarray:  # models x tasks
        return np.array([[score(run[variant][t]) for t in tasks] for run in of.values()])

    seconds = {v: sum(r["seconds"] for run in runs.values() for r in run[v].values())
               for v in variants}  # fmt: skip
    rows = []
    for variant in variants:
        share = shares(variant, optimal)
        success = shares(variant, lambda r: float(r["found"] is not None))
        base = (
            shares(variants[0], optimal) if against is None else shares(variant, optimal, against)
        )
        gain = interval([share.mean(axis=0) - base.mean(axis=0)], mean)
        rows.append({
            "variant": variant, "tasks": len(tasks), "models": len(runs),
            "optimal_pct_per_model": " ".join(f"{100 * s:g}" for s in share.mean(axis=1)),
            **({} if against is None else {"against_pct_per_model": " ".join(
                f"{100 * s:g}" for s in base.mean(axis=1))}),
            "optimal_pct": round(100 * share.mean(), 2),
            "success_pct": round(100 * success.mean(), 2),
            "gain_pt": round(100 * gain[0], 2), "gain_low": round(100 * gain[1], 2),
            "gain_high": round(100 * gain[2], 2),
            "cpu_over_first": round(seconds[variant] / seconds[variants[0]], 3),
        })  # fmt: skip
    return rows


def main(argv: list[str] | None = None) -> int:
    args = bench_args(
        argv,
        "python -m benchmarks.fallback_seeds",
        __doc__.split("\n\n")[0],
        {"folders": {"nargs": "+", "type": path_option, "action": Distinct, "key": Path.resolve,
                     "metavar": "FOLDER", "help": "benchmarks.fallback runs, one per model"},
         "--against": {"nargs": "+", "type": path_option, "action": Distinct,
                       "key": Path.resolve, "metavar": "FOLDER", "default": None,
                       "help": "runs of models trained another way: each variant's gain is "
                               "over the same variant's mean over these models, task by task "
                               "(default: over the first variant)"}},
        seed_help=None,
        out="results/fallback_seeds",
        outputs=OUTPUTS,
    )  # fmt: skip
    against = args.against and {folder: small_rows(folder) for folder in args.against}
    rows = summary({folder: small_rows(folder) for folder in args.folders}, against)
    versus = (
        "the first variant's"
        if against is None
        else "the same variant's mean over the `--against` models (`against_pct_per_model`), "
        "paired by task"
    )
    notes = (
        "`optimal_pct_per_model`: each model's optimal share (of the tasks' certified optima); "
        "`optimal_pct`, `success_pct`: over every model and task; `gain_pt` [`gain_low`, "
        f"`gain_high`]: optimal points over {versus}, each task's gain averaged over "
        "the models, 95 % bootstrap interval over the tasks; `cpu_over_first`: CPU seconds "
        "over the first variant's. The folders' own pages name the command of each run."
    )
    words = ["python -m benchmarks.fallback_seeds", *map(str, args.folders)]
    if against is not None:
        words += ["--against", *map(str, args.against)]
    command = " ".join(words)
    text = report_page("Small tasks: each decoding over several models", command, notes, rows)
    write_report(args.out, "report", rows, text)
    print(text)
    return 0


if __name__ == "__main__":
    raise SystemExit(run_main(main, "fallback_seeds"))
