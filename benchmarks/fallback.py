"""The learned methods' fallback to greedy's choice (their option ``fallback``): modules
beside a rival per scale family and band, and the optimal share on small tasks, for each
fallback and shortlist (``top_k``), on validation draws only.

    python -m benchmarks.fallback [--method ppo|ppo-guided] [--rival greedy|beam]
        [--bands 16 32 48 64] [--families planted mixed payload torque] [--per-family 8]
        [--fallbacks 0 0.6 0.7 0.8] [--k 8 16] [--small 200] [--time-limit 30]
        [--out results/fallback] [--force]

Tasks (never the held-out suites): the tasks of :mod:`benchmarks.lookahead_top_k` (the scale
families' validation draws, searched with n_max ``max(64, band)``, and ``--small`` tasks of the
``mixed`` generator at n_max 7, each with its certified optimum). Per task, in one process
after an untimed warm-up per family and band: the shipped model's single pass (or guided
search: ``make_solver(METHOD, top_k=k, fallback=f)``) for each k and f, then the rival, each
structure verified by the exact LP; seconds are CPU seconds. Per family and band (and over
all): the tasks each variant solves of the rival's and its mean modules minus the rival's on
the tasks both solve, with a 95 % percentile bootstrap interval over the tasks (the issue's
goal: upper end <= 0; the rival's columns are named ``greedy``).
"""

from __future__ import annotations

import argparse
import sys
import time

from benchmarks.common import bench_args, made_by, markdown_table, run_main, write_csv
from benchmarks.lookahead_top_k import FAMILIES, tasks_of
from benchmarks.scale_models import summary
from modquad_gym.core.options import int_option, real_option
from modquad_gym.core.outputs import write_text
from modquad_gym.search.problem import check_time_limit

OUTPUTS = ("report.md", "rows.csv")


def variants(args) -> list[tuple[str, str, dict]]:
    """(name, method, options) of each learned variant, then the rival's."""
    learned = [(f"{args.method}-top{k}-f{f:g}", args.method, {"top_k": k, "fallback": f})
               for k in args.k for f in args.fallbacks]  # fmt: skip
    return [*learned, (args.rival, args.rival, {})]


def share_option(text: str) -> float:
    """An argparse ``type`` for a fallback: a number in [0, 1]."""
    value = real_option(text)
    if not 0.0 <= value <= 1.0:
        raise argparse.ArgumentTypeError(f"must be in [0, 1], got {value:g}")
    return value


share_option.__name__ = "fallback"


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


def main(argv: list[str] | None = None) -> int:
    args = bench_args(
        argv,
        "python -m benchmarks.fallback",
        __doc__.split("\n\n")[0],
        {
            "--method": {"choices": ("ppo", "ppo-guided"), "default": "ppo"},
            "--rival": {"choices": ("greedy", "beam"), "default": "greedy"},
            "--bands": {"type": int_option(2, 128), "nargs": "*", "default": [16, 32, 48, 64]},
            "--families": {"nargs": "+", "choices": FAMILIES, "default": list(FAMILIES)},
            "--per-family": {"type": int_option(1, 100), "default": 8,
                             "help": "validation draws per family"},
            "--fallbacks": {"type": share_option, "nargs": "+", "default": [0.0, 0.6, 0.7, 0.8],
                            "help": "values of the fallback option, each in [0, 1]"},
            "--k": {"type": int_option(1), "nargs": "+", "default": [8, 16], "help": "shortlists"},
            "--small": {"type": int_option(0, 10_000), "default": 200,
                        "help": "mixed tasks at n_max 7"},
            "--time-limit": {"type": real_option, "default": 30.0,
                             "help": "seconds per task and method, in (0, a day]"},
        },
        out="results/fallback",
        outputs=OUTPUTS,
    )  # fmt: skip
    try:
        check_time_limit(args.time_limit)
    except ValueError as exc:
        raise ValueError(f"--time-limit: {exc}") from None
    rows = measure(args)
    names = [name for name, _, _ in variants(args)][:-1]
    scale = [r for r in rows if r["family"] != "small"]
    versus = summary(scale, names, args.bands, args.families, args.rival) if scale else []
    write_csv(rows, args.out / "rows.csv")
    given = sys.argv[1:] if argv is None else argv
    command = "python -m benchmarks.fallback " + " ".join(given)
    small = small_table(rows, names)
    text = "\n".join([
        f"# `{args.method}`'s fallback to greedy's choice, beside {args.rival}", "",
        made_by(command.strip(), "; one process"), "", __doc__.split("\n\n", 2)[2].strip(), "",
        f"## Beside {args.rival}, per family and band", "",
        f"`minus_greedy_modules` [`low`, `high`]: mean modules minus {args.rival}'s on the tasks "
        f"both solve; `fewer`/`more`: tasks with fewer/more modules than {args.rival}; "
        f"`over_greedy_seconds`: CPU seconds over {args.rival}'s.", "",
        markdown_table(versus) if versus else "(no scale tasks)", "",
        *(["## Small tasks (n_max 7): success and optimal share", "", markdown_table(small), ""]
          if small else []),
    ])  # fmt: skip
    write_text(args.out / "report.md", text)
    print(text)
    return 0


if __name__ == "__main__":
    raise SystemExit(run_main(main, "fallback"))
