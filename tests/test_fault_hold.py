"""A trajectory flight through a failure goes on after the trajectory, holding its last point,
until ``seconds`` after the failure and two settling windows after the end: the verdict judges
a flight at rest that had time to recover (results/fault_delay's blind spots: a trajectory that
ended 1 s after its failure, and one whose own tracking error "rose" over the judged windows)."""

from __future__ import annotations

import json

import numpy as np
import pytest

import modquad_gym as mq
from modquad_gym import dynamics as dy

pytest.importorskip("mujoco")

from modquad_gym.cli import main  # noqa: E402
from modquad_gym.sim.failure import Failure  # noqa: E402
from modquad_gym.sim.fault_flight import (  # noqa: E402
    FAULT_SECONDS,
    SETTLE_WINDOW_S,
    fly_with_failure,
)
from modquad_gym.sim.model import HOME_HEIGHT  # noqa: E402
from modquad_gym.sim.track import fly_trajectory  # noqa: E402

LINE = dy.line(0.3, 1.0, hold=0.3, rate=20.0)  # 1.92 s
SQUARE = mq.Structure([(0, 0), (1, 0), (0, 1), (1, 1)])
DT = 1.0 / 500.0  # TrackConfig's control step


def _held_point(task) -> np.ndarray:
    traj = task.trajectory
    return traj.position[-1] - traj.position[0] + np.array([0.0, 0.0, HOME_HEIGHT])


@pytest.mark.parametrize("seconds", [None, 1.1])
def test_a_trajectory_fault_flight_lasts_seconds_after_the_failure_and_1_s_after_the_end(seconds):
    flight = fly_with_failure(SQUARE, LINE, "rotor", failure="worst", seconds=seconds)
    run, at = flight.run, flight.failure.time_s
    duration = LINE.trajectory.duration
    end = max(at + (FAULT_SECONDS if seconds is None else seconds), duration + 2 * SETTLE_WINDOW_S)
    assert run.diverged is None
    assert end - DT < run.t[-1] < end + DT, (run.t[-1], end)  # within one control step
    held = run.t > duration + 1e-9
    judged = run.t > run.t[-1] - 2 * SETTLE_WINDOW_S + 1e-9  # the verdict's two windows
    assert held[judged].all()  # lie in the hold
    np.testing.assert_allclose(run.desired[held], np.tile(_held_point(LINE), (held.sum(), 1)),
                               atol=1e-12)  # fmt: skip
    r = flight.summary()
    assert r["fault_total_seconds"] == run.t[-1]
    assert r["fault_seconds"] == pytest.approx(end - at, abs=DT)


def test_seconds_with_a_dynamic_task_is_checked_as_the_hovers():
    """The same one-line refusals as a static task's (both doors check the same bounds)."""
    static = mq.TaskRequirement.load("examples/screwdriver.json")
    for bad in (0.5, 61.0, -1.0, float("nan")):
        with pytest.raises(ValueError) as hover:
            fly_with_failure(SQUARE, static, "rotor", failure="worst", seconds=bad)
        with pytest.raises(ValueError) as trajectory:
            fly_with_failure(SQUARE, LINE, "rotor", failure="worst", seconds=bad)
        assert str(trajectory.value) == str(hover.value) and "seconds" in str(hover.value)


def test_hold_s_zero_is_the_trajectory_alone_and_the_hold_leaves_it_as_it_was():
    task = dy.circle(speed=1.0, laps=0.25)
    s = mq.Structure([(0, 0), (1, 0), (1, 1)])
    failure = Failure((4,), 1.0, 0.02)
    fields = ("t", "desired", "flown", "attitude", "attitude_error", "inputs", "saturated",
              "wrench_ff")  # fmt: skip
    plain = fly_trajectory(s, task, failure=failure)
    zero = fly_trajectory(s, task, failure=failure, hold_s=0.0)
    for name in fields:
        np.testing.assert_array_equal(getattr(zero, name), getattr(plain, name), err_msg=name)
    assert plain.t[-1] <= task.trajectory.duration + 1e-9
    held = fly_trajectory(s, task, failure=failure, hold_s=0.5)
    assert held.t[-1] == pytest.approx(task.trajectory.duration + 0.5, abs=DT)
    # the reference inputs are knots every reschedule_s (25 steps) up to the last step: before
    # the last knot both flights share, the hold changes nothing
    common = (len(plain.t) - 1) // 25 * 25
    for name in fields:
        np.testing.assert_array_equal(getattr(held, name)[:common],
                                      getattr(plain, name)[:common], err_msg=name)  # fmt: skip
    for bad in (-0.1, float("inf"), "1"):
        with pytest.raises(ValueError, match="hold_s"):
            fly_trajectory(s, task, hold_s=bad)


def _line_file(tmp_path) -> str:
    path = tmp_path / "line.json"
    return str(path if path.exists() else dy.line(0.5, 1.0, rate=20).save(path))  # 2.70 s


def _validate(tmp_path, *extra) -> list[str]:
    return ["validate", "--task", _line_file(tmp_path), "--out", str(tmp_path / "out"),
            "--max-hover-wrenches", "1", "--hover-seconds", "0.5", "--known-load-only",
            "--fault", "rotor", "--failure", "worst", *extra]  # fmt: skip


def test_cli_fault_seconds_with_a_dynamic_task_is_flown(tmp_path, capsys):
    assert main(_validate(tmp_path, "--fault-seconds", "3", "--json")) == 0
    r = json.loads(capsys.readouterr().out.strip().splitlines()[-1])
    assert r["fault_flight"] == "trajectory" and r["fault_diverged"] is None
    duration = dy.line(0.5, 1.0, rate=20).trajectory.duration
    assert r["fault_time_s"] + 3 > duration + 1  # the seconds asked set the length here
    assert r["fault_seconds"] == pytest.approx(3.0, abs=DT)


def test_cli_fault_seconds_with_a_dynamic_task_refused_as_with_a_static_one(tmp_path, capsys):
    for value, words in (("0.5", "[1.02, 60]"), ("61", "--fault-seconds 61")):
        said = []
        for task in (_line_file(tmp_path), "examples/screwdriver.json"):
            argv = _validate(tmp_path, "--fault-seconds", value)
            argv[argv.index("--task") + 1] = task
            assert main(argv) == 2
            said.append(capsys.readouterr().err)
        assert said[0] == said[1] and said[0].count("\n") == 1 and words in said[0], said
    assert not (tmp_path / "out").exists()


def _motions_cal_2():
    """The calibration task motions-cal-2 as benchmarks.fault_delay draws it."""
    from benchmarks.fault_delay import CALIBRATION_SEED0, SOURCES
    from modquad_gym.scoring.suites import draw_task
    from modquad_gym.tasks import make_generator

    k, i = SOURCES.index("motions"), 2
    return draw_task(make_generator("motions"), CALIBRATION_SEED0 + 1000 * k + i, "motions-cal-2")


# Its rotor design of margin 0, as benchmarks.fault_delay finds it:
# mq.anytime_search(task, n_max=10, time_limit=4, fault="rotor", fault_margin=0.0), certified
# (results/fault_delay/flights.csv, the same cells); T-modules.
CAL2_ROTOR = mq.Structure([(0, 0), (0, 1), (0, 2), (0, 3), (1, 0), (1, 1)])


def test_motions_cal_2_known_at_once_holds_once_judged_at_rest():
    """Its smallest-margin rotor failure, known at once: flown to the trajectory's end alone it
    is "not settled: error rising" (the trajectory's own tracking error changes over the judged
    windows); with the hold it settles within 5 cm."""
    from modquad_gym.dynamics.trajectory import Trajectory
    from modquad_gym.dynamics.wrenches import rigid_body_wrenches
    from modquad_gym.sim.fault_verdict import settling

    task = _motions_cal_2()
    assert mq.tolerates(CAL2_ROTOR, task.rotor_wrenches(CAL2_ROTOR), task.f_max,
                        fault="rotor").all()  # fmt: skip
    flight = fly_with_failure(CAL2_ROTOR, task, "rotor", detection_delay_s=0.0, failure="worst")
    assert flight.within_goal and flight.settling.settled, flight.verdict_words()
    # the hold's feed-forward: at rest at the last attitude, the payload held
    held = flight.run.t > task.trajectory.duration + 1e-9
    last = task.trajectory.quaternion[-1] / np.linalg.norm(task.trajectory.quaternion[-1])
    rest = Trajectory.resampled({"t": [0.0], "position": [[0.0, 0.0, 0.0]], "quaternion": [last],
                                 **{f: [[0.0, 0.0, 0.0]] for f in ("velocity", "acceleration",
                                    "angular_velocity", "angular_acceleration")}})  # fmt: skip
    hold_ff = rigid_body_wrenches(rest, CAL2_ROTOR.mass, CAL2_ROTOR.inertia, task.payload)[0]
    np.testing.assert_allclose(flight.run.wrench_ff[held], np.tile(hold_ff, (held.sum(), 1)),
                               atol=1e-12)  # fmt: skip
    # the same failure flown to the trajectory's end only: the blind spot
    f = flight.failure
    alone = fly_trajectory(CAL2_ROTOR, task, failure=Failure(f.columns, f.time_s, 0.0, "rotor"))
    judged = settling(alone.t, alone.position_error, alone.saturated, f.time_s)
    assert judged.growing and not judged.settled, judged


def test_the_up_front_time_check_counts_the_hold():
    """validate --fault's estimate: a trajectory flight is its duration and its hold, the
    failure at its latest (halfway); that bounds every flight flown."""
    import argparse

    from modquad_gym.cli import validate_fault as vf

    duration = LINE.trajectory.duration
    for given, after in ((None, FAULT_SECONDS), (1.1, 1.1), (10.0, 10.0)):
        args = argparse.Namespace(fault="rotor", fault_seconds=given)
        expected = max(duration / 2 + after, duration + 2 * SETTLE_WINDOW_S)
        assert vf._flight_seconds(args, LINE) == pytest.approx(expected)
        flown = fly_with_failure(SQUARE, LINE, "rotor", failure="worst", seconds=given)
        assert flown.run.t[-1] <= vf._flight_seconds(args, LINE) + DT


def test_the_hold_keeps_the_tasks_last_load_so_a_failure_it_cannot_take_does_not_pass():
    # pressing with a constant side force to the end: the failure leaves a negative margin under
    # that load; a hold that took the load away judged the unloaded windows settled
    t = np.linspace(0, 1.0, 41)
    task = dy.DynamicTask(dy.Trajectory(t, np.zeros((41, 3))), f_max=2.0, name="press",
                          exerted=np.tile([3.95, 0, 0, 0, 0, 0], (41, 1)))  # fmt: skip
    s = fly_with_failure(SQUARE, task, "rotor", failure="worst").summary()
    assert s["fault_worst_margin"] < 0
    assert not s["fault_within_5cm"]
    run = fly_trajectory(SQUARE, task, hold_s=1.0)
    held = run.t > task.trajectory.duration + 1e-9
    assert np.allclose(run.wrench_ff[held][:, 0], run.wrench_ff[~held][-1, 0])  # the load stays


def test_a_trajectory_ending_in_motion_goes_on_at_its_final_velocity_not_a_step_to_rest():
    # a straight line at 2 m/s to its end: a hold at rest was a step the controller braked from
    # (0.48 m off with no failure at all, a tolerated failure "beyond 5 cm")
    t = np.linspace(0, 1.5, 31)
    task = dy.DynamicTask(dy.Trajectory(t, np.c_[2.0 * t, 0 * t, 0 * t]), f_max=2.0, name="coast")
    run = fly_trajectory(SQUARE, task, hold_s=1.0)
    assert run.diverged is None and run.max_position_error_m < 0.01
    held = run.t > task.trajectory.duration + 1e-9
    speed = np.diff(run.desired[held][:, 0]) / DT
    assert np.allclose(speed, 2.0)
    s = fly_with_failure(SQUARE, task, "rotor", failure="worst").summary()
    assert s["fault_worst_margin"] > 0 and s["fault_within_5cm"], s["fault_why_not"]
