"""``modquad validate`` states the structure's thrust-to-weight ratio at the task's f_max in the
words ``modquad export`` uses, and, below 1, why its hovers fly all the same (their external
load holds it up): no contradiction with the export's warning that it cannot lift itself."""

from __future__ import annotations

import modquad_gym as mq
from modquad_gym.cli.validate import summary_lines, with_lift
from modquad_gym.sim.export import lift_statement, thrust_to_weight

SCREWDRIVER = mq.Structure([(0, 0), (0, 1), (1, 0)])  # its certified minimum


def test_the_summary_states_the_lift_as_export_does():
    record = with_lift({"n_modules": 3, "cells": [[0, 0], [0, 1], [1, 0]]}, SCREWDRIVER, 1.0)
    assert record["thrust_to_weight"] == thrust_to_weight(SCREWDRIVER, 1.0) < 1
    line = next(x for x in summary_lines(record) if x.startswith("lift: "))
    assert line.startswith(f"lift: {lift_statement(SCREWDRIVER, 1.0)}; the hovers here apply")
    assert "external load d = -(w + gravity wrench), as export warns" in line


def test_a_structure_that_lifts_itself_gets_no_note():
    record = with_lift({}, SCREWDRIVER, 2.1)
    assert record["thrust_to_weight"] > 1
    assert record["lift"] == lift_statement(SCREWDRIVER, 2.1)
    assert f"lift: {record['lift']}" in summary_lines(record)


def test_the_command_prints_it_and_the_report_explains_the_picture(tmp_path, capsys):
    from test_hardening import run_main

    out = tmp_path / "v"
    code, printed, _ = run_main(capsys, "validate", "--task", "example:screwdriver", "--out",
                                str(out), "--known-load-only", "--hover-seconds", "0.2",
                                "--quiet")  # fmt: skip
    assert code == 0
    assert f"lift: {lift_statement(SCREWDRIVER, 1.0)}; the hovers here apply" in printed
    report = (out / "report.md").read_text()
    assert "![structure](structure.png)\n*structure.png: the first module" in report
    assert "blue for spin +1 and orange for spin -1" in report
