"""The learned methods' fallback to greedy's choice (their option ``fallback``): modules
beside a rival per scale family and band, and the optimal share on small tasks, for each
fallback and shortlist (``top_k``) and, for ``ppo-guided``, budget, on validation draws only.

    python -m benchmarks.fallback [--method ppo|ppo-guided] [--rival greedy|beam]
        [--bands 16 32 48 64] [--families planted mixed payload torque] [--per-family 8]
        [--fallbacks 0 0.6 0.7 0.8] [--k 8 16] [--budgets auto|N ...]
        [--extra-fallbacks auto|none|F,F ...] [--small 200]
        [--model ZIP] [--time-limit 30] [--out results/fallback] [--force] [--rows CSV]

Tasks (never the held-out suites): the tasks of :mod:`benchmarks.lookahead_top_k` (the scale
families' validation draws, searched with n_max ``max(64, band)``, and ``--small`` tasks of the
``mixed`` generator at n_max 7, each with its certified optimum). Per task, in one process
after an untimed warm-up per family and band: the shipped model's ``ppo`` (``--model``:
that model's; guided search: ``make_solver(METHOD, top_k=k, fallback=f, budget=b,
extra_fallbacks=x)``, ``auto`` the method's default) for each k, f, b and x, then the rival, each
structure verified by the exact LP; seconds are CPU seconds. Per family and band (and over
all): the tasks each variant solves of the rival's and its mean modules minus the rival's on
the tasks both solve, with a 95 % percentile bootstrap interval over the tasks (the issue's
goal: upper end <= 0; the rival's columns are named ``greedy``), drawn in ``versus.png``.
``--rows`` re-renders the page and the figure from an earlier run's rows.csv (no solving).
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from pathlib import Path

import numpy as np

from benchmarks.common import (
    Distinct,
    bench_args,
    check_model,
    check_task_rows,
    machine_description,
    made_by,
    markdown_table,
    read_rows_csv,
    run_main,
    write_csv,
)
from benchmarks.lookahead_top_k import FAMILIES, tasks_of
from benchmarks.scale_models import shown, summary, versus_greedy
from modquad_gym.core.options import int_option, path_option, real_option
from modquad_gym.core.outputs import save_figure, write_text
from modquad_gym.search.problem import check_time_limit

OUTPUTS = ("report.md", "rows.csv", "versus.png")
COLUMNS = ("band", "family", "task", "method", "found", "seconds", "optimum")
"""The columns of rows.csv, in order (what ``--rows`` reads back)."""


def variants(args) -> list[tuple[str, str, dict]]:
    """(name, method, options) of each learned variant (a given budget ends its name: -bN;
    given extra fallbacks: -xA+B, -x for none), then the rival's."""
    learned = [
        (f"{args.method}-top{k}-f{f:g}" + ("" if b is None else f"-b{b}")
         + ("" if x is None else "-x" + "+".join(f"{v:g}" for v in x)), args.method,
         {"top_k": k, "fallback": f, **({} if b is None else {"budget": b}),
          **({} if x is None else {"extra_fallbacks": x}),
          **({} if args.model is None else {"model": args.model})})
        for k in args.k for f in args.fallbacks for b in args.budgets
        for x in args.extra_fallbacks
    ]  # fmt: skip
    return [*learned, (args.rival, args.rival, {})]


def budget_option(text: str) -> int | None:
    """An argparse ``type`` for a guided budget: ``auto`` (the method's default) or a count."""
    return None if text == "auto" else int_option(1)(text)


budget_option.__name__ = "budget"


def share_option(text: str) -> float:
    """An argparse ``type`` for a fallback: a number in [0, 1]."""
    value = real_option(text)
    if not 0.0 <= value <= 1.0:
        raise argparse.ArgumentTypeError(f"must be in [0, 1], got {value:g}")
    return value


share_option.__name__ = "fallback"


def shares_option(text: str) -> tuple[float, ...] | None:
    """An argparse ``type`` for ``ppo``'s extra fallbacks: ``auto`` (its default), ``none`` or
    comma-separated numbers in [0, 1]."""
    if text in ("auto", "none"):
        return None if text == "auto" else ()
    return tuple(share_option(part) for part in text.split(","))


shares_option.__name__ = "extra fallbacks"


def measure(args) -> list[dict]:
    """A row per (task, variant): band, family, task, method, found (verified modules or None),
    CPU seconds and the task's certified optimum (small tasks; None elsewhere)."""
    from modquad_gym.scoring.suites import with_optimum
    from modquad_gym.search import verified
    from modquad_gym.solvers import make_solver

    rows, solvers, warmed = [], {}, set()
    tasks = tasks_of(args.bands, args.families, args.per_family, args.small, args.seed)
    for task, n_max, learned, palette, family, band in tasks:
        task = with_optimum(task, n_max) if family == "small" else task
        for name, method, options in variants(args):
            modules = palette if name == args.rival else learned
            key = (name, n_max, tuple(m.name for m in modules or ()))
            if key not in solvers:
                solvers[key] = make_solver(method, n_max=n_max, modules=modules,
                                           time_limit=args.time_limit, **options)  # fmt: skip
            if (key, family, band) not in warmed:  # imports, compilation, caches: untimed
                warmed.add((key, family, band))
                solvers[key].solve(task)
            cpu = time.process_time()
            r = solvers[key].solve(task)
            seconds = time.process_time() - cpu
            rows.append({"band": band, "family": family, "task": task.name, "method": name,
                         "found": r.n_modules if verified(r.structure, task) else None,
                         "seconds": round(seconds, 3),
                         "optimum": task.meta.get("optimum")})  # fmt: skip
        print(rows[-len(variants(args)) :], flush=True)
    return rows


def typed_row(raw: dict) -> dict | None:
    """A row of rows.csv typed as :func:`measure` writes it; None for values it never writes."""
    row = {**raw, "band": int(raw["band"]), "seconds": float(raw["seconds"])}
    for key in ("found", "optimum"):
        row[key] = int(raw[key]) if raw[key] != "" else None
    known = raw["family"] in (*FAMILIES, "small") and raw["task"] and raw["method"]
    counts = all(row[k] is None or row[k] >= 1 for k in ("found", "optimum"))
    # a verified answer below the certified optimum cannot be
    possible = row["found"] is None or row["optimum"] is None or row["found"] >= row["optimum"]
    sizes = 2 <= row["band"] <= 128 and 0 <= row["seconds"] < math.inf
    return row if known and counts and possible and sizes else None


def read_rows(path: Path, option: str = "--rows") -> list[dict]:
    """The rows of an earlier run's rows.csv; a one-line ValueError naming ``option``, the file
    and the 1-based row otherwise."""
    what = ("benchmarks.fallback (band 2-128, a family or small, task, method, found: at least "
            "the optimum, seconds)")  # fmt: skip
    return read_rows_csv(path, option, COLUMNS, typed_row, what)


def plot(rows: list[dict], names: list[str], rival: str, path: Path) -> None:
    """One panel per family: each variant's mean modules minus ``rival``'s per band, with its
    95 % bootstrap interval over the tasks (zero: level with the rival)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    scale = [r for r in rows if r["family"] != "small"]
    families = list(dict.fromkeys(r["family"] for r in scale))
    bands = sorted({r["band"] for r in scale})
    fig, axes = plt.subplots(1, len(families), figsize=(3.6 * len(families), 4.2), sharey=True,
                             squeeze=False)  # fmt: skip
    width = min(0.7 / max(len(names), 1), 0.15)
    for ax, family in zip(axes[0], families, strict=True):
        for k, name in enumerate(names):
            cells = [versus_greedy(scale, name, b, family, rival) for b in bands]
            xs = [i + (k - (len(names) - 1) / 2) * width for i in range(len(bands))]
            mid = np.array([c["minus_greedy_modules"] for c in cells], dtype=float)
            err = [mid - [c["low"] for c in cells], [c["high"] for c in cells] - mid]
            ax.errorbar(xs, mid, yerr=err, fmt="o", ms=4, capsize=2, lw=1, color=f"C{k % 10}",
                        label=name)  # fmt: skip
        ax.axhline(0.0, color="black", lw=0.8)
        ax.set_xticks(range(len(bands)), [str(b) for b in bands])
        ax.set_title(family, fontsize="medium")
        ax.set_xlabel("modules (band)")
        ax.grid(alpha=0.3)
    axes[0][0].set_ylabel(f"modules minus {rival}'s (mean, 95 % CI)")
    handles, labels = axes[0][0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="lower center", ncol=min(len(names), 8), fontsize=8)
    fig.tight_layout(rect=(0, 0.09, 1, 1))
    save_figure(fig, path)
    plt.close(fig)


def small_table(rows: list[dict], names) -> list[dict]:
    """Per pass on the small tasks: success and optimal share (of the certified optimum)."""
    out = []
    for name in names:
        mine = [r for r in rows if r["family"] == "small" and r["method"] == name]
        if mine:
            optimal = sum(r["found"] is not None and r["found"] == r["optimum"] for r in mine)
            out.append({"method": name, "tasks": len(mine),
                        "success_pct": round(100 * sum(r["found"] is not None for r in mine)
                                             / len(mine), 1),
                        "optimal_pct": round(100 * optimal / len(mine), 1)})  # fmt: skip
    return out


def command_line(given: list[str], rows: Path | None) -> str:
    """What made the page: the command given; with ``--rows``, the run's own command (its
    options given again) and the re-rendering."""
    run, skip = [], False
    for word in given:
        if skip or word in ("--rows", "--force"):
            skip = word == "--rows"
            continue
        run.append(word)
    command = " ".join(["python -m benchmarks.fallback", *run])
    return command if rows is None else f"{command}`, re-rendered by `... --rows {rows} --force"


def parse_args(argv: list[str] | None) -> argparse.Namespace:
    """The options, checked before any work or model load (one line, exit 2)."""
    args = bench_args(
        argv,
        "python -m benchmarks.fallback",
        __doc__.split("\n\n")[0],
        {
            "--method": {"choices": ("ppo", "ppo-guided"), "default": "ppo",
                         "help": "the learned method whose fallback is varied"},
            "--rival": {"choices": ("greedy", "beam"), "default": "greedy",
                        "help": "the method it is compared with"},
            "--bands": {"type": int_option(2, 128), "nargs": "*", "action": Distinct,
                        "default": [16, 32, 48, 64], "help": "size bands (none: only --small)"},
            "--families": {"nargs": "+", "action": Distinct, "choices": FAMILIES,
                           "default": list(FAMILIES), "help": "scale families"},
            "--per-family": {"type": int_option(1, 100), "default": 8,
                             "help": "validation draws per family"},
            "--fallbacks": {"type": share_option, "nargs": "+", "action": Distinct,
                            "default": [0.0, 0.6, 0.7, 0.8],
                            "help": "values of the fallback option, each in [0, 1]"},
            "--k": {"type": int_option(1), "nargs": "+", "action": Distinct, "default": [8, 16],
                    "help": "shortlists"},
            "--budgets": {"type": budget_option, "nargs": "+", "action": Distinct,
                          "default": [None],
                          "help": "ppo-guided's budgets: structures evaluated, or auto (its "
                                  "default; the only choice for ppo)"},
            "--extra-fallbacks": {"type": shares_option, "nargs": "+", "action": Distinct,
                                  "default": [None],
                                  "help": "ppo's extra_fallbacks: auto (its default), none, or "
                                          "comma-separated values in [0, 1]"},
            "--small": {"type": int_option(0, 10_000), "default": 200,
                        "help": "mixed tasks at n_max 7"},
            "--model": {"default": None, "metavar": "ZIP",
                        "help": "the learned variants' model (default the shipped one for "
                                "each task's budget and palette)"},
            "--time-limit": {"type": real_option, "default": 30.0,
                             "help": "seconds per task and method, in (0, a day]"},
            "--rows": {"type": path_option, "default": None, "metavar": "CSV",
                       "help": "re-render from an earlier run's rows.csv (no solving; give "
                               "the --method and --rival it used)"},
        },
        out="results/fallback",
        outputs=OUTPUTS,
    )  # fmt: skip
    try:
        check_time_limit(args.time_limit)
    except ValueError as exc:
        raise ValueError(f"--time-limit: {exc}") from None
    if args.method == "ppo" and args.budgets != [None]:
        raise ValueError("--budgets: only ppo-guided has a budget (give --method ppo-guided)")
    if args.method == "ppo-guided" and args.extra_fallbacks != [None]:
        raise ValueError("--extra-fallbacks: only ppo takes extra fallbacks (give --method ppo)")
    if args.rows is None and not (args.bands or args.small):
        raise ValueError("nothing to run: give --bands or --small > 0 (or --rows)")
    if args.model is not None:
        if args.rows is not None:
            raise ValueError("--model: --rows re-renders without solving (give one of them)")
        check_model(args.model, f"--model {args.model}")
    return args


def main(argv: list[str] | None = None) -> int:
    args = parse_args(argv)
    rows = read_rows(args.rows) if args.rows else measure(args)
    names = [m for m in dict.fromkeys(r["method"] for r in rows) if m != args.rival]
    if args.rows and (not names or args.rival not in {r["method"] for r in rows}):
        raise ValueError(f"--rows {args.rows}: no rows of --rival {args.rival} and a variant")
    scale = [r for r in rows if r["family"] != "small"]
    if args.rows:  # one row per scale task and method, each task with a row of each (the
        # small tasks are counted, not compared task by task: committed rows repeat names)
        check_task_rows(scale, [*names, args.rival], f"--rows {args.rows}")
    bands, families = (
        sorted({r["band"] for r in scale}),
        list(dict.fromkeys(r["family"] for r in scale)),
    )
    versus = summary(scale, names, bands, families, args.rival) if scale else []
    write_csv(rows, args.out / "rows.csv")
    if scale:
        plot(rows, names, args.rival, args.out / "versus.png")
    command = command_line(sys.argv[1:] if argv is None else argv, args.rows)
    small = small_table(rows, names)
    text = "\n".join([
        f"# `{args.method}`'s fallback to greedy's choice"
        + ("" if args.budgets == [None] else " and budget")
        + f", beside {args.rival}", "",
        made_by(command, "; one process") if args.rows is None else
        f"Made by `{command}` on {machine_description()}; one process; load average not "
        "recorded (re-rendered).", "", __doc__.split("\n\n", 2)[2].strip(), "",
        f"## Beside {args.rival}, per family and band", "",
        f"`minus_greedy_modules` [`low`, `high`]: mean modules minus {args.rival}'s on the tasks "
        f"both solve; `fewer`/`more`: tasks with fewer/more modules than {args.rival}; "
        f"`over_greedy_seconds`: CPU seconds over {args.rival}'s.", "",
        *([markdown_table(shown(versus)), "", "![modules beside the rival](versus.png)"] if versus
          else ["(no scale tasks)"]), "",
        *(["## Small tasks (n_max 7): success and optimal share", "", markdown_table(small), ""]
          if small else []),
    ])  # fmt: skip
    write_text(args.out / "report.md", text)
    print(text)
    return 0


if __name__ == "__main__":
    raise SystemExit(run_main(main, "fallback"))
