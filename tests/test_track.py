"""Flying dynamic tasks in MuJoCo, and MuJoCo at 64 modules (bench, hover, readable pictures)."""

from __future__ import annotations

import json

import numpy as np
import pytest

import modquad_gym as mq
from modquad_gym import dynamics as dy

pytest.importorskip("mujoco")

from modquad_gym.oracle import feasible  # noqa: E402
from modquad_gym.sim import build_model, run_bench, run_hover  # noqa: E402
from modquad_gym.sim.track import TrackConfig, fly_trajectory  # noqa: E402
from modquad_gym.sim.validate_track import bench_sample, validate_trajectory  # noqa: E402

SQUARE = mq.Structure([(0, 0), (1, 0), (0, 1), (1, 1)])


@pytest.mark.parametrize(
    "task",
    [
        dy.circle(speed=1.5, heading="tangent", laps=0.5),
        dy.figure_eight(speed=1.0, laps=0.5, payload=dy.Payload(0.3, (0.0, 0.0, -0.1))),
        dy.push(distance=1.0, force=2.0),
    ],
    ids=["circle-tangent", "eight-payload", "push"],
)
def test_feasible_tasks_are_tracked_within_5_cm_without_saturating(task):
    W = task.rotor_wrenches(SQUARE)
    assert feasible(SQUARE.configuration_matrix(), W, task.f_max).all()
    res = fly_trajectory(SQUARE, task)
    assert res.diverged is None
    assert res.max_position_error_m <= 0.05
    assert res.saturated_fraction == 0.0
    assert np.all((res.inputs >= 0) & (res.inputs <= task.f_max))
    assert res.t[-1] == pytest.approx(task.trajectory.duration, abs=0.01)


def test_an_infeasible_task_saturates_or_strays():
    line = mq.Structure([(0, 0), (1, 0)])  # rank 5: no level sideways force along y
    task = dy.circle(speed=1.5, laps=0.5)
    assert not feasible(line.configuration_matrix(), task.rotor_wrenches(line), task.f_max).all()
    res = fly_trajectory(line, task, TrackConfig(drift_limit_m=0.5))
    assert res.max_position_error_m > 0.05 or res.saturated_fraction > 0


def test_validate_trajectory_writes_record_and_pictures(tmp_path):
    task = dy.circle(speed=1.0, laps=0.25, payload=0.2)
    rec = validate_trajectory(SQUARE, task, out_dir=tmp_path, max_bench_wrenches=4,
                              hover_seconds=0.3, unknown_load=False)  # fmt: skip
    assert rec["task_kind"] == "dynamic"
    assert rec["bench_max_error"] <= 1e-6
    assert rec["track_max_position_error_m"] <= 0.05
    assert rec["track_saturated_fraction"] == 0.0
    for name in ("track_path.png", "track_inputs.png", "track.gif", "report.md"):
        assert (tmp_path / name).stat().st_size > 0
    assert json.loads((tmp_path / "validation.json").read_text())["track_seconds"] > 0
    assert "Flight along the trajectory" in (tmp_path / "report.md").read_text()


def test_bench_sample_takes_the_hardest_and_spreads_the_rest():
    W = task_W = dy.circle(speed=1.0).rotor_wrenches(SQUARE)
    rows = bench_sample(W, SQUARE.configuration_matrix(), 2.0, 10)
    assert len(rows) == 10 and np.all(np.diff(rows) > 0)
    assert np.array_equal(bench_sample(task_W[:5], SQUARE.configuration_matrix(), 2.0, 10),
                          np.arange(5))  # fmt: skip


def test_64_modules_bench_and_hover(tmp_path):
    from modquad_gym.sim.pictures import plot_rotor_inputs

    s = mq.Structure([(i, j) for i in range(8) for j in range(8)])
    A = s.configuration_matrix()
    W = np.random.default_rng(0).uniform(0.2, 0.8, (3, A.shape[1])) @ A.T
    bench = run_bench(build_model(s, 1.0, bench=True), W, allocation="exact")
    assert bench.max_error <= 1e-6
    hover = run_hover(build_model(s, 1.0), W[:1], seconds_per_wrench=1.0, takeoff_seconds=1.0)
    assert hover.max_position_error <= 0.01
    plot_rotor_inputs([bench], tmp_path / "inputs.png")  # 256 rotors: a heat map
    assert (tmp_path / "inputs.png").stat().st_size > 0
