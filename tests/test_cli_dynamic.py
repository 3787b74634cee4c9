"""Dynamic tasks on the command line: `task motion` writes them, `solve` answers them (one JSON
line), `validate` flies them, and bad input is refused with exit code 2 and one line naming the
field, before any work."""

import json
import math
import re

import numpy as np
import pytest

import modquad_gym as mq
from modquad_gym import dynamics as dy
from modquad_gym.cli import main
from modquad_gym.tasks import load_task


def one_line_error(capsys, argv, match):
    assert main(argv) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and match in err, err
    return err


def test_task_motion_then_solve(tmp_path, capsys):
    out = tmp_path / "circle.json"
    argv = ["task", "motion", "--kind", "circle", "--radius", "1", "--speed", "2"]
    assert main([*argv, "--rate", "20", "--out", str(out)]) == 0
    task = load_task(out)
    assert isinstance(task, dy.DynamicTask) and task.meta["speed"] == 2.0
    capsys.readouterr()
    for method in ("exhaustive", "anytime", "greedy", "ppo", "ppo-guided"):
        assert (
            main(["solve", "--task", str(out), "--method", method, "--n-max", "8", "--json"]) == 0
        )
        line = json.loads(capsys.readouterr().out.strip())
        for key in ("cells", "n_modules", "lower_bound", "certified", "evaluated", "feasible"):
            assert key in line
        assert line["kind"] == "dynamic" and line["feasible"]
        s = mq.Structure([tuple(c) for c in line["cells"]])
        assert mq.feasible(s.configuration_matrix(), task.rotor_wrenches(s), task.f_max).all()
        if method in ("exhaustive", "anytime"):
            assert line["certified"] and line["n_modules"] == 4
    one_line_error(capsys, [*argv, "--out", str(out)], "exists")


def test_task_motion_refuses_misplaced_options(tmp_path, capsys):
    out = str(tmp_path / "x.json")
    one_line_error(
        capsys, ["task", "motion", "--kind", "hover", "--speed", "1", "--out", out], "--speed"
    )
    argv = ["task", "motion", "--kind", "hover", "--payload-mass", "1000", "--out", out]
    one_line_error(capsys, argv, "--payload-mass")  # the option, not the file's key


def test_validate_flies_a_dynamic_task(tmp_path, capsys, monkeypatch):
    """The CLI hands a dynamic task to validate_trajectory (stubbed here: the flight itself
    is tested in test_track.py) and prints its record."""
    from modquad_gym.sim import validate_track

    seen = {}

    def fake(structure, task, **kw):
        seen.update(kw, structure=structure, task=task)
        return {"track_max_position_error_m": 0.001, "track_saturated_fraction": 0.0}

    monkeypatch.setattr(validate_track, "validate_trajectory", fake)
    path = dy.line(0.5, 1.0, rate=20).save(tmp_path / "line.json")
    argv = ["validate", "--task", str(path), "--method", "exhaustive", "--json"]
    assert main([*argv, "--max-hover-wrenches", "3", "--out", str(tmp_path / "v")]) == 0
    said = capsys.readouterr()
    record = json.loads(said.out.strip().splitlines()[-1])
    assert re.search(r": about \d+ simulated s \(~\d+ s here\)", said.err), said.err  # rounded
    assert record["track_max_position_error_m"] == 0.001 and record["method"] == "exhaustive"
    assert isinstance(seen["task"], dy.DynamicTask) and seen["max_bench_wrenches"] == 3


def _trajectory(**over):
    t = np.linspace(0, 1, 11)
    traj = {"t": t.tolist(), "position": np.zeros((11, 3)).tolist()}
    return {"trajectory": {**traj, **over}, "f_max": 2.0}


@pytest.mark.parametrize(
    "data, field",
    [
        (_trajectory(t=[0.0, 0.2, 0.1] + [0.3 + 0.1 * i for i in range(8)]), "trajectory.t"),
        (_trajectory(quaternion=[[1.0, 0.5, 0, 0]] * 11), "trajectory.quaternion"),
        (_trajectory(position=[[0, 0, 0]] * 10 + [[0, math.nan, 0]]), "trajectory.position"),
        ({**_trajectory(), "payload": {"mass": 1000.0}}, "payload.mass"),
        (
            {"trajectory": {"t": list(range(10**6)), "position": [[0, 0, 0]]}},
            "trajectory.t",
        ),
    ],
)
def test_bad_dynamic_input_exits_2_with_one_line(tmp_path, capsys, data, field):
    path = tmp_path / "bad.json"
    path.write_text(json.dumps(data).replace("NaN", "NaN"))
    for command in ("solve", "validate"):
        argv = [command, "--task", str(path), "--method", "exhaustive"]
        if command == "validate":
            argv += ["--out", str(tmp_path / "v")]
        one_line_error(capsys, argv, field)


def test_learned_methods_use_the_dynamic_model_for_dynamic_tasks(tmp_path, capsys):
    """Without a model, ppo on a dynamic task of one module type acts with the model trained
    on motions, in Python and on the command line alike; a static task, a model or a palette
    keep their choice."""
    from modquad_gym.geometry.module import palette
    from modquad_gym.policy.models import default_model, shipped_model
    from modquad_gym.solvers import make_solver

    circle = dy.circle(radius=1.0, speed=1.0, rate=10)
    dynamic_model = shipped_model("dynamic")
    assert dynamic_model.is_file() and dynamic_model != shipped_model("current")
    for method in ("ppo", "ppo-guided-b64"):
        solver = make_solver(method)
        assert solver.inner(7, None, "dynamic").policy.model_path == str(dynamic_model)
        assert solver.inner(7, None, None).policy.model_path == str(default_model(7))
    types = palette("t45,flat")
    assert make_solver("ppo", modules=types).inner(7, types, "dynamic").policy.model_path == str(
        default_model(7, types)
    )
    path = tmp_path / "circle.json"
    circle.save(path)
    assert main(["solve", "--task", str(path), "--method", "ppo", "--json"]) == 0
    line = json.loads(capsys.readouterr().out)
    python = make_solver("ppo").solve(circle).to_dict()
    assert line == {**line, **python, "seconds": line["seconds"]}
