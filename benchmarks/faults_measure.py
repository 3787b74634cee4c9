"""The price-of-fault-tolerance benchmark, the measurements: the suites and designs it covers,
each design's search re-verified and timed, the test that the task's forces alone rule a margin
out, the flights through the worst failure, the oracle's speed, and the rows of faults.csv
(read, written, merged with an earlier run's).

Run through :mod:`benchmarks.faults` (``python -m benchmarks.faults``), which describes the
experiment; the report page and picture are :mod:`.faults_report`.
"""

from __future__ import annotations

import json
import sys
import time
from pathlib import Path

import numpy as np

import modquad_gym as mq
from modquad_gym.oracle.fault_delay import margin_for_delay
from modquad_gym.tasks.suites import load_suite

SUITES = ("fault_rotor", "heldout_paper", "heldout_planted", "dynamic_motions")
SUITES_DIR = Path(mq.__file__).parent / "data" / "suites"
DESIGNS = {  # name: (fault, detection delay designed for in s)
    "intact": (None, 0.0), "rotor": ("rotor", 0.0), "rotor_20ms": ("rotor", 0.02),
    "rotor_50ms": ("rotor", 0.05), "module": ("module", 0.0), "module_20ms": ("module", 0.02),
    "module_50ms": ("module", 0.05), "rotor2": ("rotor2", 0.0),
}  # fmt: skip
FLOWN = ("20ms", "50ms", "detector")
"""How each fault design is flown: told of the failure 20 ms or 50 ms late, or by the detector."""


def design(task, name: str, n_max: int, time_limit: float) -> dict:
    """The default search's answer for one design of ``task``, re-verified, with its time."""
    fault, delay = DESIGNS[name]
    mu = margin_for_delay(delay, fault) if delay else None
    t0 = time.perf_counter()
    r = mq.anytime_search(task, n_max=n_max, time_limit=time_limit, fault=fault, fault_margin=mu)
    row = {"design": name, "fault": fault or "", "delay_ms": round(1000 * delay),
           "required_margin": round(mu or 0.0, 4), "modules": r.n_modules,
           "lower_bound": r.lower_bound, "certified": r.certified, "status": r.status.value,
           "n_max": n_max,
           "seconds": round(time.perf_counter() - t0, 2), "worst_fault_margin": None,
           "cells": None if r.structure is None else cells_text(r.structure),
           "_structure": r.structure}  # fmt: skip
    if r.structure is not None and fault:
        W = task.rotor_wrenches(r.structure)
        if fault != "rotor2":  # HiGHS on every failed matrix (a pair's LPs are too many)
            ok = mq.tolerates(r.structure, W, task.f_max, fault=fault, method="scipy")
            assert ok.all(), f"{task.name} {name}: HiGHS rejects the answer"
        worst = float(mq.fault_margin(r.structure, W, task.f_max, fault=fault).min())
        assert worst >= (mu or 0.0) - 1e-6, f"{task.name} {name}: margin {worst} below {mu}"
        row["worst_fault_margin"] = round(worst, 5)
    return row


def cells_text(structure) -> str:
    """A structure's cells as faults.csv keeps them (JSON, ``[[0, 0], [1, 0]]``): a row's design
    can be flown again without its time-limited search."""
    return json.dumps([list(c) for c in structure.cells])


def forces_rule_out(task, fault: str, mu: float, n_max: int) -> bool:
    """True when the task's forces alone prove that no structure of up to ``n_max`` T-modules
    keeps the margin ``mu`` after every failure of kind ``fault``. A structure's force set
    depends only on how many rotors of each of a module's four directions still work (not on
    the shape): with counts c_j the rotors of direction j sum to U_j in [c_j mu f/2, c_j (1 -
    mu/2) f], and the force must be D U (an LP per wrench; the rotor wrenches of a line of n
    modules stand for every n-module structure, their forces being the same)."""
    from scipy.optimize import linprog

    D = mq.Structure([(0, 0)]).configuration_matrix()[:3]
    f = task.f_max
    for n in range(1, n_max + 1):
        forces = np.asarray(task.rotor_wrenches(mq.Structure([(i, 0) for i in range(n)])))[:, :3]
        counts = [np.full(4, n - 1)] if fault == "module" else [n - np.eye(4, dtype=int)[j]
                                                                 for j in range(4)]  # fmt: skip
        if all(linprog(np.zeros(4), A_eq=D, b_eq=w, method="highs",
                       bounds=[(c * mu * f / 2, c * (1 - mu / 2) * f) for c in cs]).status == 0
               for cs in counts for w in forces):  # fmt: skip
            return False  # this size is not ruled out
    return True


def explain_missing(rows: list[dict]) -> None:
    """``forces_rule_out`` for each margin design no search found (where not yet decided)."""
    tasks = {}
    for r in rows:
        if r["delay_ms"] and r["modules"] is None and r.get("forces_rule_out") is None:
            if r["suite"] not in tasks:
                tasks[r["suite"]] = {
                    t.name: t for t in load_suite(SUITES_DIR / f"{r['suite']}.json")
                }
            task = tasks[r["suite"]][r["task"]]
            r["forces_rule_out"] = forces_rule_out(
                task, r["fault"], r["required_margin"], r["n_max"]
            )


def fly(task, structure, fault: str, intact_seconds: float) -> dict:
    """Flights of one design through its smallest-margin failure (20 ms, 50 ms, the detector):
    the largest error after the failure and the flight's verdict (``within_5cm_*``: within 5 cm,
    never stopped and settled at its end, :mod:`modquad_gym.sim.fault_verdict`; ``why_not_*``:
    why not, empty when it held), and its intact hover with the detector on."""
    from modquad_gym.sim import fault_flight as ff
    from modquad_gym.sim.detector import DetectorConfig
    from modquad_gym.sim.failure import Failure

    out = {}
    for delay in (0.02, 0.05):
        f = ff.fly_with_failure(structure, task, fault, detection_delay_s=delay, failure="worst")
        out[f"error_cm_{1000 * delay:.0f}ms"] = round(100 * f.max_position_error_m, 3)
        out[f"within_5cm_{1000 * delay:.0f}ms"] = bool(f.within_goal)
        out[f"why_not_{1000 * delay:.0f}ms"] = f.verdict_words()
    f = ff.fly_with_failure(structure, task, fault, detector=DetectorConfig(), failure="worst")
    after = f.summary()["fault_detected_after_s"]
    out["error_cm_detector"] = round(100 * f.max_position_error_m, 3)
    out["within_5cm_detector"] = bool(f.within_goal)
    out["why_not_detector"] = f.verdict_words()
    out["detected_ms"] = None if after is None else round(1000 * after, 1)
    out["isolated"] = f.summary()["fault_detected_rotors"] == [int(c) for c in f.worst.columns]
    w = np.asarray(task.rotor_wrenches(structure))[f.worst.row]
    never = Failure((0,), 1e9, 0.0, fault)
    calm = ff.hover_with_failure(structure, w, never, intact_seconds, task.f_max,
                                 detector=DetectorConfig())  # fmt: skip
    out["false_alarm"] = calm.detection is not None
    return out


def price(args, command: str) -> list[dict]:
    """One row per (suite, task, design) of this run."""
    rows = []
    for suite in args.suites:
        for task in load_suite(SUITES_DIR / f"{suite}.json")[args.skip : args.per_suite]:
            flown: dict = {}  # a structure flown once per fault kind
            for name in args.designs:
                limit = args.rotor2_time_limit if name == "rotor2" else args.time_limit
                row = {"suite": suite, "task": task.name,
                       **design(task, name, args.n_max, limit)}  # fmt: skip
                s = row.pop("_structure")
                if args.fly and s is not None and row["fault"]:
                    key = (s.cells, row["fault"])
                    if key not in flown:
                        flown[key] = fly(task, s, row["fault"], args.intact_seconds)
                    row.update(flown[key])
                row["command"] = command
                rows.append(row)
                print(f"{suite} {task.name} {name}: {row['modules']} (bound {row['lower_bound']}, "
                      f"{row['seconds']:.1f} s) {row.get('error_cm_detector', '')}",
                      file=sys.stderr)  # fmt: skip
    return rows


def oracle_speed(sizes=(10, 100, 1000, 10000), repeats: int = 5) -> list[dict]:
    """Wrenches decided per second by ``tolerates`` (each fault) and by ``feasible`` (best of
    ``repeats``), 7 modules (m = 28), wrenches drawn inside W (30-100 % of random allocations)."""
    s = mq.Structure([(0, 0), (1, 0), (0, 1), (1, 1), (2, 0), (2, 1), (0, 2)])
    A = s.configuration_matrix()
    rng = np.random.default_rng(0)
    rows = []
    for t in sizes:
        W = (rng.uniform(0, 1, (t, A.shape[1])) @ A.T) * rng.uniform(0.3, 1.0, (t, 1))
        rate = {}
        for name in ("feasible", "rotor", "module", "rotor2"):
            best = np.inf
            for k in range(repeats + 1):  # the first run warms compiled code and caches
                t0 = time.perf_counter()
                mq.feasible(A, W) if name == "feasible" else mq.tolerates(s, W, fault=name)
                if k:
                    best = min(best, time.perf_counter() - t0)
            rate[name] = t / best
        rows.append({"wrenches": t, **{f"{k}_per_s": round(v) for k, v in rate.items()},
                     **{f"{k}_ratio": round(rate[k] / rate["feasible"], 4)
                        for k in ("rotor", "module", "rotor2")}})  # fmt: skip
    return rows


COLUMNS = ("suite", "task", "design", "fault", "delay_ms", "required_margin", "modules",
           "lower_bound", "certified", "status", "n_max", "seconds", "worst_fault_margin",
           "command")  # fmt: skip
"""The columns every faults.csv has (a ``--fly`` run adds its flights' after them)."""


def read_rows(path: Path, option: str) -> list[dict]:
    """The rows of an earlier faults.csv, numbers and booleans restored; a damaged file (a
    header without :data:`COLUMNS`, a row cut short, an unknown suite or design) is a one-line
    ValueError naming ``option``, the file and the 1-based row
    (:func:`~benchmarks.common.read_rows_csv`)."""
    from benchmarks.common import csv_header, read_rows_csv

    header = csv_header(path)
    missing = [c for c in COLUMNS if c not in header]
    if header and missing:
        raise ValueError(f"{option} {path}: its header has no {', '.join(missing)}")
    return read_rows_csv(path, option, header or COLUMNS, _typed, "benchmarks.faults")


def _typed(raw: dict) -> dict | None:
    """One row of faults.csv with its values restored; None where it is no such row."""

    def value(text: str):
        if text in ("True", "False"):
            return text == "True"
        for kind in (int, float):
            try:
                return kind(text)
            except ValueError:
                pass
        return None if text == "" else text

    if None in raw.values():  # fewer fields than the header: a row cut short
        return None
    row = {k: value(v) for k, v in raw.items()}
    return row if row["suite"] in SUITES and row["design"] in DESIGNS else None


def merged(old: list[dict], new: list[dict]) -> list[dict]:
    """``old`` without the (suite, task, design) rows ``new`` makes, then ``new``; in suite
    order."""
    made = {(r["suite"], r["task"], r["design"]) for r in new}
    rows = [r for r in old if (r["suite"], r["task"], r["design"]) not in made] + new
    order = {s: k for k, s in enumerate(SUITES)}
    tasks = {(r["suite"], r["task"]): k for k, r in enumerate(rows)}
    names = list(DESIGNS)
    return sorted(rows, key=lambda r: (order.get(r["suite"], 99), tasks[r["suite"], r["task"]],
                                       names.index(r["design"])))  # fmt: skip


if __name__ == "__main__":
    from benchmarks.common import refuse_as_script

    raise SystemExit(refuse_as_script("faults_measure"))
