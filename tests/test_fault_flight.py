"""Flights through a failure (issue 37, item 4): the worst single failure flown in MuJoCo on a
certified tolerant structure and on the intact minimum; ``modquad validate --fault``."""

from __future__ import annotations

import json

import numpy as np
import pytest

import modquad_gym as mq
from modquad_gym import dynamics as dy

pytest.importorskip("mujoco")

from modquad_gym.cli import main  # noqa: E402
from modquad_gym.cli.validate_fault import fault_lines  # noqa: E402
from modquad_gym.sim import fault_flight  # noqa: E402
from modquad_gym.sim.failure import Failure  # noqa: E402
from modquad_gym.sim.fault_flight import (  # noqa: E402
    GOAL_M,
    failure_columns,
    fly_with_failure,
    worst_failure,
)

SCREWDRIVER = mq.TaskRequirement.load("examples/screwdriver.json")
INTACT = mq.Structure([(0, 0), (0, 1), (1, 0)])  # its certified minimum
ROTOR_TOLERANT = mq.Structure([(0, 0), (0, 1), (1, 0), (2, 0)])  # certified, fault="rotor"
SHORT = 1.1  # seconds of hover after the failure (the least: 20 ms and two 0.5 s windows)
PLANTED = mq.TaskRequirement.load("examples/planted_seed1.json")
LINE6 = mq.Structure([(i, 0) for i in range(6)])  # its certified rotor-tolerant minimum


def test_the_structures_are_the_certified_answers():
    W = SCREWDRIVER.wrenches
    assert mq.exhaustive_search(W, n_max=4).structure.cells == INTACT.cells
    assert mq.exhaustive_search(W, n_max=4, fault="rotor").structure.cells == ROTOR_TOLERANT.cells


def test_worst_failure_is_the_smallest_margin_over_every_single_failure():
    W = SCREWDRIVER.rotor_wrenches(INTACT)
    A = INTACT.configuration_matrix()
    for fault, size in (("rotor", 1), ("module", 4)):
        sets = failure_columns(INTACT, fault)
        assert [len(S) for S in sets] == [size] * (12 // size)
        worst = worst_failure(INTACT, W, 1.0, fault)
        margins = []
        for S in sets:  # independently: the oracle on A without the columns
            keep = np.setdiff1d(np.arange(12), S)
            margins.append(mq.margin(A[:, keep], W, 1.0))
        smallest = [m.min() for m in margins]
        assert worst.margin == pytest.approx(min(smallest), abs=1e-9)
        assert smallest[worst.index] == min(smallest)
        assert worst.row == int(np.argmin(margins[worst.index]))
        assert worst.tolerates == bool(mq.tolerates(INTACT, W, 1.0, fault=fault).all())
        assert not worst.tolerates and worst.margin < 0


def test_tolerant_structure_holds_its_hover_within_5_cm_after_the_failure():
    flight = fly_with_failure(ROTOR_TOLERANT, SCREWDRIVER, "rotor", seconds=SHORT,
                              failure="worst")  # fmt: skip
    r = flight.summary()
    assert r["fault_tolerates"] is True and r["fault_worst_margin"] > 0
    assert r["fault_time_s"] == pytest.approx(fault_flight.FAULT_BEFORE_S)
    assert r["fault_diverged"] is None and r["fault_settled"] is True
    assert r["fault_seconds"] == pytest.approx(SHORT, abs=0.01)  # after the failure, as asked
    assert r["fault_total_seconds"] == pytest.approx(fault_flight.FAULT_BEFORE_S + SHORT, abs=0.01)
    assert r["fault_max_position_error_m"] <= GOAL_M and r["fault_within_5cm"]
    assert r["fault_saturated_fraction"] == 0.0
    # the rotor really stopped, and carried thrust before
    (k,) = r["fault_failed_rotors"]
    after = flight.after
    assert after.any() and (~after).any()
    assert np.all(flight.run.inputs[after, k] == 0.0)
    assert np.all(flight.run.inputs[~after, k] > 0.01)
    assert r["fault_failed_module"] == k // 4 and r["fault_failed_rotor_in_module"] == k % 4
    assert r["fault_failed_cell"] == list(ROTOR_TOLERANT.cells[k // 4])
    assert r["fault_before_max_position_error_m"] <= 1e-6  # at rest before the failure


def test_intact_minimum_saturates_or_drifts_under_its_worst_rotor_failure():
    flight = fly_with_failure(INTACT, SCREWDRIVER, "rotor", seconds=SHORT, failure="worst")
    r = flight.summary()
    assert r["fault_tolerates"] is False and r["fault_worst_margin"] < 0
    assert r["fault_saturated_fraction"] > 0.5 or r["fault_max_position_error_m"] > GOAL_M
    assert r["fault_max_position_error_m"] > 10 * r["fault_before_max_position_error_m"]
    assert not r["fault_within_5cm"] or r["fault_saturated_fraction"] > 0.5


def test_tolerant_structure_keeps_its_trajectory_through_the_failure():
    task = dy.circle(speed=1.0, laps=0.25)
    tolerant = mq.Structure([(0, 0), (1, 0), (1, 1)])  # certified rotor-tolerant minimum
    flight = fly_with_failure(tolerant, task, "rotor", failure="worst")
    r = flight.summary()
    assert r["fault_flight"] == "trajectory" and r["fault_tolerates"] is True
    # the failure comes before the moment it hurts most (or halfway)
    hardest = task.trajectory.t[r["fault_hardest_row"]] - task.trajectory.t[0]
    assert r["fault_time_s"] <= min(hardest, task.trajectory.duration / 2) + 1e-9
    assert r["fault_diverged"] is None
    assert r["fault_max_position_error_m"] <= GOAL_M
    assert r["fault_saturated_fraction"] == 0.0
    (k,) = r["fault_failed_rotors"]
    assert np.all(flight.run.inputs[flight.after, k] == 0.0)


def test_failure_event_checks_and_the_known_plant():
    with pytest.raises(ValueError, match="at least one rotor"):
        Failure((), 1.0)
    with pytest.raises(ValueError, match="detection_delay_s"):
        Failure((0,), 1.0, -0.1)
    f = Failure((1, 2), 0.5, 0.02, "module")
    assert f.detected_s == pytest.approx(0.52)
    assert f.working(4).tolist() == [True, False, False, True]
    with pytest.raises(ValueError, match="fault must be one of"):
        fly_with_failure(INTACT, SCREWDRIVER, "propeller")


def _argv(tmp_path, *extra):
    return ["validate", "--task", "examples/screwdriver.json", "--out", str(tmp_path / "out"),
            "--max-hover-wrenches", "1", "--hover-seconds", "0.5", "--known-load-only",
            *extra]  # fmt: skip


def test_cli_validate_fault_json_pictures_and_intact_minimum(tmp_path, capsys):
    fast = ("--fault-seconds", str(SHORT), "--failure", "worst")
    assert main(_argv(tmp_path, "--fault", "rotor", "--json", *fast)) == 0
    record = json.loads(capsys.readouterr().out.strip().splitlines()[-1])
    assert record["n_modules"] == 4 and record["fault"] == "rotor"
    assert record["fault_tolerates"] is True
    assert record["fault_max_position_error_m"] <= GOAL_M
    assert record["fault_saturated_fraction"] == 0.0
    assert record["fault_time_s"] == pytest.approx(fault_flight.FAULT_BEFORE_S)
    assert record["fault_failure"] == "worst" and record["fault_failures_flown"] == 1
    intact = record["intact_minimum"]
    assert intact["n_modules"] == 3 and intact["tolerates"] is False and intact["certified"]
    assert intact["cells"] == [list(c) for c in INTACT.cells]
    assert intact["fault_saturated_fraction"] > 0.5 or intact["fault_max_position_error_m"] > 0.05
    out = tmp_path / "out"
    for name in ("fault_flight.png", "fault_flight_intact_minimum.png"):
        assert (out / name).stat().st_size > 10_000
        assert str(out / name) in record["files"].values()
    saved = json.loads((out / "validation.json").read_text())
    assert saved["fault_max_position_error_m"] == record["fault_max_position_error_m"]
    assert saved["intact_minimum"] == intact
    assert "Flight through a rotor failure" in (out / "report.md").read_text()
    # the console summary names both flights
    text = "\n".join(fault_lines(record))
    assert "fault flight: tolerates any rotor failure" in text
    assert "the smallest-margin rotor failure only" in text
    assert "intact minimum (3 modules): does not tolerate" in text
    assert fault_lines({"fault": "rotor"}) == []
    # the pictures are refused without --force, before any work
    assert main(_argv(tmp_path, "--fault", "rotor", *fast)) == 2
    assert "fault_flight.png" in capsys.readouterr().err


def test_cli_fault_refusals_before_work(tmp_path, capsys):
    out = tmp_path / "out"
    assert main(_argv(tmp_path, "--fault", "rotor", "--method", "milp")) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "fault='rotor'" in err and "milp" in err
    assert not out.exists()
    assert main(_argv(tmp_path, "--detection-delay", "0.1")) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "--detection-delay" in err and "--fault" in err
    assert main(_argv(tmp_path, "--fault", "module", "--detection-delay", "5")) == 2
    assert "--detection-delay" in capsys.readouterr().err
    assert not out.exists()
    with pytest.raises(SystemExit) as exc:
        main(_argv(tmp_path, "--fault", "propeller"))
    assert exc.value.code == 2
    err = capsys.readouterr().err
    assert "--fault" in err and "invalid choice" in err and "propeller" in err


def test_cli_defaults_are_the_simulations():
    from modquad_gym.cli import validate_fault as cli

    assert cli.DEFAULT_DETECTION_DELAY == fault_flight.DETECTION_DELAY_S
    assert cli.DEFAULT_FAULT_SECONDS == fault_flight.FAULT_SECONDS
    assert cli.MAX_FAULT_SECONDS == fault_flight.MAX_FAULT_SECONDS
