"""Issue 24, family 3: nothing a user saved is overwritten or lost. Every output refuses an
existing file or folder it did not create unless ``--force``; ``--force`` never breaks another
writer's lock; a model is checked before it replaces the shipped one; devices are no outputs."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from filelock import FileLock
from test_hardening import assert_rejected, run_bench, run_main

from modquad_gym.scoring.optima import lock_path

ROOT = Path(__file__).resolve().parents[1]
TASK = '{"wrenches": [[0, 0, 6, 0.1, 0, 0]]}'


def optima(capsys, tmp_path, out: Path, *extra: str) -> tuple[int, str, str]:
    task = tmp_path / "t.json"
    task.write_text(TASK)
    argv = ["optima", "--tasks", str(task), "--out", str(out), "--n-max", "3", "--quiet"]
    return run_main(capsys, *argv, "--workers", "1", *extra)


@pytest.mark.parametrize(
    "content", [b'{"a": 1}', b'{"a": 1}\n', b"my notes, no newline", TASK.encode()]
)
def test_optima_refuses_a_file_that_is_not_a_dataset(tmp_path, capsys, content):
    """A json.dump output, notes or the task file itself are not datasets: exit 2, unchanged
    (they used to lose their content, exit 0)."""
    out = tmp_path / "notes.txt"
    out.write_bytes(content)
    code, _, err = optima(capsys, tmp_path, out)
    assert_rejected(code, err, "notes.txt", "not an optima record", "--force")
    assert out.read_bytes() == content


def test_optima_resumes_its_own_dataset_and_force_starts_over(tmp_path, capsys):
    out = tmp_path / "o.jsonl"
    assert optima(capsys, tmp_path, out)[0] == 0
    first = out.read_bytes()
    out.write_bytes(first + first[:15])  # an interrupted second record
    code, printed, _ = optima(capsys, tmp_path, out)
    assert code == 0 and "0 records written, 1 already there" in printed
    assert out.read_bytes() == first
    out.write_bytes(b"junk that --force may replace")
    assert optima(capsys, tmp_path, out, "--force")[0] == 0
    (again,) = [json.loads(line) for line in out.read_bytes().splitlines()]
    assert again["digest"] == json.loads(first)["digest"] and again["optimum"] == 3


def test_force_never_breaks_another_writers_lock(tmp_path, capsys):
    """Another run holds the dataset's lock: --force is refused, its records stay."""
    out = tmp_path / "o.jsonl"
    assert optima(capsys, tmp_path, out)[0] == 0
    held = out.read_bytes()
    with FileLock(lock_path(out), timeout=0):  # as another run's build_dataset holds it
        code, _, err = optima(capsys, tmp_path, out, "--force")
    assert_rejected(code, err, "being written by another run")
    assert out.read_bytes() == held


def test_the_dataset_lock_needs_no_posix_module(tmp_path):
    """The lock is filelock's (msvcrt on Windows): the dataset writer imports without fcntl."""
    import subprocess
    import sys

    code = "import sys; sys.modules['fcntl'] = None; import modquad_gym.scoring.optima"
    run = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         cwd=ROOT, timeout=120)  # fmt: skip
    assert run.returncode == 0, run.stderr


@pytest.mark.parametrize("device", ["/dev/null", "/dev/full"])
def test_devices_are_no_outputs(tmp_path, capsys, device):
    code, _, err = optima(capsys, tmp_path, Path(device))
    assert_rejected(code, err, "--out", device, "not a regular file")
    code, _, err = run_main(
        capsys, "task", "generate", "--kind", "paper", "--out", device, "--force"
    )
    assert_rejected(code, err, device, "not a regular file")


@pytest.mark.parametrize(
    "what, name",
    [("oracle", "oracle_benchmark.md"), ("env", "env_benchmark.csv"),
     ("search", "search_benchmark.md"), ("paper", "paper_structures.png"),
     ("scaling", "search_scaling.csv")],
)  # fmt: skip
def test_benchmarks_refuse_to_replace_reports(tmp_path, capsys, what, name):
    (tmp_path / name).write_text("the user's report")
    code, _, err = run_bench(capsys, what, "--out", str(tmp_path))
    assert_rejected(code, err, name, "--force")
    assert (tmp_path / name).read_text() == "the user's report"


def test_publish_run_checks_the_model_before_replacing_anything(tmp_path, capsys, monkeypatch):
    """A junk model.zip, or a model of another tier, is never installed as the shipped one."""
    from agents.cli import main as train_main

    shipped = tmp_path / "shipped" / "model.zip"
    shipped.parent.mkdir()
    shipped.write_bytes(b"the shipped model")
    monkeypatch.setattr("modquad_gym.policy.models.DEFAULT_MODEL", shipped)
    run = tmp_path / "run"
    run.mkdir()
    (run / "model.zip").write_bytes(b"junk")
    (run / "config.json").write_text(json.dumps({"tier": "current", "env_kwargs": {}}))
    with pytest.raises(SystemExit) as exc:
        train_main(["--publish-run", str(run), "--no-report"])
    assert exc.value.code == 2
    assert "--publish-run" in capsys.readouterr().err.splitlines()[-1]
    mixed = ROOT / "modquad_gym" / "data" / "models" / "ppo_mixed"
    if (mixed / "model.zip").is_file():  # the mixed tier's model published as the current tier's
        (run / "model.zip").write_bytes((mixed / "model.zip").read_bytes())
        own = json.loads((mixed / "config.json").read_text())["env_kwargs"]
        (run / "config.json").write_text(json.dumps({"tier": "current", "env_kwargs": own}))
        with pytest.raises(SystemExit):
            train_main(["--publish-run", str(run), "--no-report"])
        assert "its tier's" in capsys.readouterr().err
    assert shipped.read_bytes() == b"the shipped model"
