"""The commands that fill folders (train.py's run and log folders, ``modquad validate`` and
the Python ``validate``, the fault benchmark, the leaderboard's rescoring): another run's files
are refused before any work unless ``--force``, which removes what the earlier run recorded,
earlier rows that cannot be read are named by file and row, and a write is whole or absent."""

from __future__ import annotations

import importlib
import json
import os
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

import modquad_gym as mq
from modquad_gym.core.outputs import MANIFEST_NAME, OutputError, write_text

ROOT = Path(__file__).resolve().parents[1]
QUIET = ["--no-report", "--no-progress"]


# --------------------------------------------------------------------------------- train.py
@pytest.fixture
def fake_training(monkeypatch):
    """``agents.cli.run`` replaced by one that writes, as training does, the run files into
    each run folder and a checkpoint named after the run's seed into its log folder."""
    pytest.importorskip("sb3_contrib")
    from agents import cli
    from agents.training import RUN_FILES, log_name

    def run(args):
        for out in cli.run_folders(args):
            if args.resume is not None:
                assert Path(args.resume).is_file(), "the model to continue was removed"
            for name in RUN_FILES:
                write_text(out / name, f"seed {args.seed}")
            log = Path(args.tensorboard) / log_name(out, Path(args.tensorboard)) / "train"
            write_text(log / "checkpoints" / f"ppo_{args.seed}_steps.zip", f"seed {args.seed}")
            write_text(log / "best_model.zip", f"seed {args.seed}")
        return 0

    monkeypatch.setattr(cli, "run", run)
    return cli.main


def test_train_refuses_a_log_folder_that_holds_another_runs_logs(tmp_path, capsys, fake_training):
    """Two run folders with the same last two names share a log folder: the second run is
    refused at once (exit 2, one line naming the folder and --force); the first's files stay."""
    tb = tmp_path / "tb"
    first = ["--out", str(tmp_path / "p1/a/run"), "--tensorboard", str(tb), *QUIET]
    assert fake_training(first) == 0
    best = tb / "a-run" / "train" / "best_model.zip"
    assert best.read_text() == "seed 0"
    with pytest.raises(SystemExit) as stop:
        fake_training(["--out", str(tmp_path / "p2/a/run"), "--tensorboard", str(tb), "--seed", "5",
                       *QUIET])  # fmt: skip
    assert stop.value.code == 2
    last = capsys.readouterr().err.strip().splitlines()[-1]
    assert "--tensorboard" in last and str(tb / "a-run") in last and "--force" in last
    assert best.read_text() == "seed 0" and not (tmp_path / "p2").exists()


def test_train_force_removes_the_earlier_runs_recorded_logs_only(tmp_path, fake_training):
    tb = tmp_path / "tb"
    first = ["--out", str(tmp_path / "p1/a/run"), "--tensorboard", str(tb), *QUIET]
    assert fake_training(first) == 0
    log = tb / "a-run"
    (log / "my_notes.txt").write_text("keep me")
    assert "train/checkpoints/ppo_0_steps.zip" in json.loads((log / MANIFEST_NAME).read_text())
    argv = ["--out", str(tmp_path / "p2/a/run"), "--tensorboard", str(tb), "--seed", "5", *QUIET]
    assert fake_training([*argv, "--force"]) == 0
    assert sorted(p.name for p in (log / "train" / "checkpoints").iterdir()) == ["ppo_5_steps.zip"]
    assert (log / "my_notes.txt").read_text() == "keep me"
    recorded = json.loads((tmp_path / "p2/a/run" / MANIFEST_NAME).read_text())
    assert {"model.zip", "config.json", "model_actor.npz", "evaluations.npz"} <= set(recorded)


def test_train_in_a_run_folder_records_its_logs_and_force_keeps_the_model_it_resumes(
    fake_training, untrained_run
):
    """With the log folder inside the run folder (``--out`` in ``--tensorboard``) its train/
    files are recorded there; ``--resume`` of the run's own model with ``--force`` removes
    them but keeps that model."""
    run = untrained_run("own")
    saved = {name: (run / name).read_bytes() for name in ("model.zip", "config.json")}
    argv = ["--out", str(run), "--tensorboard", str(run.parent), "--force", *QUIET]
    assert fake_training(argv) == 0
    assert "train/checkpoints/ppo_0_steps.zip" in json.loads((run / MANIFEST_NAME).read_text())
    for name, data in saved.items():  # the model and config training saved
        (run / name).write_bytes(data)
    resume = ["--resume", str(run / "model.zip"), "--trust-model", "--seed", "1"]
    assert fake_training([*resume, *argv]) == 0  # (the fake asserts the model is still there)
    assert sorted(p.name for p in (run / "train" / "checkpoints").iterdir()) == ["ppo_1_steps.zip"]


def test_train_resuming_its_own_run_goes_on_in_its_log_folder(tmp_path, fake_training,
                                                              untrained_run):  # fmt: skip
    """The log folder a ``--resume`` model's config.json records (log_dir) is its own run's:
    a continuation into a new run folder of the same last two names is not refused."""
    earlier = untrained_run("a")
    tb = tmp_path / "tb"
    logs = tb / f"{earlier.parent.name}-a" / "train"
    write_text(logs / "checkpoints" / "ppo_64_steps.zip", "earlier")
    record = json.loads((earlier / "config.json").read_text())
    record["log_dir"] = os.path.relpath(logs, earlier)
    (earlier / "config.json").write_text(json.dumps(record))
    out = tmp_path / earlier.parent.name / "a"
    argv = ["--resume", str(earlier / "model.zip"), "--trust-model", "--out", str(out),
            "--tensorboard", str(tb), *QUIET]  # fmt: skip
    assert fake_training(argv) == 0
    assert (logs / "checkpoints" / "ppo_64_steps.zip").read_text() == "earlier"


# ------------------------------------------------------------------------- validate (MuJoCo)
def _boom(*args, **kwargs):
    raise AssertionError("a simulation started before the outputs were checked")


def test_python_validate_checks_out_dir_before_any_simulation(tmp_path, monkeypatch):
    pytest.importorskip("mujoco")
    sim_validate = importlib.import_module("modquad_gym.sim.validate")  # not the function
    s, W = mq.Structure([(0, 0), (1, 0)]), np.array([[0.0, 0.0, 2.0, 0.0, 0.0, 0.0]])
    with monkeypatch.context() as m:
        m.setattr(sim_validate, "_bench", _boom)
        m.setattr(sim_validate, "run_hover", _boom)
        (tmp_path / "afile").write_text("x")
        with pytest.raises(OutputError, match="out_dir: .*afile exists and is not a folder"):
            sim_validate.validate(s, W, out_dir=tmp_path / "afile")
        (tmp_path / "report.md").write_text("MY OWN NOTES")
        with pytest.raises(OutputError, match=r"out_dir: .*report\.md .*force=True"):
            sim_validate.validate(s, W, out_dir=tmp_path)
    assert (tmp_path / "report.md").read_text() == "MY OWN NOTES"
    sim_validate.validate(s, W, out_dir=tmp_path, hover_seconds=0.1, render=False,
                          unknown_load=False, force=True)  # fmt: skip
    assert (tmp_path / "report.md").read_text().startswith("# MuJoCo validation")


def test_validate_trajectory_checks_its_pictures_before_flying(tmp_path, monkeypatch):
    pytest.importorskip("mujoco")
    from modquad_gym import dynamics as dy
    from modquad_gym.sim import validate_track

    monkeypatch.setattr(importlib.import_module("modquad_gym.sim.validate"), "validate", _boom)
    monkeypatch.setattr(validate_track, "fly_trajectory", _boom)
    (tmp_path / "track_path.png").write_text("mine")
    with pytest.raises(OutputError, match=r"track_path\.png .*force=True"):
        line = dy.line(0.5, 1.0, rate=20)
        validate_track.validate_trajectory(mq.Structure([(0, 0), (1, 0)]), line, out_dir=tmp_path)
    assert (tmp_path / "track_path.png").read_text() == "mine"


def test_validate_records_its_files_and_force_removes_an_earlier_runs(tmp_path, monkeypatch):
    """The folder's manifest lists what validate wrote: a --force run without
    --infeasible-demo leaves no hover_infeasible.png of the run before it."""
    pytest.importorskip("mujoco")
    from modquad_gym.cli import main

    sim_validate = importlib.import_module("modquad_gym.sim.validate")

    def fake(structure, task, out_dir=None, include_infeasible_demo=False, force=False, **kw):
        for name in sim_validate.output_names(include_infeasible_demo=include_infeasible_demo):
            write_text(Path(out_dir) / name, "this run's")
        return SimpleNamespace(to_dict=dict)

    monkeypatch.setattr(sim_validate, "validate", fake)
    out = tmp_path / "v"
    argv = ["validate", "--task", "example:screwdriver", "--out", str(out),
            "--max-hover-wrenches", "1", "--hover-seconds", "0.1"]  # fmt: skip
    assert main([*argv, "--infeasible-demo"]) == 0
    assert "hover_infeasible.png" in json.loads((out / MANIFEST_NAME).read_text())
    (out / "my_notes.md").write_text("keep me")
    assert main([*argv, "--force"]) == 0
    assert not (out / "hover_infeasible.png").exists() and (out / "report.md").is_file()
    assert (out / "my_notes.md").read_text() == "keep me"


# ------------------------------------------------------------------- the fault benchmark
FAULTS_CSV = ROOT / "results" / "faults" / "faults.csv"


@pytest.mark.parametrize("option", ["--oracle-only", "--update"])
def test_faults_names_the_file_and_row_of_a_cut_faults_csv(tmp_path, capsys, monkeypatch, option):
    """Before any search or timing: one line naming the option, the file and the row."""
    from benchmarks import faults
    from benchmarks.common import run_main

    monkeypatch.setattr(faults, "oracle_speed", _boom)
    monkeypatch.setattr(faults, "price", _boom)
    text = FAULTS_CSV.read_text()
    cut = text[: text.index("\n", 1500) - 20]  # a file cut in the middle of a row
    (tmp_path / "faults.csv").write_text(cut)
    argv = [option, "--force", "--out", str(tmp_path), "--suites", "heldout_paper"]
    assert run_main(faults.main, "faults", argv) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "Traceback" not in err, err
    assert f"{tmp_path / 'faults.csv'}: row {cut.count(chr(10))}:" in err and option in err
    assert (tmp_path / "faults.csv").read_text() == cut


def test_faults_csv_is_replaced_whole_or_not_at_all(tmp_path, monkeypatch):
    """A write that fails half-way (the disk fills) leaves the earlier faults.csv as it was."""
    from benchmarks import faults
    from benchmarks.common import run_main

    class Full:
        def __str__(self):
            raise OSError(28, "No space left on device")

    monkeypatch.setattr(faults, "oracle_speed", lambda: [])
    monkeypatch.setattr(faults, "explain_missing", lambda rows: rows.append({"suite": Full()}))
    (tmp_path / "faults.csv").write_bytes(FAULTS_CSV.read_bytes())
    argv = ["--oracle-only", "--force", "--out", str(tmp_path)]
    assert run_main(faults.main, "faults", argv) == 2
    assert (tmp_path / "faults.csv").read_bytes() == FAULTS_CSV.read_bytes()


# ------------------------------------------------------------------------ the leaderboard
def test_rescoring_with_nothing_to_rescore_says_so_and_writes_nothing(tmp_path, capsys):
    from benchmarks.leaderboard_entries import TIERS
    from benchmarks.leaderboard_scoring import rescore_searches
    from modquad_gym.search import SEARCHES

    header = "suite,task,optimum,method,success,n_modules,gap,optimal,evaluated,oracle_calls,"
    for tier in TIERS:  # every tier report already ran every search
        rows = [f"{header}seconds,cells", *(f's,t,5,{m},1,5,0,1,1,1,0.1,"0,0"' for m in SEARCHES)]
        write_text(tmp_path / "results" / f"tier_{tier}" / "benchmark.csv", "\n".join(rows) + "\n")
    into = tmp_path / "into"
    assert rescore_searches(tmp_path / "results", progress=False, into=into) is None
    assert "nothing to rescore" in capsys.readouterr().err
    assert not into.exists()
