"""The price-of-fault-tolerance benchmark keeps each flight's verdict (settled, not only the
error) and each design's cells, and its report counts a flight by the verdict where a row keeps
it and says which rows were judged so."""

from __future__ import annotations

import json

import pytest

import modquad_gym as mq
from benchmarks import faults_measure, faults_report


def _row(task: str, design: str, error_cm: float, verdict: bool | None) -> dict:
    fault, delay = faults_measure.DESIGNS[design]
    row = {"suite": "heldout_paper", "task": task, "design": design, "fault": fault,
           "delay_ms": round(1000 * delay), "detected_ms": 15.0, "isolated": True,
           "false_alarm": False}  # fmt: skip
    for k in faults_measure.FLOWN:
        row[f"error_cm_{k}"] = error_cm
        if verdict is not None:
            row[f"within_5cm_{k}"] = verdict
    return row


def test_the_report_counts_by_the_verdict_and_names_the_older_rows():
    rows = [
        _row("old", "rotor", 1.0, None),  # an earlier run's row: its error alone
        _row("new", "rotor", 1.0, False),  # within 5 cm but not settled
        _row("new", "rotor_20ms", 0.5, False),
    ]
    page = "\n".join(faults_report.flights_section(rows))
    assert "| rotor | 2 | 1 | 1/2 | 1/2 | 1/2 | 1.00, 1.00, 1.00 |" in page
    assert "(2 of 3 flown rows, column *verdict kept*); the other 1" in page
    assert "new rotor_20ms at detector (0.5 cm, not settled)" in page
    assert "new rotor_20ms at 20ms (0.5 cm, not settled)" in page
    # never detected and within 5 cm but not settled: it did not hold, it did not drift away
    rows[1]["detected_ms"] = None
    page = "\n".join(faults_report.flights_section(rows))
    assert "1 did not hold: new rotor (1.0 cm, not settled)" in page
    for r, command in zip(rows, ("old run", "new run", "new run")):
        r["command"] = command
    assert faults_report.made(rows, "new run") == "2 rows: rotor, rotor_20ms"


def test_a_design_keeps_its_cells_and_its_flights_their_verdict():
    task = mq.TaskRequirement.load(mq.tasks.example_path("screwdriver"))
    row = faults_measure.design(task, "rotor", n_max=7, time_limit=10.0)
    assert mq.Structure([tuple(c) for c in json.loads(row["cells"])]) == row["_structure"]
    flights = faults_measure.fly(task, row["_structure"], "rotor", intact_seconds=1.0)
    for k in faults_measure.FLOWN:  # the 4-module rotor design holds (docs/faults.md)
        assert flights[f"within_5cm_{k}"] is True
        assert flights[f"error_cm_{k}"] < 5.0 and flights[f"why_not_{k}"] == ""


def test_fault_delay_leaves_out_designs_that_fail_with_the_failure_known_at_once():
    """A design that does not hold at D = 0 (a trajectory that never settles, say) fails for
    another reason than the delay: it must not set the margin the delay needs."""
    from benchmarks import fault_delay_report as fault_delay

    delays = [0.0, 0.01, 0.05]
    flights = [flight("steady", 0.01, d, d < 0.05) for d in delays]
    flights += [flight("wavy", 0.09, d, False, "not settled: error rising") for d in delays]
    needed, slope = fault_delay.fit(flights, delays, "rotor")
    assert slope == 0.01 / 0.05 and needed[0.01] == 0.0
    assert fault_delay.fit(flights, delays, "rotor", control=False)[1] == 0.09 / 0.01
    text = "\n".join(fault_delay.control_lines(flights, delays))
    assert "- rotor: 1 of 2 designs do not hold with the failure known at once" in text
    assert "wavy margin 0 (not settled: error rising)" in text
    assert "with them the fit would be 9.000 D" in text
    named = fault_delay.binding(flights, delays, "rotor")
    assert "set by steady (margin 0.01, 6 modules) at 50 ms" in named
    assert (
        "without that flight the fit would be 0.000 D, without that task's flights 0.000 D" in named
    )


def flight(task, margin, delay, held, why="", fault="rotor"):
    """A made-up flight of benchmarks.fault_delay (a 6-module design of margin 0 for ``task``)."""
    return {"task": task, "fault": fault, "required_margin": 0.0, "modules": 6,
            "certified": True, "worst_fault_margin": margin, "delay_s": delay,
            "max_error_cm": 0.2, "within_5cm": held, "why_not": why}  # fmt: skip


def test_fault_delay_says_plainly_that_no_design_is_left_out():
    """Where every design holds at D = 0 the page says so, with no fit "with them" (it named
    "0 of 46 designs do not hold ..., left out of the fit; with them the fit would be ...");
    a fault with no flight says that."""
    from benchmarks.fault_delay_report import control_lines

    delays = [0.0, 0.01, 0.05]
    flights = [flight(t, 0.01, d, d < 0.05) for t in ("steady", "calm") for d in delays]
    *_, rotor, module = control_lines(flights, delays)
    assert (
        rotor
        == "- rotor: all 2 designs hold with the failure known at once; every flight is fitted"
    )
    assert module == "- module: no flights"
    flights += [flight("wavy", 0.09, d, d == 0.01, "beyond 5 cm", "module") for d in delays[1:]]
    *_, module = control_lines(flights, delays)  # a design not flown at D = 0 is not counted so
    assert module == "- module: no design flown at delay 0; every flight is fitted"
    flights += [flight(t, 0.02, 0.0, True, fault="module") for t in ("late", "later")]
    *_, module = control_lines(flights, delays)
    assert module == (
        "- module: all 2 designs flown at D = 0 (of 3) hold with the failure known at once; "
        "every flight is fitted"
    )


def test_the_rule_is_the_one_its_report_fits():
    """DELAY_SLOPES is 1.25 times the fit of results/fault_delay, rounded up to 0.05; module
    failures' slope also stands for two rotors and a module with a rotor."""
    import math
    import re
    from pathlib import Path

    from modquad_gym.oracle.fault_delay import DELAY_SLOPES

    page = (Path(__file__).resolve().parents[1] / "results/fault_delay/report.md").read_text()
    for fault in ("rotor", "module"):
        found = re.search(rf"- {fault}: fit mu = ([\d.]+) D, rule mu = ([\d.]+) D", page)
        fitted, rule = map(float, found.groups())
        assert DELAY_SLOPES[fault] == rule
        assert DELAY_SLOPES[fault] == pytest.approx(
            math.ceil(round(1.25 * fitted / 0.05, 6)) * 0.05
        )
    assert DELAY_SLOPES["rotor2"] == DELAY_SLOPES["rotor+module"] == DELAY_SLOPES["module"]
