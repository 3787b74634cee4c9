"""``modquad check``: verify a certificate with the independent checker
(:mod:`modquad_gym.proofcheck`)."""

from __future__ import annotations

import argparse
import time

from modquad_gym.cli.common import add_command
from modquad_gym.core.options import path_option


def add_check(sub) -> None:
    p = add_command(
        sub,
        "check",
        cmd_check,
        help="verify a certificate of a minimum structure (written by solve --certificate)",
        description="Verify a certificate written by `modquad solve --certificate FILE` with "
        "the independent checker modquad_gym/proofcheck.py and its format, "
        "proofcheck_format.py (numpy only, no other part of the package): it reads every field "
        "strictly (an unknown key or a value of the wrong type is refused), rebuilds every "
        "configuration matrix from the rotor data in the file, checks the answer's thrusts for "
        "every task wrench, enumerates every smaller structure itself and checks each one's "
        "separating direction (or the bound that covers its level). Prints 'valid: ...' (exit "
        "0) or 'invalid: ' and the first thing that fails (exit 1); a file that is not a "
        "certificate exits 2, with one line naming the field. The format and the checker's "
        "argument: docs/certificates.md.",
    )
    p.add_argument(
        "file", metavar="FILE", type=path_option, help="the certificate (.json, or .json.gz)"
    )
    p.add_argument(
        "--levels",
        action="store_true",
        help="also print how each smaller level was proved and how long its check took (one "
        "line per level on stdout, before the verdict)",
    )


def cmd_check(args: argparse.Namespace) -> int:
    from modquad_gym import proofcheck

    start = [time.perf_counter()]

    def report(n: int, how: str) -> None:
        now = time.perf_counter()
        if args.levels:
            print(f"level {n}: {how} ({now - start[0]:.2f} s)")  # what was asked: stdout
        start[0] = now

    try:  # a file that is not a certificate: CertificateFormatError (a ValueError), exit 2
        print(proofcheck.check_file(args.file, report))
    except proofcheck.ProofError as exc:
        print(f"invalid: {exc}")
        return 1
    return 0
