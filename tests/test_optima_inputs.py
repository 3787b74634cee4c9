"""``modquad optima``'s inputs (review findings 5, 7, 11, 12, 21): a record of the --out dataset is
checked key by key (a wrong type or range, an unknown key: refused with its file and line, never
taken for finished work), dynamic tasks are refused before any work, one task file is recorded
once whatever path names it, and a refused run leaves neither the dataset nor its lock behind.
``read_dataset`` and ``build_dataset`` refuse what the command refuses."""

from __future__ import annotations

import json
import os
from functools import cache
from pathlib import Path

import pytest
from test_hardening import assert_rejected, run_main

from modquad_gym.core.distributed import Engine, Failed
from modquad_gym.scoring.optima import (
    build_dataset,
    check_record,
    lock_path,
    optimum_record,
    read_dataset,
)
from modquad_gym.tasks import TaskRequirement, load_task

TASK = '{"wrenches": [[0, 0, 6, 0.1, 0, 0]]}'


@pytest.fixture
def task(tmp_path) -> Path:
    path = tmp_path / "t.json"
    path.write_text(TASK)
    return path


def optima(capsys, out: Path, *tasks: str | Path, extra=()) -> tuple[int, str, str]:
    argv = ["optima", "--out", str(out), "--n-max", "3", "--quiet", "--workers", "1"]
    for t in tasks:
        argv += ["--task", str(t)]
    return run_main(capsys, *argv, *extra)


@cache
def written(task_id: str) -> str:
    return json.dumps(optimum_record(3, (task_id, TaskRequirement.from_dict(json.loads(TASK)))))


def record(task_id: str = "t.json") -> dict:
    """A record of TASK as the writer writes it (optimum 3, five optimal structures)."""
    return json.loads(written(task_id))


def nothing_made(*paths: Path) -> None:
    for path in paths:
        assert not os.path.lexists(path), path
        assert not os.path.lexists(lock_path(path)), lock_path(path)


def test_the_writers_records_pass_the_check(task):
    for task_id in ("t.json", "suite.json#3"):
        assert check_record(r := record(task_id)) is r and r["count"] == 5
    infeasible = {**record(), "optimum": None, "structures": [], "count": 0, "proof": "bound"}
    assert check_record(infeasible) is infeasible


BAD = [  # (what is changed, the words the refusal names)
    ({"task": ["t.json"]}, ("task must be a string", '["t.json"]')),  # finding 5: a TypeError
    ({"optimum": "lots"}, ("optimum", '"lots"')),  # finding 11
    ({"structures": 5}, ("structures must be a list", "5")),
    ({"extra": 1}, ('"extra": unknown key',)),
    ({"n_max": float("nan")}, ("n_max", "NaN")),
    ({"n_max": 99}, ("n_max", "99")),
    ({"digest": None}, ("digest", "null")),
    ({"digest": "xyz"}, ("digest must be 16 hex digits",)),
    ({"optimum": 4}, ("optimum must be an integer from 1 to 3", "4")),
    ({"optimum": True}, ("optimum", "true")),
    ({"count": 7}, ("count says 7",)),
    ({"seconds": -1}, ("seconds", "-1")),
    ({"evaluated": 1.5}, ("evaluated", "1.5")),
    ({"structures": [[[0, 0], [0, 0], [1, 0]]], "count": 1}, ("structure 1", "distinct")),
    ({"structures": [[[0, 0], [0, 1]]], "count": 1}, ("structure 1", "3 distinct")),
    ({"structures": [[[0, 0], [0, 1], [-1, 0]]], "count": 1}, ("non-negative", "-1")),
    ({"optimum": None}, ("count must be 0 when optimum is null",)),
    ({"proof": 3}, ("proof must be a string",)),
]


@pytest.mark.parametrize("change, words", BAD)
def test_a_record_that_is_not_one_is_refused_with_file_line_and_key(
    tmp_path, capsys, task, change, words
):
    """A garbage record was kept as finished work (or a non-string task crashed with a
    TypeError): now the line is refused, naming the file, the 1-based line and the key; the
    file stays as it was and no lock file is made."""
    out = tmp_path / "o.jsonl"
    content = json.dumps(record("other.json")) + "\n" + json.dumps({**record(), **change}) + "\n"
    out.write_text(content)
    code, _, err = optima(capsys, out, task)
    assert_rejected(code, err, "o.jsonl: line 2 is not an optima record", *words, "--force")
    assert len(err.strip().splitlines()) == 1
    assert out.read_text() == content and not lock_path(out).exists()
    with pytest.raises(ValueError, match="line 2 is not an optima record") as caught:
        read_dataset(out)  # the Python door refuses it the same way
    assert str(caught.value) == err.strip().removeprefix("modquad: error: ")


def test_dynamic_tasks_are_refused_before_any_work(tmp_path, capsys, task):
    """Dynamic tasks failed one by one with an AttributeError naming no task, and the summary
    said '-60 already there': now one line names the file or suite, and nothing is made."""
    motion = tmp_path / "m.json"
    assert run_main(capsys, "task", "motion", "--kind", "hover", "--out", str(motion))[0] == 0
    out = tmp_path / "sub" / "o.jsonl"
    code, printed, err = optima(capsys, out, task, motion)
    assert_rejected(code, err, "optima takes static tasks", f"{motion} is a dynamic task")
    assert len(err.strip().splitlines()) == 1 and "already there" not in printed
    nothing_made(out, out.parent)
    argv = ["optima", "--suite", "dynamic_motions", "--out", str(out), "--workers", "1"]
    code, _, err = run_main(capsys, *argv)
    assert_rejected(code, err, "optima takes static tasks", "dynamic_motions.json", "task 1")
    nothing_made(out, out.parent)
    with pytest.raises(ValueError, match="optima takes static tasks: m is a dynamic task"):
        build_dataset([("t", load_task(task)), ("m", load_task(motion))], out, 3, Engine(1))
    nothing_made(out, out.parent)


def test_one_task_file_is_recorded_once_whatever_path_names_it(tmp_path, capsys, task,
                                                               monkeypatch):  # fmt: skip
    """Resume matched tasks by the path as typed: t.json, then its absolute path, recorded the
    same task twice. Now the resolved path matches (a dataset written with relative paths still
    resumes), and one run naming one file twice is refused."""
    monkeypatch.chdir(tmp_path)
    out = tmp_path / "o.jsonl"
    assert optima(capsys, out, "t.json")[0] == 0
    first = out.read_text()
    (tmp_path / "link.json").symlink_to(task)
    for name in (str(task), "./t.json", "link.json"):
        code, printed, _ = optima(capsys, out, name)
        assert code == 0 and "0 records written, 1 already there" in printed, name
    assert out.read_text() == first and json.loads(first)["task"] == "t.json"
    code, _, err = optima(capsys, out, "t.json", task)
    assert_rejected(code, err, f"task {str(task)!r} is given twice (also as 't.json')")
    assert out.read_text() == first


def test_a_refused_run_leaves_nothing_behind(tmp_path, capsys, task):
    """A missing task file left an empty --out and its lock; a file refused as no dataset got a
    lock beside it. Every input is now read and checked before anything is created."""
    out = tmp_path / "new" / "m.jsonl"
    code, _, err = optima(capsys, out, tmp_path / "nope.json")
    assert_rejected(code, err, "nope.json")
    assert len(err.strip().splitlines()) == 1
    nothing_made(out, out.parent)
    code, _, err = optima(capsys, out, tmp_path / "nope.json", tmp_path / "nope2.json")
    assert code == 2 and "nope.json" in err and "nope2.json" in err and "Traceback" not in err
    nothing_made(out, out.parent)
    with pytest.raises(ValueError, match="given twice"):
        build_dataset([("a", Failed("a", "bad")), ("a", Failed("a", "bad"))], out, 3, Engine(1))
    run = build_dataset([("a", Failed("a", "bad"))], out, 3, Engine(1))
    assert (run.written, run.skipped, len(run.failed)) == (0, 0, 1)
    nothing_made(out, out.parent)

    notes = tmp_path / "notes.txt"
    notes.write_text("my notes\n")
    assert_rejected(*optima(capsys, notes, task)[::2], "notes.txt: line 1", "not JSON")
    other = tmp_path / "other.jsonl"  # the same task with another n_max
    other.write_text(json.dumps({**record(str(task)), "n_max": 4}) + "\n")
    assert_rejected(*optima(capsys, other, task)[::2], "another n_max (4)")
    assert not lock_path(notes).exists() and not lock_path(other).exists()
    assert notes.read_text() == "my notes\n"
