"""`modquad validate` end to end on a one-wrench task (fast: one hover wrench)."""

from __future__ import annotations

import os

os.environ.setdefault("MUJOCO_GL", "egl")  # before mujoco is imported: headless rendering

import json  # noqa: E402
from pathlib import Path  # noqa: E402

import pytest  # noqa: E402

from modquad_gym.cli import main  # noqa: E402


def test_validate_cli_json(tmp_path, capsys):
    task = tmp_path / "task.json"
    task.write_text(
        json.dumps({"name": "one", "f_max": 1.0, "wrenches": [[0.8, 0.0, 3.0, 0.0, 0.1, 0.0]]})
    )
    out_dir = tmp_path / "out"
    argv = ["validate", "--task", str(task), "--method", "exhaustive"]
    argv += ["--max-hover-wrenches", "1", "--out", str(out_dir), "--json"]
    assert main(argv) == 0
    lines = [line for line in capsys.readouterr().out.splitlines() if line.strip()]
    record = json.loads(lines[-1])
    assert record["method"] == "exhaustive" and record["feasible"] is True
    assert record["bench_max_error"] <= 1e-6
    assert 0.0 <= record["hover_max_position_error_m"] <= 0.01
    assert record["hover_wrenches"] == 1 and record["saturated_fraction"] == 0.0
    assert "hover_unknown_load_max_position_error_m" in record
    files = record["files"]
    for key in ("report", "json", "hover", "rotor_inputs", "bench_wrench"):
        assert Path(files[key]).is_file(), key
    assert Path(files["json"]) == out_dir / "validation.json"
    saved = json.loads((out_dir / "validation.json").read_text())
    assert saved["files"] == files
    assert saved["bench_max_error"] == record["bench_max_error"]
    assert "all 1 wrenches" in (out_dir / "report.md").read_text()
    made_by = (out_dir / "report.md").read_text().splitlines()[2]  # under the title
    assert made_by == f"Made by `modquad {' '.join(argv)}`."


def test_validate_cli_known_load_only_and_bad_hover_time(tmp_path, capsys):
    task = tmp_path / "task.json"
    task.write_text(json.dumps({"wrenches": [[0.0, 0.0, 3.0, 0.0, 0.0, 0.0]]}))
    argv = ["validate", "--task", str(task), "--out", str(tmp_path / "out"), "--json"]
    assert main([*argv, "--known-load-only", "--hover-seconds", "1.0"]) == 0
    record = json.loads(capsys.readouterr().out.strip().splitlines()[-1])
    assert record["hover_max_position_error_m"] <= 0.01
    assert "hover_unknown_load_max_position_error_m" not in record
    assert main([*argv, "--hover-seconds", "0"]) == 2
    assert "--hover-seconds" in capsys.readouterr().err
    assert main([*argv, "--load-ramp-seconds", "-1"]) == 2
    assert "--load-ramp-seconds" in capsys.readouterr().err


def _written(folder: Path) -> set[str]:
    """The files a run left in ``folder`` (the lock and manifest files start with a dot)."""
    return {p.name for p in folder.iterdir() if not p.name.startswith(".")}


def counted_writes(monkeypatch) -> list[Path]:
    """The paths the package writes from now on (its one writer, ``atomic_write``), in order."""
    from modquad_gym.core import atomic_files

    writes: list[Path] = []
    real = atomic_files.atomic_write

    def counted(path, write):
        writes.append(Path(path))
        return real(path, write)

    monkeypatch.setattr(atomic_files, "atomic_write", counted)
    return writes


def _static_task(tmp_path: Path) -> Path:
    task = tmp_path / "task.json"
    task.write_text(json.dumps({"f_max": 1.0, "wrenches": [[0.8, 0.0, 3.0, 0.0, 0.1, 0.0]]}))
    return task


def _dynamic_task(tmp_path: Path) -> Path:
    from modquad_gym import dynamics as dy

    task = tmp_path / "motion.json"
    task.write_text(json.dumps(dy.hover(0.4, rate=20.0).to_dict()))
    return task


@pytest.mark.parametrize(
    "make_task, options",
    [
        (_static_task, ["--infeasible-demo"]),  # both hovers, the demo and the render
        (_dynamic_task, ["--fault", "rotor", "--known-load-only"]),  # the flights' files
    ],
    ids=["static", "dynamic-fault"],
)
def test_every_file_validate_writes_is_refused_without_force(
    tmp_path, capsys, monkeypatch, make_task, options
):
    """Each file one run wrote into --out, found there beforehand, is refused by name (exit 2,
    the user's file untouched, nothing else written) unless --force; the list the command
    checks is the simulation's own, so it cannot leave a file out."""
    from modquad_gym.sim import fault_flight

    monkeypatch.setattr(fault_flight, "FAULT_BEFORE_S", 0.2)
    monkeypatch.setattr(fault_flight, "FAULT_SECONDS", 1.02)
    base = ["validate", "--task", str(make_task(tmp_path)), "--method", "exhaustive", "--n-max",
            "4", "--max-hover-wrenches", "1", "--hover-seconds", "0.2", *options]  # fmt: skip
    assert main([*base, "--out", str(tmp_path / "first")]) == 0
    written = _written(tmp_path / "first")
    assert {"report.md", "validation.json", "structure.png", "hover.png"} <= written
    capsys.readouterr()
    for name in sorted(written):
        out = tmp_path / f"user-{name}"
        out.mkdir()
        (out / name).write_text("USERDATA")
        assert main([*base, "--out", str(out)]) == 2, name
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and name in err and "--force" in err, err
        assert (out / name).read_text() == "USERDATA" and _written(out) == {name}


def test_report_md_is_written_once_with_the_command_that_made_it(tmp_path, capsys, monkeypatch):
    """A static task's ``report.md`` without ``--fault`` is written once, whole: the "Made by"
    line under its title comes with it, not from a second pass that reads and rewrites the file
    (a dynamic task's and ``--fault``'s pages too: test_validate_page.py)."""
    writes = counted_writes(monkeypatch)
    out = tmp_path / "out"
    argv = ["validate", "--task", str(_static_task(tmp_path)), "--method", "exhaustive",
            "--max-hover-wrenches", "1", "--hover-seconds", "0.2", "--out", str(out)]  # fmt: skip
    assert main(argv) == 0
    assert writes.count(out / "report.md") == 1, writes
    assert (out / "report.md").read_text().splitlines()[2] == f"Made by `modquad {' '.join(argv)}`."
