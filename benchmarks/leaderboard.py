"""The leaderboard: every method on every benchmark tier, ranked at a stated time budget per task.

    python -m benchmarks.leaderboard --force

reads the committed data files and writes ``results/leaderboard.md``, ``results/leaderboard.csv``,
``results/leaderboard.png`` (optimal share against seconds per task),
``results/leaderboard_anytime.png`` (the share of tasks answered optimally within t seconds,
against t; both drawn by :mod:`benchmarks.leaderboard_figures`) and the documentation page
``docs/leaderboard.md`` (no number is typed by hand):

* the learned methods over five training seeds from ``results/seeds_<tier>/seeds.csv`` (one row
  per seed, method and suite): each seed's scores pooled over the tier's held-out tasks, the
  mean over seeds with a 95 % percentile bootstrap interval over seeds; their oracle calls and
  optimal share within the budget from the shipped model's one run in the tier report;
* the searches (one deterministic run; random and genetic seeded) from the one-run tier reports
  ``results/tier_<tier>/benchmark.csv`` (one row per method and task), and, for the searches a
  tier report did not run, from ``results/leaderboard_searches.csv``, which
  ``python -m benchmarks.leaderboard --rescore-searches --force`` fills by running just those
  searches on the tier's held-out suites (seconds, not hours: no training, no learned method);
* the anytime search's history (when its best structure so far first had the optimal count) from
  ``results/leaderboard_anytime.csv`` (``--anytime-history`` runs it again; with ``--out``,
  into that folder, as ``--rescore-searches`` does, so the committed data stay);
* outside agents' submissions, ``results/submissions/*.csv`` (the ``submission.csv`` that
  ``--solver`` writes), over their seeds like the learned methods.

Add your own agent (scored now on every tier, beside the committed rows; nothing committed
changes)::

    python -m benchmarks.leaderboard --solver my_agent:Agent --out my_board

It follows the protocol of ``modquad score --solver`` (docs/benchmarks.md, "Score your own
agent"): told each tier's n_max and the run's seed, counted through the evaluator it is handed.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from benchmarks.common import Distinct, HelpFormatter, hold_out
from benchmarks.leaderboard_entries import (
    ANYTIME,
    BUDGET,
    COMMAND,
    RESCORED,
    RESULTS,
    ROOT,
    SUBMISSION,
    TIERS,
    curves,
    one_run_rows,
    read_anytime,
    submission_entries,
    tier_entries,
)
from benchmarks.leaderboard_figures import plot, plot_curves
from benchmarks.leaderboard_page import page
from benchmarks.leaderboard_scoring import (
    anytime_history,
    rescore_searches,
    score_agent,
    write_submission,
)
from modquad_gym.core.options import OneLineParser, nonempty_option, path_option

DOCS = ROOT / "docs"
OUTPUTS = ("leaderboard.md", "leaderboard.csv", "leaderboard.png", "leaderboard_anytime.png",
           SUBMISSION)  # fmt: skip


def build(tiers: list[str], out: Path, docs: Path | None, records: list[dict] | None = None,
          results: Path = RESULTS, data: dict[str, Path] | None = None) -> Path:  # fmt: skip
    """Write the leaderboard of the committed entries into ``out`` (and the documentation page
    into ``docs``); ``records`` (an outside agent scored now) are written as ``out``'s
    submission file and ranked beside them. ``data``: the files of :data:`RESCORED` or
    :data:`ANYTIME` this run wrote elsewhere (into ``--out``) by name, read instead of
    ``results``' ones."""
    from modquad_gym.core.outputs import write_csv, write_text
    from modquad_gym.scoring.tiers import get_tier

    def where(name: str) -> Path:
        return (data or {}).get(name, results / name)

    entries = [e for t in tiers for e in tier_entries(t, results, rescored=where(RESCORED))]
    if records:
        path = write_submission(records, out / SUBMISSION)
        for t in tiers:
            full = max((e.full for e in entries if e.tier == t and not e.status), default=0)
            entries += submission_entries(path, get_tier(t), full)
    write_csv([e.as_csv() for e in entries], out / "leaderboard.csv")
    history = read_anytime(where(ANYTIME))
    series = {}
    for t in tiers:
        tier = get_tier(t)
        by = {m: rows for m, (rows, _) in one_run_rows(tier, results, where(RESCORED)).items()}
        series[t] = curves(tier, by, history.get(t, []))
    plot(entries, tiers, out / "leaderboard.png")
    plot_curves(series, BUDGET, out / "leaderboard_anytime.png")
    path = write_text(out / "leaderboard.md", page(entries, tiers, "leaderboard.png", ""))
    if docs is not None:
        write_text(docs / "leaderboard.md", page(entries, tiers, "results/leaderboard.png",
                                                 "results/"))  # fmt: skip
    return path


def main(argv: list[str] | None = None) -> int:
    p = parser()
    args = p.parse_args(argv)
    check_args(p, args)
    try:
        records = first_runs(args)
    except ValueError as err:
        p.error(str(err))
    except KeyboardInterrupt:
        print(f"{COMMAND}: interrupted; nothing written", file=sys.stderr)
        return 130
    out = args.out or RESULTS
    docs = DOCS if args.out is None else None
    ran = {RESCORED: args.rescore_searches, ANYTIME: args.anytime_history}
    data = {name: out / name for name, done in ran.items() if done}  # this run's data
    path = build(args.tiers, out, docs, records, data=data)
    print(path.read_text())
    return 0


def parser() -> argparse.ArgumentParser:
    """The command's options: what to run first, an outside agent to score, where to write."""
    from modquad_gym.core.options import int_option

    p = OneLineParser(
        prog=COMMAND, description=__doc__.split("\n\n")[0], formatter_class=HelpFormatter
    )
    p.add_argument(
        "--rescore-searches",
        action="store_true",
        help=f"first run the searches the tier reports lack into {RESCORED} in --out "
        "(default results/), and rank them from there",
    )
    p.add_argument(
        "--anytime-history",
        action="store_true",
        help=f"first run the anytime search on every tier's tasks into {ANYTIME} in --out "
        "(default results/), and draw it from there",
    )
    p.add_argument(
        "--solver",
        type=nonempty_option,
        metavar="PKG.MOD:NAME",
        default=None,
        help="also score this outside agent on every tier (needs --out; a clone of the "
        "repository: `modquad score --solver` works from the wheel, one tier at a time)",
    )
    p.add_argument(
        "--seeds",
        nargs="+",
        action=Distinct,
        type=int_option(0),
        default=None,
        help="with --solver: the seeds it is run with (default 0 1 2 3 4; one run when it "
        "takes no seed)",
    )
    p.add_argument(
        "--tiers",
        nargs="+",
        action=Distinct,
        choices=TIERS,
        default=list(TIERS),
        help="tiers to show (default all)",
    )
    p.add_argument(
        "--limit",
        type=int_option(1),
        default=None,
        help="with --solver: the first N tasks of each suite (the row is marked partial)",
    )
    p.add_argument(
        "--out",
        type=path_option,
        default=None,
        help="folder for the leaderboard (default: results/ and docs/leaderboard.md; "
        "required with --solver, so the committed page stays the committed data's)",
    )
    p.add_argument(
        "--force",
        action="store_true",
        help="replace the leaderboard's files in --out (without --out: the committed pages "
        "results/leaderboard.*, docs/leaderboard.md) and, with --rescore-searches or "
        f"--anytime-history, {RESCORED} or {ANYTIME} there; default: refuse",
    )
    p.add_argument("--no-progress", action="store_true", help="no progress bars")
    return p


def check_args(p: argparse.ArgumentParser, args: argparse.Namespace) -> None:
    """Options that do not go together, and every file the run would write, checked before
    any work (``p.error``: one line, exit 2); the folders are held until the run ends."""
    if args.solver and args.out is None:
        p.error("--solver needs --out: the committed leaderboard holds committed data only")
    if args.out is None and sorted(args.tiers) != sorted(TIERS):
        p.error("--tiers needs --out: the committed leaderboard holds every tier")
    for flag, value in (("--limit", args.limit), ("--seeds", args.seeds)):
        if value is not None and not args.solver:
            p.error(f"{flag} goes with --solver")
    args.seeds = args.seeds or [0, 1, 2, 3, 4]
    written = OUTPUTS if args.solver else OUTPUTS[:-1]
    data = (RESCORED,) * args.rescore_searches + (ANYTIME,) * args.anytime_history
    data += tuple(Path(n).with_suffix(".md").name for n in data)  # each with its note
    try:  # held until the run ends: a second run into them is refused at once
        if args.out is None:
            hold_out(RESULTS, written + data, args.force)
            hold_out(DOCS, ("leaderboard.md",), args.force)
        else:  # the runs' data go to --out too: the committed data stay
            hold_out(args.out, written + data, args.force)
    except ValueError as err:
        p.error(str(err))


def first_runs(args: argparse.Namespace) -> list[dict] | None:
    """The runs asked for before the page is built: the rescored searches, the anytime
    history, and the outside agent's records (None without ``--solver``)."""
    into = args.out or RESULTS  # the committed data are replaced only without --out
    if args.rescore_searches:
        path = rescore_searches(progress=not args.no_progress, into=into)
        args.rescore_searches = path is not None  # the page reads the file written, if any
        if path is not None:
            print(path)
    if args.anytime_history:
        print(anytime_history(into, progress=not args.no_progress))
    if not args.solver:
        return None
    return score_agent(args.solver, args.tiers, args.limit, args.seeds, not args.no_progress)


if __name__ == "__main__":
    from benchmarks.common import run_main

    raise SystemExit(run_main(main, "leaderboard"))
