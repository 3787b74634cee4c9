"""The two doors of a MuJoCo validation, ``validate(out_dir=)`` and ``modquad validate --out``:
one hold of the output folder (refused in the same words while another process writes it, before
any simulation) and the same files written for the same options."""

from __future__ import annotations

import os

os.environ.setdefault("MUJOCO_GL", "egl")  # before mujoco is imported: headless rendering

import importlib  # noqa: E402
import json  # noqa: E402

import numpy as np  # noqa: E402
import pytest  # noqa: E402
from test_hardening import another_run_holds  # noqa: E402

import modquad_gym as mq  # noqa: E402
from modquad_gym.cli import main  # noqa: E402
from modquad_gym.core.outputs import LOCK_NAME, OutputError  # noqa: E402

pytest.importorskip("mujoco")
WRENCHES = [[0.8, 0.0, 3.0, 0.0, 0.1, 0.0]]
"""One wrench (f_max 1): a quick bench and hover."""


def _boom(*args, **kwargs):
    raise AssertionError("a simulation started although another process writes the folder")


def test_both_doors_refuse_a_folder_another_process_writes_in_the_same_words(
    tmp_path, capsys, monkeypatch
):
    """While another process holds the folder (its lock taken on a descriptor of its own), the
    Python door raises and the command exits 2, before any simulation, with the same sentence
    after the name of their own argument (``out_dir``, ``--out``)."""
    sim_validate = importlib.import_module("modquad_gym.sim.validate")  # not the function
    for name in ("_bench", "run_hover", "build_model"):
        monkeypatch.setattr(sim_validate, name, _boom)
    task = tmp_path / "task.json"
    task.write_text(json.dumps({"f_max": 1.0, "wrenches": WRENCHES}))
    folder = tmp_path / "v"
    with another_run_holds(folder):
        with pytest.raises(OutputError) as raised:
            sim_validate.validate(mq.Structure([(0, 0), (1, 0)]), np.array(WRENCHES),
                                  out_dir=folder)  # fmt: skip
        argv = ["validate", "--task", str(task), "--method", "exhaustive", "--out", str(folder)]
        assert main(argv) == 2
    python = str(raised.value)
    line = capsys.readouterr().err.strip().splitlines()[-1]
    assert python.startswith("out_dir: ") and "being written by another run" in python, python
    assert line.endswith(": --out: " + python.removeprefix("out_dir: ")), line
    assert [p.name for p in folder.iterdir()] == [LOCK_NAME]  # the holder's, nothing written


def test_both_doors_write_the_same_files_for_the_same_options(tmp_path, capsys):
    """The command's folder and the Python door's, on the structure the command found with the
    same options and command: the same files (the manifest a later ``force`` reads included),
    the same report, the same record but for the folder in its paths."""
    from modquad_gym.sim.validate import validate
    from modquad_gym.tasks import load_task

    task = tmp_path / "task.json"
    task.write_text(json.dumps({"f_max": 1.0, "wrenches": WRENCHES}))
    cli, py = tmp_path / "cli", tmp_path / "py"
    argv = ["validate", "--task", str(task), "--method", "exhaustive", "--max-hover-wrenches",
            "1", "--hover-seconds", "0.2", "--infeasible-demo", "--out", str(cli)]  # fmt: skip
    assert main(argv) == 0
    capsys.readouterr()
    made = json.loads((cli / "validation.json").read_text())
    validate(mq.Structure([tuple(c) for c in made["cells"]]), load_task(str(task)), out_dir=py,
             max_hover_wrenches=1, hover_seconds=0.2, include_infeasible_demo=True,
             command=f"modquad {' '.join(argv)}")  # fmt: skip
    names = sorted(p.name for p in cli.iterdir())
    assert names == sorted(p.name for p in py.iterdir()) and ".modquad-files.json" in names
    for name in (".modquad-files.json", "report.md"):
        assert (cli / name).read_text() == (py / name).read_text(), name
    mine = (py / "validation.json").read_text().replace(str(py), str(cli))
    assert json.loads(mine) == json.loads((cli / "validation.json").read_text())


def test_the_fault_step_keeps_a_users_picture_without_force(tmp_path, monkeypatch):
    """``validate_with_failure(out_dir=)`` holds its folder as ``--out`` does: an existing
    ``fault_flight.png`` is refused before any flight without ``force`` (the user's file kept),
    and replaced with it."""
    from modquad_gym.sim import validate_fault
    from modquad_gym.sim.validate_fault import validate_with_failure

    s = mq.Structure([(0, 0), (0, 1), (1, 0), (1, 1)])
    task = np.array(WRENCHES)
    picture = tmp_path / "fault_flight.png"
    picture.write_text("USERDATA")
    with monkeypatch.context() as patched:
        patched.setattr(validate_fault, "fly_with_failure", _boom)
        with pytest.raises(OutputError, match="fault_flight.png"):
            validate_with_failure(s, task, "rotor", out_dir=tmp_path, failure="worst", seconds=1.1)
    assert picture.read_text() == "USERDATA"
    record = validate_with_failure(s, task, "rotor", out_dir=tmp_path, force=True,
                                   failure="worst", seconds=1.1)  # fmt: skip
    assert record["fault_files"] == {"fault_flight": str(picture)}
    assert picture.read_bytes().startswith(b"\x89PNG")
