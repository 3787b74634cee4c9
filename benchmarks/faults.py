"""The price of fault tolerance: how many more modules a structure needs to keep doing its task
after a failure, with thrust to spare for a late detection, and how it flies through it.

    python -m benchmarks.faults --fly --out results/faults

For the first ``--per-suite`` tasks of each suite of ``--suites`` (the fault tier's suite and
the held-out paper-like, planted and dynamic suites; none of them seen by the margin's
calibration, benchmarks/fault_delay.py), the default search's minimum for each design of
:data:`DESIGNS`: intact; surviving any rotor, any module, any two rotors; surviving a rotor or
a module with the margin :func:`~modquad_gym.oracle.fault_delay.margin_for_delay` derives from
a 20 ms and a 50 ms detection delay. Each answer is re-verified (HiGHS on every failed matrix for
one failure) and timed. ``--fly`` flies each fault design through its worst failure in MuJoCo
with the controller told 20 ms and 50 ms late, and with the in-flight detector told nothing
(:class:`~modquad_gym.sim.detector.FailureDetector`, default sensor noise), and hovers each 60 s
intact with the detector on (false alarms). The oracle section times ``tolerates`` against
``feasible`` on a 7-module structure, one core. Writes report.md, faults.csv, oracle.csv and
price.png (extra modules against the delay designed for) into ``--out``.

A full run takes longer than one sitting: ``--update`` replaces only the rows (suite, task,
design) it makes and keeps the others of faults.csv (each row names the command that made it);
``--skip`` continues a suite where an earlier run stopped.
"""

from __future__ import annotations

import argparse
import fcntl
import os
import sys
from pathlib import Path

from benchmarks.common import Distinct, HelpFormatter, add_force, command_as_run, run_main
from benchmarks.faults_measure import (
    DESIGNS,
    SUITES,
    explain_missing,
    merged,
    oracle_speed,
    price,
    read_rows,
)
from benchmarks.faults_report import plot, report
from modquad_gym.cli.common import N_MAX_OPTION, time_limit_option
from modquad_gym.core.options import OneLineParser, int_option, path_option, real_option
from modquad_gym.core.outputs import OutputError, check_output_dir, write_csv

OUTPUTS = ("report.md", "faults.csv", "oracle.csv", "price.png")


def parse_args(argv: list[str] | None) -> argparse.Namespace:
    """The options, checked before any work (argparse's error, exit 2)."""
    parser = OneLineParser(
        prog="python -m benchmarks.faults",
        description=__doc__.split("\n\n")[0],
        formatter_class=HelpFormatter,
    )
    parser.add_argument("--suites", nargs="+", action=Distinct, choices=SUITES,
                        default=list(SUITES), help="suites (default all four)")  # fmt: skip
    parser.add_argument("--per-suite", type=int_option(1), default=10,
                        help="tasks per suite (default 10)")  # fmt: skip
    parser.add_argument(
        "--skip",
        type=int_option(0),
        default=0,
        help="leave out the first SKIP of them (a run that continues another; default 0)",
    )
    parser.add_argument("--designs", nargs="+", action=Distinct, choices=list(DESIGNS),
                        default=list(DESIGNS), help="designs (default all)")  # fmt: skip
    parser.add_argument("--n-max", type=N_MAX_OPTION, default=12,
                        help="module budget (default 12)")  # fmt: skip
    parser.add_argument("--time-limit", type=time_limit_option, default=10.0,
                        help="seconds per search (default 10)")  # fmt: skip
    parser.add_argument(
        "--rotor2-time-limit",
        type=time_limit_option,
        default=30.0,
        help="seconds per two-rotor search (default 30: the issue's goal)",
    )
    parser.add_argument("--fly", action="store_true", help="fly the fault designs in MuJoCo")
    parser.add_argument(
        "--intact-seconds",
        type=real_option,
        default=60.0,
        help="seconds of the intact hover with the detector (default 60)",
    )
    parser.add_argument(
        "--update",
        action="store_true",
        help="keep the rows of faults.csv in --out that this run does not make",
    )
    parser.add_argument("--oracle-only", action="store_true",
                        help="measure only the oracle's speed again and rewrite the report from "
                        "the faults.csv already in --out")  # fmt: skip
    parser.add_argument(
        "--out", type=path_option, default=Path("results/faults"), help="report folder"
    )
    add_force(parser)
    args = parser.parse_args(argv)
    if args.skip >= args.per_suite:
        parser.error(f"--skip must be below --per-suite ({args.per_suite}), got {args.skip}")
    if not 0 < args.intact_seconds <= 3600:
        parser.error(f"--intact-seconds must lie in (0, 3600], got {args.intact_seconds:g}")
    if args.oracle_only and args.fly:
        parser.error("--oracle-only rewrites the report from the rows in --out without "
                     "searching or flying; leave out --fly")  # fmt: skip
    if (args.oracle_only or args.update) and not (args.out / "faults.csv").is_file():
        parser.error(f"--{'oracle-only' if args.oracle_only else 'update'}: no faults.csv in "
                     f"{args.out} to keep rows from (run once without it)")  # fmt: skip
    try:
        check_output_dir(args.out, OUTPUTS, args.force)
    except OutputError as exc:
        parser.error(str(exc))
    return args


def main(argv: list[str] | None = None) -> int:
    args = parse_args(argv)
    reread = "--oracle-only" if args.oracle_only else "--update" if args.update else None
    earlier = args.out / "faults.csv"
    if reread:  # a damaged file is refused in one line before the searches, not after them
        read_rows(earlier, reread)
    args.out.mkdir(parents=True, exist_ok=True)
    command = command_as_run("faults", argv)
    new = [] if args.oracle_only else price(args, command)
    speed = oracle_speed()
    lock = os.open(args.out, os.O_RDONLY)  # runs in parallel merge one at a time (the folder
    try:  # is locked: faults.csv itself is replaced, atomically, by each run)
        fcntl.flock(lock, fcntl.LOCK_EX)
        rows = merged(read_rows(earlier, reread) if reread else [], new)
        explain_missing(rows)
        write_csv(rows, earlier)
        write_csv(speed, args.out / "oracle.csv")
        plot(args.out / "price.png", rows)
        report(args.out, rows, speed, args)
    finally:
        os.close(lock)
    print(f"wrote {args.out}/report.md", file=sys.stderr)
    return 0


if __name__ == "__main__":
    raise SystemExit(run_main(main, "faults"))
