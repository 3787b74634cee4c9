"""The `modquad` command line: JSON round trip, infeasible tasks, bad files, generate, show."""

import argparse
import json
import subprocess
import sys

import numpy as np
import pytest

import modquad_gym as mq
from modquad_gym.cli import main
from modquad_gym.tasks import TaskRequirement


def run_cli(*args):
    return subprocess.run(
        [sys.executable, "-m", "modquad_gym.cli", *args], capture_output=True, text=True
    )


def test_solve_json_round_trip(tmp_path):
    a, b = tmp_path / "a.json", tmp_path / "b.csv"
    task_a = TaskRequirement(np.array([[0, 0, 5.0, 0, 0, 0], [0.5, 0, 4.0, 0, 0, 0.1]]), "a")
    task_a.save(a)
    TaskRequirement(np.array([[0, 0, 100.0, 0, 0, 0]]), "b").save(b)  # infeasible up to 4
    proc = run_cli("solve", "--task", str(a), "--task", str(b), "--n-max", "4", "--json")
    assert proc.returncode == 0, proc.stderr
    lines = [json.loads(line) for line in proc.stdout.splitlines()]
    assert len(lines) == 2
    first, second = lines
    for key in ("cells", "n_modules", "evaluated", "feasible", "seconds"):
        assert key in first and key in second
    assert first["feasible"] and first["n_modules"] == len(first["cells"])
    structure = mq.Structure([tuple(c) for c in first["cells"]])
    assert mq.feasible(structure.configuration_matrix(), task_a.wrenches).all()
    assert first["n_modules"] == mq.exhaustive_search(task_a, n_max=4).n_modules
    assert second == {**second, "cells": None, "n_modules": None, "feasible": False}


@pytest.mark.parametrize("method", ["centrosymmetric", "greedy", "random"])
def test_solve_text_output(method, capsys):
    assert main(["solve", "--task", "examples/screwdriver.json", "--method", method]) == 0
    out = capsys.readouterr().out
    assert "configurations evaluated" in out and "[" in out


@pytest.mark.parametrize(
    "content, suffix, message",
    [
        ("{not json", ".json", "a.json"),
        ('{"wrenches": [[1, 2, 3]]}', ".json", "row 1"),
        ("1,2,3,4,5,7\n1,2,x,4,5,6\n", ".csv", "row 2"),
        ("", ".csv", "a.csv"),
    ],
)
def test_bad_task_file_exits_2(tmp_path, content, suffix, message):
    path = tmp_path / f"a{suffix}"
    path.write_text(content)
    proc = run_cli("solve", "--task", str(path))
    assert proc.returncode == 2
    assert message in proc.stderr and "Traceback" not in proc.stderr


def test_missing_file_exits_2(tmp_path):
    proc = run_cli("solve", "--task", str(tmp_path / "nope.json"))
    assert proc.returncode == 2 and "nope.json" in proc.stderr


def test_generate_and_show(tmp_path):
    out = tmp_path / "t.json"
    assert main(["task", "generate", "--kind", "planted", "--seed", "3", "--out", str(out)]) == 0
    task = TaskRequirement.load(out)
    assert task.n_wrenches >= 1
    png = tmp_path / "s.png"
    assert main(["show", "--cells", "[[0,0],[1,0],[0,1]]", "--out", str(png)]) == 0
    assert png.stat().st_size > 1000


def test_help_explains_every_command():
    proc = run_cli("--help")
    assert proc.returncode == 0
    for command in ("solve", "task", "show", "validate", "score", "bench"):
        assert command in proc.stdout
    proc = run_cli("solve", "--help")
    assert "--method" in proc.stdout and "--json" in proc.stdout


def _parsers(parser, name="modquad"):
    """Every (sub)command parser, with its command line."""
    yield name, parser
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for sub_name, sub in action.choices.items():
                yield from _parsers(sub, f"{name} {sub_name}")


def test_help_explains_every_option():
    from modquad_gym.cli import build_parser

    seen = set()
    for name, parser in _parsers(build_parser()):
        seen.add(name)
        for action in parser._actions:
            if isinstance(action, argparse._SubParsersAction):
                for choice in action._choices_actions:  # one line per sub-command
                    assert choice.help, f"{name} {choice.dest}: no help"
                continue
            label = "/".join(action.option_strings) or action.dest
            assert action.help and action.help.strip(), f"`{name}` {label} has no help text"
    assert {"modquad task generate", "modquad validate", "modquad score", "modquad bench"} <= seen


def test_command_without_action_prints_its_own_help(capsys):
    assert main(["task"]) == 0
    out = capsys.readouterr().out
    assert out.startswith("usage: modquad task") and "generate" in out


def test_validate_help_states_the_hover_time():
    import inspect

    from modquad_gym.sim.validate import validate

    seconds = inspect.signature(validate).parameters["hover_seconds"].default
    proc = run_cli("validate", "--help")
    text = " ".join(proc.stdout.split())
    assert f"simulated seconds per hover segment (default {seconds})" in text
    assert "0.25" not in text


def test_solve_on_an_infeasible_task_exits_2_only_for_the_export_it_cannot_write(tmp_path, capsys):
    """docs/cli.md: ``solve`` exits 0 on an infeasible task and ``--certificate`` writes its
    proof; ``--export`` has no structure to write: it prints the result, writes neither file
    and exits 2, as ``modquad export`` does (``solve --help`` says so)."""
    task = tmp_path / "big.json"
    TaskRequirement(np.array([[0, 0, 30.0, 0, 0, 0]]), "big").save(task)  # none up to 3
    solve = ["solve", "--task", str(task), "--n-max", "3", "--quiet"]
    certificate, export = tmp_path / "proof.json", tmp_path / "x.json"
    assert main([*solve, "--certificate", str(certificate)]) == 0
    assert "infeasible" in capsys.readouterr().out
    assert main(["check", str(certificate)]) == 0
    certificate.unlink()
    assert main([*solve, "--export", str(export)]) == 2
    out, err = capsys.readouterr()
    assert "infeasible" in out
    assert err.strip().splitlines()[-1] == (
        "modquad: error: --export: no structure found for 'big'; nothing written"
    )
    assert main([*solve, "--export", str(export), "--certificate", str(certificate)]) == 2
    assert not export.exists() and not certificate.exists()
    capsys.readouterr()
    assert main(["export", "--task", str(task), "--n-max", "3", "--out", str(export)]) == 2
    assert "nothing to export" in capsys.readouterr().err and not export.exists()
    helps = " ".join(run_cli("solve", "--help").stdout.split())
    assert "it writes nothing, nor the --certificate, and exits 2" in helps
