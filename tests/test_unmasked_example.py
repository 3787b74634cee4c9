"""examples/unmasked_sb3.py, which docs/getting-started/agents.md tells users to run: its report
goes through the package's output checks (an existing report is kept unless ``--force``; an
``--out`` it cannot write is refused before any training), its counts are checked, and each
refusal is one error line with exit code 2."""

from __future__ import annotations

import csv
import re
from pathlib import Path

import pytest

from examples import unmasked_sb3 as ex
from modquad_gym.core.interrupts import run_command

ROOT = Path(__file__).resolve().parents[1]
SMALL = ["--algos", "dqn", "--steps", "64", "--tasks", "1"]


def run(capsys, *argv: str):
    """Exit code and captured output of the script run as ``python examples/unmasked_sb3.py``."""
    code = run_command(ex.main, ex.PROG, list(argv))
    return code, capsys.readouterr()


def error_line(said) -> str:
    """The script's one error line (argparse puts its usage above it)."""
    lines = said.err.strip().splitlines()
    errors = [line for line in lines if line.startswith(f"{ex.PROG}: error: ")]
    assert len(errors) == 1 and errors[0] == lines[-1] and "Traceback" not in said.err, said.err
    return errors[0]


@pytest.fixture
def no_training(monkeypatch):
    """Any training fails the test: a refusal must come before it."""

    def refuse(*args, **kwargs):
        raise AssertionError("trained before refusing")

    monkeypatch.setattr(ex, "train", refuse)


def test_an_existing_report_is_kept_unless_force(tmp_path, capsys, no_training):
    (tmp_path / "report.md").write_text("my own notes\n")
    code, said = run(capsys, *SMALL, "--out", str(tmp_path))
    line = error_line(said)
    assert code == 2 and "report.md" in line and "--force" in line
    assert said.err.count("\n") == 1  # not an option: no usage above it
    assert (tmp_path / "report.md").read_text() == "my own notes\n"


def test_an_out_that_cannot_be_a_folder_is_refused_before_training(tmp_path, capsys, no_training):
    afile = tmp_path / "afile"
    afile.write_text("x")
    code, said = run(capsys, *SMALL, "--out", str(afile / "sub"))
    assert code == 2 and str(afile) in error_line(said) and said.err.count("\n") == 1
    assert afile.read_text() == "x"


@pytest.mark.parametrize(
    "option, value",
    [("--tasks", "0"), ("--tasks", "61"), ("--steps", "-5"), ("--steps", "0"), ("--steps", "1.5")],
)
def test_a_count_out_of_range_is_refused(option, value, capsys, no_training):
    code, said = run(capsys, "--algos", "dqn", option, value)
    line = error_line(said)
    assert code == 2 and line.startswith(f"{ex.PROG}: error: argument {option}: ") and value in line


def test_the_default_steps_are_those_of_the_docs_and_the_committed_report():
    docs = (ROOT / "docs" / "getting-started" / "agents.md").read_text()
    documented = int(re.search(r"examples/unmasked_sb3\.py --steps (\d+)", docs).group(1))
    committed = (ROOT / "results" / "unmasked" / "report.md").read_text()
    made = int(re.search(r"\(([\d,]+) training steps each\)", committed).group(1).replace(",", ""))
    assert ex.parse_args([], 60).steps == documented == made


def test_force_replaces_the_report(tmp_path, capsys):
    pytest.importorskip("stable_baselines3")
    (tmp_path / "report.md").write_text("an earlier report\n")
    code, said = run(capsys, *SMALL, "--out", str(tmp_path), "--force")
    assert code == 0, said.err
    text = (tmp_path / "report.md").read_text()
    assert text.startswith(f"Made by `{ex.PROG} --algos dqn --steps 64 --tasks 1 --out ")
    with open(tmp_path / "report.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    assert [row["agent"] for row in rows] == ["random actions + wrapper", "DQN + wrapper"]
