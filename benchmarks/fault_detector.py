"""The in-flight failure detector on the fault designs of results/faults/, flown again.

    python -m benchmarks.fault_detector --suites heldout_paper --out results/fault_detector

For each row of ``--faults`` (results/faults/faults.csv) that has a detector flight, of the suites
``--suites`` and the designs ``--designs``: the design's search again
(:func:`benchmarks.faults_measure.design`, the row's n_max and its run's time limit) and its flight
through its smallest-margin failure (``failure="worst"``) with the detector told nothing (default
sensor noise), as ``python -m benchmarks.faults --fly`` flies it. Where the detector revised its
first decision the same structure is flown again with ``DetectorConfig(revise=False)`` (the first
decision stands, as the detector of faults.csv's runs did): the ``*_unrevised`` columns. The
``*_before`` columns are faults.csv's own; faults.csv keeps no cells, so a time-limited search may
have found another structure of the same size and worst margin (``same_design`` compares only
those). Cheaper than that benchmark: no flights at fixed delays, no intact hovers, no oracle
timing. ``--update --force`` keeps the rows of other (suite, design) pairs already in ``--out``
(each row names its command). Writes flights.csv and report.md into ``--out``.
"""

from __future__ import annotations

import re
import sys
from pathlib import Path

from benchmarks.common import (
    Distinct,
    bench_args,
    command_as_run,
    csv_header,
    load_average,
    machine_description,
    markdown_table,
    read_rows_csv,
    run_main,
    write_csv,
    write_text,
)
from benchmarks.faults_measure import DESIGNS, SUITES, SUITES_DIR
from modquad_gym.core.options import path_option

COLUMNS = ("suite", "task", "design", "fault", "modules", "worst_fault_margin", "same_design",
           "error_cm", "detected_ms", "isolated", "decisions", "error_cm_unrevised",
           "isolated_unrevised", "error_cm_before", "detected_ms_before", "isolated_before",
           "command")  # fmt: skip
"""The columns of flights.csv, in order (what ``--update`` reads back)."""
BEFORE = ("error_cm_detector", "detected_ms", "isolated")
"""The detector columns of faults.csv."""
FLAGS = ("same_design", "isolated", "isolated_unrevised", "isolated_before")


def committed(path: Path, suites, designs) -> list[dict]:
    """The rows of faults.csv ``path`` with a detector flight, of ``suites`` and ``designs``."""
    rows = read_rows_csv(path, "--faults", csv_header(path), lambda raw: raw, "benchmarks.faults")
    if not set(BEFORE) <= set(rows[0]):
        raise ValueError(f"--faults {path}: no detector columns ({', '.join(BEFORE)})")
    chosen = [r for r in rows if r["suite"] in suites and r["design"] in designs]
    return [r for r in chosen if r["error_cm_detector"]]


def fly(row: dict, tasks: dict, command: str) -> dict:
    """One design of faults.csv searched again and flown with the detector (and, where it
    revised a decision, without revisions)."""
    from benchmarks.faults_measure import design
    from modquad_gym.sim.detector import DetectorConfig
    from modquad_gym.sim.fault_flight import fly_with_failure
    from modquad_gym.tasks.suites import load_suite

    if row["suite"] not in tasks:
        tasks[row["suite"]] = {t.name: t for t in load_suite(SUITES_DIR / f"{row['suite']}.json")}
    task = tasks[row["suite"]][row["task"]]
    limit = re.search(r"--time-limit (\S+)", row["command"])
    limit = float(limit.group(1)) if limit else (30.0 if row["design"] == "rotor2" else 10.0)
    found = design(task, row["design"], int(row["n_max"]), limit)
    structure = found.pop("_structure")
    out = {"suite": row["suite"], "task": row["task"], "design": row["design"],
           "fault": found["fault"], "modules": found["modules"],
           "worst_fault_margin": found["worst_fault_margin"], "same_design": False,
           "error_cm": None, "detected_ms": None, "isolated": False, "decisions": "",
           "error_cm_unrevised": None, "isolated_unrevised": False,
           "error_cm_before": float(row["error_cm_detector"]),
           "detected_ms_before": float(row["detected_ms"]) if row["detected_ms"] else None,
           "isolated_before": row["isolated"] == "True", "command": command}  # fmt: skip
    if structure is None:  # the time-limited search found none this time: nothing flown
        return out
    flown = {}
    for revise in (True, False):
        f = fly_with_failure(structure, task, found["fault"], failure="worst",
                             detector=DetectorConfig(revise=revise))  # fmt: skip
        record = f.summary()
        flown[revise] = (round(100 * f.max_position_error_m, 3),
                         record["fault_detected_rotors"] == [int(c) for c in f.worst.columns],
                         record["fault_detector_decisions"])  # fmt: skip
        if revise and len(record["fault_detector_decisions"]) < 2:
            flown[False] = flown[True]  # no revision: the same flight
            break
    made = flown[True][2]
    return {**out, "same_design": found["modules"] == int(row["modules"])
            and abs(found["worst_fault_margin"] - float(row["worst_fault_margin"])) < 1e-4,
            "error_cm": flown[True][0], "isolated": flown[True][1],
            "detected_ms": round(1000 * made[0][0], 1) if made else None,
            "decisions": " ".join(f"{1000 * t:.0f}ms:{'+'.join(map(str, S))}" for t, S in made),
            "error_cm_unrevised": flown[False][0],
            "isolated_unrevised": flown[False][1]}  # fmt: skip


def _typed(raw: dict) -> dict:
    """A row of an earlier flights.csv (``--update``), kept as read but for its flags."""
    flags = {"True": True, "False": False}
    return {**raw, **{k: flags[raw[k]] for k in FLAGS}}


def _flag(value) -> bool:
    return value is True or value == "True"


def summary(rows: list[dict]) -> list[dict]:
    """Per group of designs: flights, detected, revised, right rotors named last, within 5 cm
    and the largest error, with the same structures unrevised in brackets."""
    groups = {
        "with a margin for a delay": lambda r: DESIGNS[r["design"]][1] > 0,
        "margin-free, one rotor or module": lambda r: r["design"] in ("rotor", "module"),
        "two rotors (rotor2)": lambda r: r["design"] == "rotor2",
    }
    out = []
    for name, member in groups.items():
        rs = [r for r in rows if member(r)]
        if not rs:
            continue
        now, unrevised = ([float(r[k]) for r in rs] for k in ("error_cm", "error_cm_unrevised"))
        right = (sum(_flag(r[k]) for r in rs) for k in ("isolated", "isolated_unrevised"))
        out.append({"designs": name, "flights": len(rs),
                    "detected": sum(r["detected_ms"] not in (None, "") for r in rs),
                    "revised": sum(" " in (r["decisions"] or "") for r in rs),
                    "right rotors": "{} ({})".format(*right),
                    "within 5 cm": f"{sum(e <= 5 for e in now)} ({sum(e <= 5 for e in unrevised)})",
                    "largest error cm": f"{max(now):.3g} ({max(unrevised):.3g})"})  # fmt: skip
    return out


def report(rows: list[dict]) -> str:
    """The page: the commands, the summary table, the flights the revision changed, and those
    that differ from faults.csv without one."""
    flown = [r for r in rows if r["error_cm"] not in (None, "")]
    revised = [r for r in flown if " " in (r["decisions"] or "")]
    differ = [r for r in flown if r not in revised and (
        abs(float(r["error_cm"]) - float(r["error_cm_before"])) > 0.01
        or _flag(r["isolated"]) != _flag(r["isolated_before"]))]  # fmt: skip
    missing = [f"{r['suite']} {r['task']} {r['design']}" for r in rows if r not in flown]
    keys = ("suite", "task", "design")
    shown = ("error_cm_unrevised", "error_cm", "isolated_unrevised", "isolated", "decisions")
    changed = [{k: r[k] for k in (*keys, *shown)} for r in revised]
    other = [{**{k: r[k] for k in keys}, "same_design": r["same_design"],
              **{k: r[k] for k in ("error_cm_before", "error_cm", "detected_ms_before",
                                   "detected_ms", "isolated_before", "isolated")}}
             for r in differ]  # fmt: skip
    lines = [
        "# The failure detector on the fault designs, flown again", "",
        f"Made on {machine_description()}, load average at the end {load_average()}, by:", "",
        *[f"- `{c}`" for c in sorted({r["command"] for r in rows})], "",
        "Each design of results/faults/faults.csv with a detector flight, searched again and "
        "flown through its worst failure with the detector; in brackets the same structures "
        "with the first decision left standing (`DetectorConfig(revise=False)`, the detector "
        "of faults.csv's runs). A decision is revised when the residual stays after the "
        "allocator drops the rotors named (decisions: ms after the failure, rotors).", "",
        markdown_table(summary(flown)), "",
        f"## Flights the revision changed ({len(revised)} of {len(flown)})", "",
        markdown_table(changed) if changed else "None.", "",
        f"## Flights without a revision that differ from faults.csv ({len(differ)})", "",
        "Their first decision is made as before, so the difference is the structure (faults.csv "
        "keeps no cells: a time-limited search may find another one, *same_design* compares "
        "size and worst margin only) or the code of faults.csv's command.", "",
        markdown_table(other) if other else "None.", "",
        f"Searched again without an answer: {', '.join(missing) or 'none'}.", "",
    ]  # fmt: skip
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    args = bench_args(argv, "python -m benchmarks.fault_detector", __doc__.split("\n\n")[0], {
        "--faults": {"type": path_option, "default": Path("results/faults/faults.csv"),
                     "help": "the faults.csv whose designs are flown (default "
                             "results/faults/faults.csv)"},
        "--suites": {"nargs": "+", "action": Distinct, "choices": SUITES, "default": list(SUITES),
                     "help": "suites (default all four)"},
        "--designs": {"nargs": "+", "action": Distinct,
                      "choices": [d for d in DESIGNS if DESIGNS[d][0]],
                      "default": [d for d in DESIGNS if DESIGNS[d][0]],
                      "help": "fault designs (default all)"},
        "--update": {"action": "store_true",
                     "help": "keep the rows of other (suite, design) pairs in --out"},
    }, seed_help=None, out="results/fault_detector",
        outputs=("report.md", "flights.csv"))  # fmt: skip
    try:
        rows = committed(args.faults, args.suites, args.designs)
        kept = read_rows_csv(args.out / "flights.csv", "--update", COLUMNS, _typed,
                             "benchmarks.fault_detector") if args.update else []  # fmt: skip
    except ValueError as exc:
        print(f"python -m benchmarks.fault_detector: error: {exc}", file=sys.stderr)
        return 2
    command = command_as_run("fault_detector", argv)
    tasks: dict = {}
    new = []
    for row in rows:
        new.append(fly(row, tasks, command))
        print(f"{row['suite']} {row['task']} {row['design']}: {new[-1]['error_cm']} cm "
              f"({new[-1]['decisions'] or 'not detected'})", file=sys.stderr)  # fmt: skip
    made = {(r["suite"], r["design"]) for r in new}
    rows = [r for r in kept if (r["suite"], r["design"]) not in made] + new
    order = {key: i for i, key in enumerate((s, d) for s in SUITES for d in DESIGNS)}
    rows.sort(key=lambda r: (order[(r["suite"], r["design"])], r["task"]))
    write_csv(rows, args.out / "flights.csv")
    write_text(args.out / "report.md", report(rows))
    print(f"wrote {args.out}/report.md", file=sys.stderr)
    return 0


if __name__ == "__main__":
    raise SystemExit(run_main(main, "fault_detector"))
