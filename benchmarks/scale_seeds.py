"""The learned designer's training seeds on the held-out scale suites, single pass, beside
greedy with the same time limit: does `ppo` solve what greedy solves, with no more modules and
in less time (issue 36's scale goal)?

    python -m benchmarks.scale_seeds [--bands 16 32 64] [--runs runs/exact-seeds]
        [--mixed-runs runs/mixed-exact-seeds] [--out results/scale_seeds]

Each seed's one-type model (``RUNS/seed-S/model.zip``, the current tier's recipe) acts on the
one-type families (planted, payload, torque) and its mixed-palette model (``MIXED_RUNS``) on the
``mixed`` family, as ``modquad solve --method ppo`` picks a model by palette. Greedy is
deterministic: one run. Every (method, seed, band) runs in a fresh process after an untimed
warm-up (:func:`benchmarks.scale.run_band`). Per band, over the seeds (95 % percentile bootstrap
of the seeds): the share of greedy's solved tasks that `ppo` solves, `ppo`'s modules minus
greedy's on the tasks both solve, and `ppo`'s seconds over greedy's.
"""

from __future__ import annotations

from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import numpy as np

from benchmarks.common import (
    Distinct,
    bench_args,
    check_task_rows,
    markdown_table,
    read_rows_csv,
    report_page,
    write_csv,
    write_report,
)
from benchmarks.scale_models import answers
from benchmarks.scale_suites import FAMILIES, load_scale_suite
from modquad_gym.cli.common import time_limit_option
from modquad_gym.core.options import int_option, path_option
from modquad_gym.scoring.seed_runs import find_runs
from modquad_gym.scoring.stats import interval

OUTPUTS = ("report.md", "report.csv", "rows.csv")
ONE_TYPE = tuple(f for f in FAMILIES if f != "mixed")


def jobs(bands, runs: dict, mixed_runs: dict) -> list[tuple]:
    """(band, method, seed, tasks, model) per fresh process: greedy once, ppo per seed and
    palette."""
    out = []
    for band in bands:
        tasks = load_scale_suite(band)
        one = [t for t in tasks if t.meta["family"] in ONE_TYPE]
        mixed = [t for t in tasks if t.meta["family"] == "mixed"]
        out.append((band, "greedy", "", tasks, None))
        for seed, model in runs.items():
            out.append((band, "ppo", seed, one, str(model)))
            if seed in mixed_runs and mixed:
                out.append((band, "ppo", seed, mixed, str(mixed_runs[seed])))
    return out


def solve(job: tuple, time_limit: float) -> list[dict]:
    """One (band, method, seed) job in a fresh process: a row per task, with its seed."""
    band, method, seed, tasks, model = job
    return answers(band, method, tasks, time_limit, model, seed=seed)


def seed_rows(rows: list[dict], band: int) -> list[dict]:
    """Per seed in ``band``: the share of greedy's solved tasks ``ppo`` solves (one the seed did
    not run, e.g. with no mixed-palette model, counts as missed), its mean modules above
    greedy's where both solve, and its total wall time over greedy's on the tasks it ran."""
    greedy = {r["task"]: r for r in rows if r["band"] == band and r["method"] == "greedy"}
    solved = [t for t, r in greedy.items() if r["found"] is not None]
    seeds = sorted({r["seed"] for r in rows if r["method"] == "ppo"}, key=lambda s: (len(s), s))
    out = []
    for seed in seeds:
        mine = {r["task"]: r for r in rows
                if r["band"] == band and r["method"] == "ppo" and r["seed"] == seed}  # fmt: skip
        both = [t for t in solved if t in mine and mine[t]["found"] is not None]
        extra = np.mean([mine[t]["found"] - greedy[t]["found"] for t in both]) if both else np.nan
        ratio = sum(r["seconds"] for r in mine.values()) / max(
            1e-9, sum(greedy[t]["seconds"] for t in mine)
        )
        out.append({"band": band, "seed": seed,
                    "ppo_solves_greedys_pct": 100.0 * len(both) / max(1, len(solved)),
                    "ppo_minus_greedy_modules": float(extra),
                    "ppo_over_greedy_seconds": float(ratio)})  # fmt: skip
    return out


def per_seed_table(rows: list[dict], bands) -> list[dict]:
    """:func:`seed_rows` of every band, rounded for the report."""
    return [{k: round(v, 2) if isinstance(v, float) else v for k, v in r.items()}
            for band in bands for r in seed_rows(rows, band)]  # fmt: skip


def band_summary(rows: list[dict], band: int) -> dict:
    """The band's greedy line and ppo's per-seed scores with their bootstrap intervals
    (:func:`seed_mean`)."""
    greedy = [r for r in rows if r["band"] == band and r["method"] == "greedy"]
    per_seed = seed_rows(rows, band)
    share = [r["ppo_solves_greedys_pct"] for r in per_seed]
    extra = [r["ppo_minus_greedy_modules"] for r in per_seed]
    ratio = [r["ppo_over_greedy_seconds"] for r in per_seed]
    return {"band": band, "tasks": len(greedy),
            "greedy_solved": sum(r["found"] is not None for r in greedy),
            "seeds": len(per_seed), "ppo_solves_greedys_pct": seed_mean(share, ".1f"),
            "ppo_every_seed_all": sum(s == 100.0 for s in share),
            "ppo_minus_greedy_modules": seed_mean(extra, "+.2f"),
            "ppo_over_greedy_seconds": seed_mean(ratio, ".2f")}  # fmt: skip


def seed_mean(values, fmt: str) -> str:
    """``mean [low, high]`` of the per-seed ``values`` with its 95 % bootstrap interval; a
    seed without a value (NaN: ppo solved none of greedy's tasks, no difference) is left out
    and counted (``(4 of 5 seeds)``); ``n/a (1 seed)`` where one is left; ``-`` for none."""
    v = np.asarray(values, dtype=float)
    kept = v[~np.isnan(v)]
    if not len(kept):
        return "-"
    point, low, high = interval([kept], np.mean)
    text = f"{point:{fmt}} " + ("n/a (1 seed)" if len(kept) < 2 else f"[{low:{fmt}}, {high:{fmt}}]")
    return text if len(kept) == len(v) else f"{text} ({len(kept)} of {len(v)} seeds)"


def family_rows(rows: list[dict]) -> list[dict]:
    """Per band and family over every seed: tasks ppo solves (of seed x task runs) and its mean
    modules above greedy's where both solve."""
    greedy = {r["task"]: r["found"] for r in rows if r["method"] == "greedy"}
    out = []
    keys = dict.fromkeys((r["band"], r["family"]) for r in rows)
    for band, family in sorted(keys, key=lambda k: (int(k[0]), k[1])):
        here = (band, family)
        mine = [r for r in rows if r["method"] == "ppo" and (r["band"], r["family"]) == here]
        both = [r["found"] - greedy[r["task"]] for r in mine
                if r["found"] is not None and greedy[r["task"]] is not None]  # fmt: skip
        out.append({"band": band, "family": family, "runs": len(mine),
                    "ppo_solved": sum(r["found"] is not None for r in mine),
                    "greedy_solved": sum(greedy[r["task"]] is not None for r in mine),
                    "ppo_minus_greedy_modules": round(float(np.mean(both)), 2) if both
                    else "-"})  # fmt: skip
    return out


COLUMNS = ("band", "family", "task", "method", "seed", "found", "seconds")
"""The columns of ``rows.csv``, as :func:`solve` writes them."""


def read_rows(path: Path) -> list[dict]:
    """Rows of an earlier run's rows.csv, typed as :func:`solve` writes them
    (:func:`~benchmarks.common.read_rows_csv`: a one-line ValueError naming the file and the
    1-based row for anything else)."""
    return read_rows_csv(path, "--rows", COLUMNS, typed_row, "benchmarks.scale_seeds")


def typed_row(raw: dict) -> dict | None:
    """A row of rows.csv with band, found (empty: none) and seconds as numbers; None for values
    :func:`solve` never writes (a band outside 16..128, an unknown family, a method other than
    greedy (no seed) or ppo (its seed), fewer than 1 module, seconds not in [0, inf))."""
    row = raw | {"band": int(raw["band"]), "seconds": float(raw["seconds"]),
                 "found": int(raw["found"]) if raw["found"] else None}  # fmt: skip
    method = {"greedy": raw["seed"] == "", "ppo": raw["seed"] != ""}.get(raw["method"], False)
    known = 16 <= row["band"] <= 128 and raw["family"] in FAMILIES and raw["task"] and method
    counts = (row["found"] is None or row["found"] >= 1) and 0 <= row["seconds"] < np.inf
    return row if known and counts else None


def read_runs_rows(path: Path, bands) -> list[dict]:
    """:func:`read_rows` of ``--rows``, each row of ``bands`` and each task with one greedy row
    and at most one per ppo seed (what the report compares); a one-line ValueError otherwise."""
    rows = read_rows(path)
    for i, r in enumerate(rows, start=1):
        if r["band"] not in bands:
            raise ValueError(f"--rows {path}: row {i}: band {r['band']} is not among --bands "
                             f"{' '.join(map(str, bands))}")  # fmt: skip
    check_task_rows(rows, ["greedy"], f"--rows {path}", run_name)
    return rows


def run_name(row: dict) -> str:
    """``greedy`` or ``ppo seed S``: one run of a task."""
    return f"{row['method']} seed {row['seed']}" if row["seed"] else row["method"]


def seed_models(folder: Path, option: str) -> dict[str, Path]:
    """``seed-S/model.zip`` of ``folder`` by seed; a ValueError naming ``option`` if none."""
    try:
        return find_runs([folder])
    except ValueError as exc:
        raise ValueError(f"{option}: {str(exc).removeprefix('RUNS: ')}") from None


def main(argv: list[str] | None = None) -> list[dict]:
    options = {
        "--bands": dict(type=int_option(16, 128), nargs="+", action=Distinct, default=[16, 32, 64],
                        help="size bands of the held-out scale suites (default 16 32 64)"),
        "--runs": dict(type=path_option, default=Path("runs/exact-seeds"),
                       help="folder of seed-S/model.zip, one-type models (python train.py "
                            "--seeds 0 1 2 3 4 --out FOLDER)"),
        "--mixed-runs": dict(type=path_option, default=Path("runs/mixed-exact-seeds"),
                             help="folder of seed-S/model.zip, mixed-palette models "
                                  "(python train.py --tier mixed --seeds ...)"),
        "--time-limit": dict(type=time_limit_option, default=30.0,
                             help="seconds each method gets per task (default 30)"),
        "--workers": dict(type=int_option(1, 64), default=2,
                          help="processes at a time (default 2)"),
        "--rows": dict(type=path_option, default=None, metavar="CSV",
                       help="re-render the report from an earlier run's rows.csv (no solving; "
                            "give the options it used)"),
    }  # fmt: skip
    args = bench_args(argv, "python -m benchmarks.scale_seeds", __doc__.split("\n\n")[0],
                      options, seed_help=None, out="results/scale_seeds",
                      outputs=OUTPUTS)  # fmt: skip
    if args.rows is not None:  # the seeds are the rows' (no model is read)
        rows = read_runs_rows(args.rows, args.bands)
        seeds = sorted({r["seed"] for r in rows if r["seed"]}, key=lambda s: (len(s), s))
    else:
        runs = seed_models(args.runs, "--runs")
        mixed_runs = seed_models(args.mixed_runs, "--mixed-runs")
        seeds = list(runs)
        work = jobs(args.bands, runs, mixed_runs)
        with ThreadPoolExecutor(args.workers) as pool:  # each thread waits on its own process
            rows = [r for part in pool.map(lambda j: solve(j, args.time_limit), work) for r in part]
    summary = [band_summary(rows, band) for band in args.bands]
    command = (f"python -m benchmarks.scale_seeds --bands {' '.join(map(str, args.bands))} "
               f"--runs {args.runs} --mixed-runs {args.mixed_runs} --time-limit "
               f"{args.time_limit:g} --workers {args.workers} --out {args.out}"
               + (f" --rows {args.rows}" if args.rows else ""))  # fmt: skip
    notes = (
        f"Seeds: {', '.join(seeds)} (`{args.runs}`; mixed palette `{args.mixed_runs}`). "
        "`ppo_solves_greedys_pct`: of the tasks greedy solves, the share `ppo` solves (mean "
        "over seeds, 95 % bootstrap interval); `ppo_every_seed_all`: seeds that solve all of "
        "them; `ppo_minus_greedy_modules`: mean modules above greedy's on the tasks both solve "
        "(a seed that solves none of greedy's tasks has no difference: the cell then says over "
        "how many seeds it is); "
        "`ppo_over_greedy_seconds`: `ppo`'s total wall time over greedy's on the same tasks. "
        "A structure counts only when the exact LP verifies it."
        + (" Re-rendered from the rows the same command wrote without `--rows`." if args.rows
           else "")
    )  # fmt: skip
    text = report_page("The learned designer's seeds at 16-64 modules", command, notes, summary,
                       "## Per family (every seed)", "", markdown_table(family_rows(rows)), "",
                       "## Per seed", "",
                       markdown_table(per_seed_table(rows, args.bands)), "",
                       "## Every task and seed", "", markdown_table(rows), "",
                       how=f"; {args.workers} processes at a time")  # fmt: skip
    write_report(args.out, "report", summary, text)
    write_csv(rows, args.out / "rows.csv")
    print(markdown_table(summary))
    return summary


if __name__ == "__main__":
    from benchmarks.common import run_main

    raise SystemExit(run_main(main, "scale_seeds"))
