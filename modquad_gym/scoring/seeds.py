"""Learned agents over training seeds: interquartile mean with 95 % bootstrap intervals.

A single training seed is not a result (Henderson et al. 2018; Agarwal et al. 2021). ``python -m
modquad_gym.scoring.seeds RUNS --tier T`` scores the model of every ``RUNS/seed-*`` folder (from
``python train.py --seeds ...``; at least two) with each learned method on the tier's held-out
suites, the searches once as the reference, and writes to ``--out``
(:mod:`.seeds_report`):

* ``seeds.md``: per method and metric the IQM and the mean over seeds of each seed's score on
  the tier's held-out tasks (the suites weighted by their task counts, as the leaderboard
  counts it), each with its 95 % percentile bootstrap interval over the seeds, per suite, and
  the tier's goals (:attr:`.tiers.Tier.goals`) judged on the interval's pessimistic end (the
  lower end of a share, the upper end of configurations);
* ``seeds.csv``: one row per (seed, method, suite) with the suite-level figures (success,
  optimal share, configurations and seconds per task, mean modules over the solved tasks);
* ``seeds.png``: the intervals as bars.
"""

from __future__ import annotations

import sys
import time
from collections.abc import Sequence
from pathlib import Path

from modquad_gym.core.options import OneLineParser
from modquad_gym.core.outputs import check_output_dir, hold_output_dir
from modquad_gym.scoring.agents import SEARCH_METHODS, run_benchmark
from modquad_gym.scoring.seed_runs import LIMIT, check_limit, check_runs, find_runs, learned_methods
from modquad_gym.scoring.seed_scores import SeedScore
from modquad_gym.scoring.seeds_report import write_report
from modquad_gym.scoring.tiers import TIERS, Tier, get_tier, honours_fault

SEED_FILES = ("seeds.md", "seeds.csv", "seeds.png")


def score_runs(
    runs: dict[str, Path],
    tier_name: str,
    methods: Sequence[str] | None = None,
    limit: int | None = None,
    progress: bool = True,
) -> list[SeedScore]:
    """Every run's model (``runs``: seed label -> model.zip) with every learned method (default
    the tier's), and the searches once (seed label ``-``), on the tier's held-out suites, scored
    per suite on the tasks whose certified optimum is within the tier's n_max. On a tier with a
    failure every method designs for it and a success survives it; the searches that cannot
    honour it are left out (:func:`~.tiers.honours_fault`). The methods, ``limit`` and every
    run are checked first, as the command line checks them (:mod:`.seed_runs`): a ValueError
    before any work."""
    tier = get_tier(tier_name)
    methods = learned_methods(methods, tier)
    check_limit(limit)
    check_runs(runs, methods, tier)
    return scored(runs, tier, methods, limit, progress)


def scored(
    runs: dict[str, Path], tier: Tier, methods: list[str], limit: int | None, progress: bool
) -> list[SeedScore]:
    """:func:`score_runs` on inputs it has checked."""
    suites = tier.load_suites(limit)
    scores: list[SeedScore] = []
    searches = [m for m in SEARCH_METHODS if tier.fault is None or honours_fault(m)]
    plan = [("-", None, searches)]
    plan += [(label, path, methods) for label, path in runs.items()]
    for label, model, ms in plan:
        rows = run_benchmark(suites, ms, tier.n_max, model, None, progress, 1, tier.modules,
                             tier.name, tier.fault)  # fmt: skip
        for m in ms:
            for suite in suites:
                rs = [
                    r
                    for r in rows
                    if r.method == m
                    and r.suite == suite
                    and r.optimum is not None
                    and r.optimum <= tier.n_max
                ]
                if rs:
                    scores.append(SeedScore.of(label, m, suite, rs))
    return scores


def main(argv: list[str] | None = None) -> int:
    p = OneLineParser(
        prog="python -m modquad_gym.scoring.seeds",
        description="Score every seed's model of a `train.py --seeds` folder on a tier's "
        "held-out suites and report the IQM and mean with 95 % bootstrap intervals.",
    )
    p.add_argument("runs", type=Path, nargs="+", help="folders with seed-*/model.zip")
    p.add_argument("--tier", choices=tuple(TIERS), default="current", help="(default current)")
    p.add_argument(
        "--methods",
        nargs="+",
        default=None,
        help="learned methods (default the tier's: ppo ppo-k8 ppo-guided, and on the large "
        "tier also ppo-guided-b256-w8)",
    )
    p.add_argument("--out", type=Path, default=None, help="report folder (default RUNS/report)")
    p.add_argument("--limit", type=LIMIT, default=None, help="first N tasks per suite")
    p.add_argument("--force", action="store_true", help="replace an existing report")
    p.add_argument("--no-progress", action="store_true", help="no progress bars")
    args = p.parse_args(argv)
    try:  # everything the work needs, before it starts (a model that does not load included)
        tier = get_tier(args.tier)
        methods = learned_methods(args.methods, tier)
        runs = find_runs(args.runs)
        out = args.out or args.runs[0] / "report"
        check_output_dir(out, SEED_FILES, args.force, "--out")
        check_runs(runs, methods, tier)
    except ValueError as exc:
        p.error(str(exc))
    argv_text = " ".join(argv if argv is not None else sys.argv[1:])
    command = f"python -m modquad_gym.scoring.seeds {argv_text}"
    with hold_output_dir(out, SEED_FILES, args.force, "--out"):  # a second run: refused at once
        t0 = time.perf_counter()
        scores = scored(runs, tier, methods, args.limit, not args.no_progress)
        path = write_report(scores, args.tier, out, runs, command, time.perf_counter() - t0)
    print(path.read_text())
    return 0


if __name__ == "__main__":
    from modquad_gym.core.interrupts import run_command

    raise SystemExit(run_command(main, "python -m modquad_gym.scoring.seeds"))
