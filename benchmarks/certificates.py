"""Certificates of the held-out suites' certified optima: made, hashed, checked and timed.

    python -m benchmarks.certificates --out results/certificates --force

For every task of the four tiers' held-out suites (each tier's n_max and palette) and of the
fault benchmark (the first ``--fault-tasks`` tasks of its three suites, with a rotor and a module
failure, n_max 7): the certified exhaustive search (where the suites' optima come from), the
certificate made from its answer, written gzip-compressed (mtime 0: the same floats give the same
bytes) to ``--out/files/SUITE/TASK[-FAULT].json.gz`` with its sha256, and the independent
checker's verdict. On the current tier the default (anytime) search is timed too: the cost of
the certificate is reported as a share of each search's time, one process, the same run.
``--enumerated`` also proves a 10- and a 12-module optimum of the large tier structure by
structure (no level bounds) and runs the checker on them in a fresh process (seconds and peak
memory per certificate, seconds per level). Writes hashes.csv, certificates.csv, report.md.
"""

from __future__ import annotations

import argparse
import gzip
import hashlib
import json
import statistics
import subprocess
import sys
import time
from pathlib import Path

import modquad_gym as mq
from benchmarks.common import (
    RawHelpFormatter,
    bench_args,
    int_option,
    made_by,
    markdown_table,
    write_csv,
    write_text,
)
from modquad_gym import proofcheck
from modquad_gym.geometry.module import palette
from modquad_gym.scoring.tiers import get_tier
from modquad_gym.search import certificates
from modquad_gym.search.problem import SearchProblem
from modquad_gym.tasks import load_suite

SUITES_DIR = Path(mq.__file__).parent / "data" / "suites"
SCALE_TIME = 20.0
"""Seconds of the default search per scale task (``--scale``)."""
FAULT_SUITES = ("heldout_paper", "heldout_planted", "dynamic_motions")
CHILD = (
    "import json, os, sys, time\n"
    "sys.path.insert(0, os.path.dirname(sys.argv[1]))  # the checker's three files alone\n"
    "import proofcheck as pc\n"
    "levels = []; t = [time.perf_counter()]\n"
    "def report(n, how):\n"
    "    now = time.perf_counter(); levels.append([n, how, now - t[0]]); t[0] = now\n"
    "t0 = time.perf_counter(); verdict = pc.check(pc.load(sys.argv[2]), report)\n"
    "hwm = [ln for ln in open('/proc/self/status') if ln.startswith('VmHWM')][0].split()[1]\n"
    "print(json.dumps({'verdict': verdict, 'seconds': time.perf_counter() - t0, 'levels': levels,"
    " 'max_rss_mb': int(hwm) / 1024}))\n"
)


SCALE_SUITES = ("scale_16", "scale_24", "scale_32", "scale_48", "scale_64")
FAULT_TASKS = 10
"""``--fault-tasks``'s default: the first tasks of each fault suite."""
OUTPUTS = ("hashes.csv", "report.md", "certificates.csv", "files")
"""What the run writes into ``--out`` (``files/``: the certificates), refused without
``--force`` when there."""


def jobs(fault_tasks: int, limit: int | None, scale: int):
    """(tier, suite, task, n_max, palette, fault) of every certificate to make."""
    for name in ("current", "large", "mixed", "dynamic"):
        tier = get_tier(name)
        for suite in tier.suites:
            for task in load_suite(SUITES_DIR / f"{suite}.json")[:limit]:
                yield name, suite, task, tier.n_max, tier.modules, None
    for suite in FAULT_SUITES:
        for task in load_suite(SUITES_DIR / f"{suite}.json")[:fault_tasks]:
            for fault in ("rotor", "module"):
                yield "faults", suite, task, 7, None, fault
    for suite in SCALE_SUITES[: 5 if scale else 0]:
        for task in load_suite(SUITES_DIR / f"{suite}.json")[:scale]:
            yield "scale", suite, task, 64, task.meta.get("palette"), None


def certify(tier, suite, task, n_max, modules, fault, out: Path) -> dict:
    """One row: search, certificate, file, hash and check."""
    problem = SearchProblem.build(
        task, n_max=n_max, modules=None if modules is None else palette(modules), fault=fault
    )
    t0 = time.perf_counter()
    if tier == "scale":  # beyond the exhaustive search: the default one, certified or not
        result = mq.anytime_search.solve(problem, time_limit=SCALE_TIME, seed=0)
    else:
        result = mq.exhaustive_search.solve(problem)
    search = time.perf_counter() - t0
    if not result.certified:
        return {"tier": tier, "suite": suite, "task": task.name, "certified": False}
    row = {"tier": tier, "suite": suite, "task": task.name, "fault": fault or "",
           "minimum": result.n_modules, "certified": result.certified}  # fmt: skip
    t0 = time.perf_counter()
    try:
        cert = certificates.make(result, problem)
    except certificates.CertificateError as exc:
        return {**row, "certified": False, "why": str(exc)}
    make = time.perf_counter() - t0
    default = None
    if tier == "current":
        t0 = time.perf_counter()
        mq.anytime_search.solve(problem, time_limit=10.0, seed=0)
        default = time.perf_counter() - t0
    path = out / "files" / suite / f"{task.name}{'-' + fault if fault else ''}.json.gz"
    path.parent.mkdir(parents=True, exist_ok=True)
    data = gzip.compress(json.dumps(cert, separators=(",", ":")).encode(), mtime=0)
    path.write_bytes(data)
    t0 = time.perf_counter()
    verdict = proofcheck.check(proofcheck.load(str(path)))
    check = time.perf_counter() - t0
    levels = ",".join("bound" if "bound" in e else str(len(e["direction"])) for e in cert["levels"])
    return {**row, "levels": levels, "directions": len(cert["directions"]),
            "bytes": len(data), "sha256": hashlib.sha256(data).hexdigest(),
            "search_s": search, "default_s": default, "make_s": make, "check_s": check,
            "valid": verdict.startswith("valid"), "file": str(path.relative_to(out))}  # fmt: skip


def enumerated(out: Path) -> list[dict]:
    """A 10- and a 12-module optimum of the large tier proved structure by structure, checked
    in a fresh process that loads only the checker."""
    rows = []
    tasks = load_suite(SUITES_DIR / "large_planted.json")
    for size in (10, 12):
        task = next(t for t in tasks if t.meta.get("optimum") == size)
        problem = SearchProblem.build(task, n_max=size)
        result = mq.exhaustive_search.solve(problem)
        for bounds in (True, False):
            path = (
                out
                / "files"
                / "enumerated"
                / f"{task.name}-{'bounds' if bounds else 'none'}.json.gz"
            )
            path.parent.mkdir(parents=True, exist_ok=True)
            t0 = time.perf_counter()
            certificates.write(result, problem, path, force=True, bounds=bounds)
            make = time.perf_counter() - t0
            child = subprocess.run([sys.executable, "-c", CHILD, proofcheck.__file__, str(path)],
                                   capture_output=True, text=True, check=True)  # fmt: skip
            got = json.loads(child.stdout)
            rows.append({"task": task.name, "minimum": size, "level bounds": bounds,
                         "bytes": path.stat().st_size, "make_s": make,
                         "check_s": got["seconds"], "max_rss_mb": got["max_rss_mb"],
                         "valid": got["verdict"].startswith("valid"),
                         "per level (n: structures, s)": per_level(got["levels"])})  # fmt: skip
            print(f"{task.name} bounds={bounds}: check {got['seconds']:.2f} s", file=sys.stderr)
    return rows


def per_level(levels: list) -> str:
    """``n: structures or bound, seconds`` of each level the checker reported."""
    return "; ".join(f"{n}: {how.split()[0]}, {s:.2f}" for n, how, s in levels)


def summary(rows: list[dict]) -> list[str]:
    lines = ["| tier | certificates | valid | median make / search | total make / search | "
             "median check (s) | median size (kB) |", "|---|---|---|---|---|---|---|"]  # fmt: skip
    for tier in dict.fromkeys(r["tier"] for r in rows):
        rs = [r for r in rows if r["tier"] == tier]
        ratio = statistics.median(r["make_s"] / r["search_s"] for r in rs)
        total = sum(r["make_s"] for r in rs) / sum(r["search_s"] for r in rs)
        lines.append(
            f"| {tier} | {len(rs)} | {sum(r['valid'] for r in rs)} | {ratio:.0%} | {total:.0%} | "
            f"{statistics.median(r['check_s'] for r in rs):.3f} | "
            f"{statistics.median(r['bytes'] for r in rs) / 1e3:.1f} |"
        )
    current = [r for r in rows if r["tier"] == "current"]
    if current:
        ratio = statistics.median(r["make_s"] / r["default_s"] for r in current)
        total = sum(r["make_s"] for r in current) / sum(r["default_s"] for r in current)
        lines += ["", f"Current tier against the default (anytime) search: median make / search "
                      f"{ratio:.0%}, total {total:.0%}."]  # fmt: skip
    return lines


def command_line(args: argparse.Namespace) -> str:
    """The command that makes this page: every option that changes what it covers."""
    return (
        "python -m benchmarks.certificates"
        + (f" --limit {args.limit}" if args.limit is not None else "")
        + (f" --fault-tasks {args.fault_tasks}" if args.fault_tasks != FAULT_TASKS else "")
        + (" --enumerated" if args.enumerated else "")
        + (f" --scale {args.scale}" if args.scale else "")
        + f" --out {args.out} --force"
    )


def main(argv: list[str] | None = None) -> int:
    args = bench_args(
        argv, "python -m benchmarks.certificates", __doc__,
        {"--fault-tasks": {"type": int_option(0), "default": FAULT_TASKS,
                           "help": f"tasks per fault suite (default {FAULT_TASKS})"},
         "--limit": {"type": int_option(1), "default": None,
                     "help": "first tasks of each tier suite (default all)"},
         "--enumerated": {"action": "store_true", "help": "also the 10/12-module checks"},
         "--scale": {"type": int_option(0), "default": 0, "help": "also the first N tasks of "
                     "each scale suite of 16-64 modules, the default search (20 s), where "
                     "certified (default 0)"}},
        seed_help=None, out="results/certificates", outputs=OUTPUTS,
        formatter_class=RawHelpFormatter,  # the docstring's own lines
    )  # fmt: skip
    rows, uncertified = [], []
    for job in jobs(args.fault_tasks, args.limit, args.scale):
        r = certify(*job, args.out)
        if not r["certified"]:
            uncertified.append(
                f"{r['suite']}/{r['task']}" + (f" ({r['why']})" if "why" in r else "")
            )
            continue
        rows.append(r)
        print(f"{r['suite']} {r['task']} {r['fault']}: {r['minimum']} modules, make "
              f"{r['make_s']:.3f} s, search {r['search_s']:.3f} s", file=sys.stderr)  # fmt: skip
    keys = ("tier", "suite", "task", "fault", "minimum", "levels", "bytes", "sha256", "file")
    write_csv([{k: r[k] for k in keys} for r in rows], args.out / "hashes.csv")
    write_csv(rows, args.out / "certificates.csv")
    lines = ["# Certificates of the held-out suites' certified optima", "",
             made_by(command_line(args), "; one process"), "",
             "Each certificate is made after the certified exhaustive search from its answer "
             "(make / search: its cost as a share of the search's time), written gzip-compressed "
             "to files/ (sha256 in hashes.csv; `modquad check FILE` verifies one) and checked "
             "by modquad_gym/proofcheck.py. Levels: `bound` where a level bound covers the "
             "level, else the number of structures proved one by one.", "",
             *summary(rows)]  # fmt: skip
    if uncertified:
        lines += ["", "No certificate (not certified by the default search in "
                  f"{SCALE_TIME:g} s, or a level beyond bounds and enumeration): "
                  + "; ".join(uncertified) + "."]  # fmt: skip
    if args.enumerated:
        lines += ["", "## Checking large optima (a fresh process that loads only the checker)",
                  "", markdown_table(enumerated(args.out), ".2f")]  # fmt: skip
    write_text(args.out / "report.md", "\n".join(lines) + "\n")
    print(f"wrote {args.out / 'report.md'}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    from benchmarks.common import run_main

    raise SystemExit(run_main(main, "certificates"))
