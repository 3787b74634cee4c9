"""One-type learned models beside greedy, per scale family and band: which model to ship?

    python -m benchmarks.scale_models --models NAME=ZIP [NAME=ZIP ...] [--bands 16 32 48 64]
        [--families planted torque payload] [--per-family 4] [--held-out] [--out DIR]

Each model acts single pass (``ppo --model ZIP``) on the validation draws of the one-type scale
families (where models are chosen; ``--held-out``: the held-out suites, once the choice is
made), beside greedy with the same time limit; every (method, band) runs in a fresh process
after an untimed warm-up (:func:`benchmarks.scale.run_band`, n_max as there). Per family and
band, and over all of them: the tasks each model solves of greedy's, and its mean modules minus
greedy's on the tasks both solve with a 95 % percentile-bootstrap interval over the tasks (the
goal: upper end <= 0), and its total time over greedy's.
"""

from __future__ import annotations

import math
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import numpy as np

from benchmarks.common import (
    Distinct,
    bench_args,
    check_model,
    markdown_table,
    read_rows_csv,
    report_page,
    write_csv,
    write_report,
)
from benchmarks.measure import fresh
from benchmarks.scale import run_band
from benchmarks.scale_suites import load_scale_suite
from modquad_gym.cli.common import time_limit_option
from modquad_gym.core.options import int_option, path_option
from modquad_gym.scoring.stats import interval

OUTPUTS = ("report.md", "report.csv", "rows.csv")
COLUMNS = ("band", "family", "task", "method", "found", "seconds")
"""The columns of rows.csv, in order (what ``--reuse`` reads back)."""
ONE_TYPE = ("planted", "torque", "payload")


def model_option(text: str) -> tuple[str, str]:
    """``NAME=ZIP`` -> (name, path); a ValueError naming the option otherwise."""
    name, sep, path = text.partition("=")
    if not sep or not name or not path:
        raise ValueError(f"--models {text}: give NAME=ZIP")
    check_model(path, f"--models {text}")
    return name, path


def read_rows(path: Path) -> list[dict]:
    """The rows of an earlier run's rows.csv, typed; a ValueError naming the file and the
    1-based row (after the header) otherwise."""
    what = ("benchmarks.scale_models (band 2-128, a one-type family, task, method, found: "
            "modules or empty, seconds >= 0)")  # fmt: skip
    return read_rows_csv(path, "--reuse", COLUMNS, typed_row, what, empty_ok=True)


def typed_row(r: dict) -> dict | None:
    """A row of rows.csv typed; None for values this benchmark never writes."""
    row = {"band": int(r["band"]), "family": r["family"], "task": r["task"],
           "method": r["method"], "found": int(r["found"]) if r["found"] else None,
           "seconds": float(r["seconds"])}  # fmt: skip
    return row if plausible(row) else None


def plausible(row: dict) -> bool:
    """Whether a typed row's values are ones this benchmark writes."""
    found = row["found"]
    return (2 <= row["band"] <= 128 and row["family"] in ONE_TYPE and (found is None or found >= 1)
            and 0 <= row["seconds"] < math.inf)  # fmt: skip


def band_tasks(band: int, families, per_family: int, held_out: bool) -> list:
    from modquad_gym.scoring.scale_tasks import draw

    if held_out:
        return load_scale_suite(band, list(families), per_family)
    return [draw(f, band, i, validation=True) for f in families for i in range(per_family)]


def solve(job: tuple, time_limit: float) -> list[dict]:
    """One (band, model) job: greedy (no model) or the model's single pass, rows named ``name``."""
    band, name, tasks, model = job
    return answers(
        band, "greedy" if model is None else "ppo", tasks, time_limit, model, method=name
    )


def answers(band: int, solver: str, tasks, time_limit: float, model, **columns) -> list[dict]:
    """The method ``solver`` (with ``model``) on ``tasks`` of ``band`` in a fresh process: a row
    per task (found only when verified), ``columns`` set among its fields (``method``: the row's
    name, else ``solver``; ``seed``: the model's training seed)."""
    results = fresh(run_band, solver, tasks, time_limit, 0, model)
    return [
        {"band": band, "family": t.meta["family"], "task": t.name, "method": solver, **columns,
         "found": r["found"] if r["verified"] else None, "seconds": round(r["seconds"], 3)}
        for t, r in zip(tasks, results, strict=True)
    ]  # fmt: skip


def versus_greedy(rows: list[dict], name: str, band="all", family="all", rival="greedy") -> dict:
    """Model ``name`` against greedy (or the method ``rival``: the ``greedy`` columns are then
    its) on the rows of ``band`` and ``family`` ("all": every)."""

    def here(r):
        return (band == "all" or r["band"] == band) and (family == "all" or r["family"] == family)

    greedy = {r["task"]: r for r in rows if r["method"] == rival and here(r)}
    mine = {r["task"]: r for r in rows if r["method"] == name and here(r)}
    solved = [t for t, r in greedy.items() if r["found"] is not None]
    both = [t for t in solved if mine[t]["found"] is not None]
    extra = np.array([mine[t]["found"] - greedy[t]["found"] for t in both], dtype=float)
    point, low, high = interval([extra], np.mean) if len(extra) else (np.nan,) * 3
    seconds = sum(r["seconds"] for r in mine.values()) / max(
        1e-9, sum(r["seconds"] for r in greedy.values())
    )
    return {"band": band, "family": family, "model": name, "tasks": len(mine),
            "greedy_solved": len(solved), "solves_of_greedys": len(both),
            "solved": sum(r["found"] is not None for r in mine.values()),
            "fewer": int((extra < 0).sum()), "more": int((extra > 0).sum()),
            "minus_greedy_modules": round(point, 2), "low": round(low, 2),
            "high": round(high, 2), "over_greedy_seconds": round(seconds, 2)}  # fmt: skip


def shown(table: list[dict], count: str = "solves_of_greedys") -> list[dict]:
    """``table`` for a page: where the difference is over one task (``count`` 1), which has no
    interval (NaN bounds), the bounds read ``n/a (1 task)``."""
    return [{**r, "low": "n/a (1 task)", "high": "n/a"} if r[count] == 1 else r for r in table]


def summary(rows: list[dict], names, bands, families, rival="greedy") -> list[dict]:
    """:func:`versus_greedy` per model over everything, then per band and family."""
    out = [versus_greedy(rows, n, rival=rival) for n in names]
    for band in bands:
        for family in families:
            out += [versus_greedy(rows, n, band, family, rival) for n in names]
    return out


def main(argv: list[str] | None = None) -> list[dict]:
    options = {
        "--models": dict(nargs="+", required=True, metavar="NAME=ZIP",
                         help="the one-type models to compare, each named"),
        "--bands": dict(type=int_option(2, 128), nargs="+", action=Distinct,
                        default=[16, 32, 48, 64], help="size bands (default 16 32 48 64)"),
        "--families": dict(nargs="+", action=Distinct, choices=ONE_TYPE, default=list(ONE_TYPE),
                           help="one-type scale families (default all three)"),
        "--per-family": dict(type=int_option(1, 100), default=4,
                             help="tasks per family and band (default 4)"),
        "--held-out": dict(action="store_true",
                           help="the held-out suites instead of the validation draws"),
        "--time-limit": dict(type=time_limit_option, default=30.0,
                             help="seconds each method gets per task, in (0, 86400] "
                                  "(default 30)"),
        "--workers": dict(type=int_option(1, 64), default=2,
                          help="processes at a time (default 2)"),
        "--reuse": dict(type=path_option, default=None, metavar="CSV",
                        help="an earlier run's rows.csv on the same tasks: its (band, method) "
                             "rows are kept, not solved again (greedy, a model of the same "
                             "name)"),
    }  # fmt: skip
    args = bench_args(argv, "python -m benchmarks.scale_models", __doc__.split("\n\n")[0],
                      options, seed_help=None, out="results/scale_models",
                      outputs=OUTPUTS)  # fmt: skip
    args.models = [model_option(text) for text in args.models]
    names = [n for n, _ in args.models]
    if len(set(names)) < len(names) or "greedy" in names:
        raise ValueError(f"--models: names must differ and not be greedy, got {' '.join(names)}")
    kept = read_rows(args.reuse) if args.reuse else []
    work = []
    for band in args.bands:
        tasks = band_tasks(band, args.families, args.per_family, args.held_out)
        for name, model in [("greedy", None), *args.models]:
            done = [r for r in kept if r["band"] == band and r["method"] == name]
            if sorted(r["task"] for r in done) != sorted(t.name for t in tasks):
                work.append((band, name, tasks, model))
    rows = [r for r in kept if (r["band"], r["method"]) not in {(b, n) for b, n, _, _ in work}
            and r["method"] in ("greedy", *names) and r["band"] in args.bands]  # fmt: skip
    with ThreadPoolExecutor(args.workers) as pool:  # each thread waits on its own process
        rows += [r for part in pool.map(lambda j: solve(j, args.time_limit), work) for r in part]
    table = summary(rows, names, args.bands, args.families)
    command = (
        "python -m benchmarks.scale_models --models "
        + " ".join(f"{n}={m}" for n, m in args.models)
        + f" --bands {' '.join(map(str, args.bands))} --families "
        f"{' '.join(args.families)} --per-family {args.per_family}"
        + (" --held-out" if args.held_out else "")
        + f" --time-limit {args.time_limit:g} --workers {args.workers} --out {args.out}"
        + (f" --reuse {args.reuse}" if args.reuse else "")
    )
    notes = (
        ("Tasks: the held-out scale suites. " if args.held_out else
         "Tasks: the validation draws of the scale families (never trained on). ")
        + "`solves_of_greedys`: of the tasks greedy solves, those the model solves; "
        "`minus_greedy_modules` [`low`, `high`]: the model's mean modules minus greedy's on the "
        "tasks both solve, 95 % percentile bootstrap over the tasks; `fewer`/`more`: tasks "
        "where it used fewer / more modules than greedy; `over_greedy_seconds`: its total time "
        "over greedy's. A structure counts only when the exact LP verifies it."
        + (f" The rows of (band, method) pairs in `{args.reuse}` were kept from that run "
           "(their seconds measured under its load), the others solved here." if args.reuse
           else "")
    )  # fmt: skip
    text = report_page("Learned models beside greedy per scale family and band", command,
                       notes, shown(table), "## Every task", "", markdown_table(rows), "",
                       how=f"; {args.workers} processes at a time")  # fmt: skip
    write_report(args.out, "report", table, text)
    write_csv(rows, args.out / "rows.csv")
    print(markdown_table(table))
    return table


if __name__ == "__main__":
    from benchmarks.common import run_main

    raise SystemExit(run_main(main, "scale_models"))
