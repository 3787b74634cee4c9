"""Given derivatives against the samples, the coarse-sampling estimate on few samples, and the
dynamic task's doors (review 19, dynamics): rates given without quaternions give their angular
acceleration; rates, velocities and accelerations that disagree with the samples (times in
milliseconds) are refused naming field, sample and both values; the motions' own exact
derivatives, the tier's draws and the shipped suite pass; 4 samples get a real estimate; row
errors name the sample; a ``kind: dynamic`` file without a trajectory names it; ``with_f_max``
keeps meta; the Python door refuses what the command line refuses."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from test_edges_cli import assert_one_line_error, run_main

import modquad_gym as mq
from modquad_gym import dynamics as dy
from modquad_gym.dynamics import quaternions as quat
from modquad_gym.dynamics.random_motions import MotionTasks
from modquad_gym.tasks import TaskFileError, load_suite, load_task

T = np.linspace(0.0, 1.0, 11)
REST = np.zeros((11, 3))
ROLL = np.c_[60 * T, 0 * T, 0 * T]  # roll rate ramping at 60 rad/s^2


# --------------------------------------------------------------- rates without quaternions
def test_rates_without_quaternions_give_their_angular_acceleration():
    alone = dy.Trajectory(T, REST, angular_velocity=ROLL)
    np.testing.assert_allclose(
        alone.angular_acceleration, np.tile([60.0, 0, 0], (11, 1)), atol=1e-9
    )
    given = dy.Trajectory(
        T, REST, angular_velocity=ROLL, angular_acceleration=alone.angular_acceleration
    )
    pair = mq.Structure([(0, 0), (1, 0)])
    w = dy.DynamicTask(alone, f_max=2.0).rotor_wrenches(pair)
    np.testing.assert_allclose(w, dy.DynamicTask(given, f_max=2.0).rotor_wrenches(pair))
    assert abs(w[5, 3]) > 0.4  # J_xx alpha: the torque the 0 rad/s^2 of before left out


def test_a_rate_file_without_quaternions_needs_more_than_one_module(tmp_path, capsys):
    t = np.linspace(0, 10, 11)
    spin = [[0, 0, 0.5 * x] for x in t]  # yaw rate ramping at 0.5 rad/s^2, no attitude given
    data = {"trajectory": {"t": t.tolist(), "position": np.zeros((11, 3)).tolist(),
                           "angular_velocity": spin}, "f_max": 2}  # fmt: skip
    task = load_task(_write(tmp_path / "spin.json", data))
    np.testing.assert_allclose(task.trajectory.angular_acceleration[:, 2], 0.5, atol=1e-9)
    assert task.wrench_model.uses_inertia


def test_rates_that_disagree_with_the_quaternions_are_refused():
    level = np.tile([1.0, 0, 0, 0], (11, 1))
    match = (
        r"^angular_velocity: sample 2 is \[6, 0, 0\] rad/s, but the quaternions imply \[0, 0, 0\]"
    )
    with pytest.raises(ValueError, match=match):
        dy.Trajectory(T, REST, level, angular_velocity=ROLL)
    with pytest.raises(ValueError, match=r"^angular_acceleration: sample 1 is \[60, 0, 0\]"):
        dy.Trajectory(T, REST, level, angular_acceleration=np.tile([60.0, 0, 0], (11, 1)))
    t = np.linspace(0, 2, 201)
    yaw = 0.3 * t**2  # rates and acceleration that do agree: accepted as given
    rates, alpha = np.c_[0 * t, 0 * t, 0.6 * t], np.tile([0, 0, 0.6], (201, 1))
    ok = dy.Trajectory(t, np.zeros((201, 3)), quat.about_z(yaw), angular_velocity=rates,
                       angular_acceleration=alpha)  # fmt: skip
    assert ok.given[-2:] == ("angular_velocity", "angular_acceleration")


# ------------------------------------------------------ given derivatives against samples
def _write(path, data) -> str:
    path.write_text(json.dumps(data))
    return str(path)


def _in_milliseconds(task: dy.DynamicTask) -> dict:
    data = task.to_dict()
    data["trajectory"]["t"] = [1000.0 * x for x in data["trajectory"]["t"]]
    return data


@pytest.mark.parametrize("motion", ["line", "circle", "figure-eight", "push"])
def test_a_motion_written_in_milliseconds_is_refused(tmp_path, capsys, motion):
    path = _write(tmp_path / "ms.json", _in_milliseconds(dy.MOTIONS[motion](rate=20.0)))
    with pytest.raises(
        TaskFileError, match=r"trajectory\.(velocity|acceleration): sample \d+ is \["
    ):
        load_task(path)
    code, _, err = run_main(
        capsys, "solve", "--task", path, "--method", "exhaustive", "--n-max", "4"
    )
    assert_one_line_error(code, err, path, "but the positions imply", "check the units")


def test_a_wrong_given_velocity_is_refused_naming_both_values():
    t = np.linspace(0, 2 * math.pi, 200)
    pos = np.c_[np.cos(t), np.sin(t), 0 * t]
    vel = np.c_[-np.sin(t), np.cos(t), 0 * t]
    dy.Trajectory(t, pos, velocity=vel)  # right: accepted
    with pytest.raises(
        ValueError,
        match=r"^velocity: sample 1 is \[0, 2, 0\] m/s, but the positions imply \[.*1, 0\]",
    ):
        dy.Trajectory(t, pos, velocity=2 * vel)


def test_the_motions_the_tier_draws_and_the_suite_pass_the_check():
    """What `modquad task motion` writes (every kind, default and extreme options), the tier's
    draws and the shipped dynamic suite carry given derivatives that agree with their samples."""
    for make in dy.MOTIONS.values():
        for rate in (4.0, 10.0, 1000.0):
            make(rate=rate)
    dy.line(100.0, 50.0, rate=4.0)
    dy.line(0.01, 50.0, rate=1000.0)
    dy.circle(50.0, 5.0, laps=3.0, heading="tangent", rate=4.0)
    dy.circle(0.05, 0.1, laps=3.0, heading="tangent", rate=100.0)
    dy.figure_eight(0.05, 1.0, laps=3.0, rate=4.0)  # 1.8 samples per turn: still accepted
    for seed in range(60):
        MotionTasks()(np.random.default_rng(seed))
    assert len(load_suite("modquad_gym/data/suites/dynamic_motions.json")) == 60


def test_task_motion_names_rate_when_its_samples_cannot_show_the_motion(tmp_path, capsys):
    out = tmp_path / "c.json"
    code, _, err = run_main(capsys, "task", "motion", "--kind", "circle", "--radius", "0.05",
                            "--speed", "5", "--laps", "100", "--rate", "4", "--f-max", "1000",
                            "--out", str(out))  # fmt: skip
    line = assert_one_line_error(code, err, "raise --rate")
    assert line.startswith("modquad: error: --rate: samples every 0.244 s are too sparse"), line
    assert not out.exists()


# ------------------------------------------------------------- coarse sampling, few samples
def test_four_samples_get_a_real_estimate():
    t = np.arange(4.0)
    with pytest.raises(ValueError, match=r"^acceleration: sampling too coarse .* lower order"):
        dy.Trajectory(t, np.c_[[0, 0, 1, 1], [0] * 4, [0] * 4])
    with pytest.raises(ValueError, match=r"^angular_acceleration: sampling too coarse"):
        dy.Trajectory(t, np.zeros((4, 3)), quat.about_z(np.array([0, 0, 1, 1.0])))
    gentle = dy.Trajectory(t, np.c_[[0, 0.001, 0.004, 0.01], [0] * 4, [0] * 4])
    assert 0 < gentle.derivative_error["acceleration"] < 0.05


def test_three_samples_compare_with_a_line():
    with pytest.raises(ValueError, match=r"^acceleration: sampling too coarse"):
        dy.Trajectory([0, 1, 2], [[0, 0, 0], [0, 0, 0], [1, 0, 0]])
    assert dy.Trajectory([0, 1, 2], np.zeros((3, 3))).derivative_error["acceleration"] == 0.0


# ----------------------------------------------------------------------------- file errors
@pytest.mark.parametrize(
    "field, index, row, words",
    [
        ("position", 4, [0, 0], "trajectory.position: sample 5 has 2 entries, expected 3"),
        ("velocity", 7, [0, 0, 0, 0], "trajectory.velocity: sample 8 has 4 entries, expected 3"),
        ("position", 4, [0, 0, "x"], "trajectory.position: sample 5 holds 'x', not a number"),
        ("exerted", 9, [0] * 5, "exerted: sample 10 has 5 entries, expected 6"),
    ],
)
def test_a_wrong_row_names_its_field_and_sample(tmp_path, capsys, field, index, row, words):
    data = dy.hover(1.0, rate=20.0).to_dict()
    data["exerted"] = [[0.0] * 6] * len(data["trajectory"]["t"])
    (data if field == "exerted" else data["trajectory"])[field][index] = row
    path = _write(tmp_path / "row.json", data)
    with pytest.raises(TaskFileError, match=f"^{path}: {words}".replace(".", r"\.")):
        load_task(path)
    code, _, err = run_main(capsys, "solve", "--task", path)
    assert_one_line_error(code, err, path, words)


def test_a_dynamic_file_without_trajectory_names_it(tmp_path, capsys):
    data = dy.hover(1.0, rate=20.0).to_dict()
    del data["trajectory"]
    path = _write(tmp_path / "nt.json", data)
    code, _, err = run_main(capsys, "solve", "--task", path)
    assert_one_line_error(code, err, path, "trajectory: missing")
    suite = _write(tmp_path / "s.json", {"name": "s", "tasks": [data]})
    with pytest.raises(TaskFileError, match="task 1: trajectory: missing"):
        load_suite(suite)


def test_with_f_max_keeps_meta():
    task = dy.circle(rate=20.0)
    assert task.with_f_max(3.0).meta == task.meta and task.meta["motion"] == "circle"


# ----------------------------------------------------------- the Python door and the CLI's
@pytest.mark.parametrize(
    "call, match",
    [
        (lambda: dy.hover(payload=(0, (0, 0, 1))), r"^payload\.offset \[0\.0, 0\.0, 1\.0\] places"),
        (lambda: dy.Payload(0, (5, 0, 0)), r"^payload\.offset .* payload\.mass is 0 kg"),
        (lambda: dy.hover(payload=(1, (0, 0, 0), 5)), r"^payload must be .* got 3 entries"),
        (lambda: dy.line(direction=(np.inf, 0, 0)), r"^direction must be a finite non-zero"),
        (lambda: dy.line(direction="x"), r"^direction must be"),
        (lambda: dy.push(direction=(1, 0, 0.1)), r"^direction must be a finite horizontal"),
    ],
)
def test_the_python_door_refuses_what_the_command_line_refuses(call, match):
    with pytest.raises(ValueError, match=match):
        call()


def test_a_zero_payload_with_an_offset_is_refused_in_a_file(tmp_path):
    data = {**dy.hover(1.0, rate=20.0).to_dict(), "payload": {"mass": 0, "offset": [0, 0, 1]}}
    with pytest.raises(TaskFileError, match=r"payload\.offset .* payload\.mass is 0 kg"):
        load_task(_write(tmp_path / "p.json", data))


@pytest.mark.parametrize(
    "option, match",
    [
        ({"f_max": 50.0}, r"^f_max = 50\.0: applies to a wrench array only"),
    ],
)
def test_a_flight_through_a_failure_refuses_what_a_dynamic_task_ignores(option, match):
    from modquad_gym.sim.fault_flight import fly_with_failure

    task = dy.line(0.3, 1.0, hold=0.3, rate=20.0)
    with pytest.raises(ValueError, match=match):
        fly_with_failure(mq.Structure([(0, 0), (1, 0), (0, 1), (1, 1)]), task, "rotor", **option)


def test_tangent_heading_points_body_y_along_the_path():
    traj = dy.circle(1.0, 2.0, heading="tangent").trajectory
    centre = np.array([-1.0, 0.0, 0.0])
    for i in range(0, len(traj.t), 37):
        R, v = traj.rotations()[i], traj.velocity[i]
        if np.linalg.norm(v) > 0.5:
            np.testing.assert_allclose(R[:, 1], v / np.linalg.norm(v), atol=1e-9)
            radial = traj.position[i] - centre
            np.testing.assert_allclose(R[:, 0], radial / np.linalg.norm(radial), atol=1e-9)
            assert (R.T @ traj.acceleration[i])[0] < 0  # the centripetal pull along body -x


def test_validate_report_calls_the_bench_a_sample_of_the_trajectory(tmp_path):
    from modquad_gym.sim.validate_track import validate_trajectory

    task = dy.line(0.3, 1.0, hold=0.2, rate=20.0)
    record = validate_trajectory(mq.Structure([(0, 0), (1, 0)]), task, out_dir=tmp_path,
                                 max_bench_wrenches=3, hover_seconds=0.2, unknown_load=False,
                                 render=False)  # fmt: skip
    n = task.n_wrenches
    assert record["n_wrenches"] == 3 and record["trajectory_samples"] == n > 3
    head = [x for x in (tmp_path / "report.md").read_text().splitlines() if x.startswith("Task:")]
    assert len(head) == 1 and f"3 of its {n} rotor wrenches" in head[0], head
    assert "wrenches of kind total" not in head[0]
