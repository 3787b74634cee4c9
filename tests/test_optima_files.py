"""The optima dataset's file (hostile review of `modquad optima`, findings 1-3 and 6-8): one lock
per file whatever path or link names it, records found again from any working folder (and a
task recorded twice refused), one n_max per file, a complete last record kept when its newline
is missing, the Python door's arguments checked before anything is made, and a lock that
cannot be made named for what it is."""

from __future__ import annotations

import errno
import json
import os
import sys
from pathlib import Path

import pytest
from filelock import FileLock
from test_hardening import assert_rejected
from test_optima_inputs import TASK, optima

from modquad_gym.core.distributed import Engine
from modquad_gym.scoring.optima import build_dataset, lock_path, read_dataset
from modquad_gym.tasks import load_task

OTHER = '{"wrenches": [[0, 0, 4, 0, 0.05, 0]]}'


@pytest.fixture
def tasks(tmp_path) -> Path:
    """A folder ``tasks`` with two task files, a.json and b.json."""
    folder = tmp_path / "tasks"
    folder.mkdir()
    (folder / "a.json").write_text(TASK)
    (folder / "b.json").write_text(OTHER)
    return folder


def test_a_link_to_the_dataset_has_its_lock(tmp_path, capsys, tasks):
    """Finding 1: the lock was keyed on the name given, so a second run through a symbolic
    link wrote the same file at once (and --force emptied it under the first run)."""
    out = tmp_path / "o.jsonl"
    assert optima(capsys, out, tasks / "a.json")[0] == 0
    held = out.read_bytes()
    link = tmp_path / "link.jsonl"
    link.symlink_to(out)
    with FileLock(tmp_path / ".o.jsonl.lock", timeout=0):  # another run writes o.jsonl
        for extra in ((), ("--force",)):
            code, _, err = optima(capsys, link, tasks, extra=extra)
            assert_rejected(code, err, "--out", "link.jsonl is being written by another run")
            assert out.read_bytes() == held
    assert not (tmp_path / ".link.jsonl.lock").exists()
    assert lock_path(link) == lock_path(out) == tmp_path / ".o.jsonl.lock"


def test_a_dataset_resumes_from_any_working_folder(tmp_path, capsys, tasks, monkeypatch):
    """Finding 2: a record kept the task path as typed, relative to the folder of its run, so
    a resume from another folder recomputed every task and appended duplicates. Records now
    hold ``path``, the file relative to the dataset's folder."""
    out = tmp_path / "o.jsonl"
    monkeypatch.chdir(tmp_path)
    assert optima(capsys, Path("o.jsonl"), Path("tasks"))[0] == 0
    first = out.read_bytes()
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    monkeypatch.chdir(elsewhere)
    code, printed, _ = optima(capsys, Path("../o.jsonl"), Path("../tasks"))
    assert code == 0 and "0 records written, 2 already there" in printed, printed
    assert out.read_bytes() == first
    records = read_dataset(out)[0]
    assert [(r["task"], r["path"]) for r in records] == [
        ("tasks/a.json", "tasks/a.json"), ("tasks/b.json", "tasks/b.json")]  # fmt: skip

    # another folder's tasks/a.json is another file: its own record, never the first one's
    (elsewhere / "tasks").mkdir()
    (elsewhere / "tasks" / "a.json").write_text(OTHER)
    code, printed, _ = optima(capsys, Path("../o.jsonl"), Path("tasks/a.json"))
    assert code == 0 and "1 records written, 0 already there" in printed, printed
    last = read_dataset(out)[0][-1]
    assert last["task"] == "tasks/a.json" and last["path"] == "elsewhere/tasks/a.json"


def test_a_dataset_of_records_without_path_resumes_from_its_folder(tmp_path, capsys, tasks,
                                                                   monkeypatch):  # fmt: skip
    """Records written before they had ``path`` match by ``task`` resolved in the current
    folder, as before: their run's folder resumes them."""
    monkeypatch.chdir(tmp_path)
    out = tmp_path / "o.jsonl"
    assert optima(capsys, out, Path("tasks"))[0] == 0
    old = [{k: v for k, v in r.items() if k != "path"} for r in read_dataset(out)[0]]
    out.write_text("".join(json.dumps(r) + "\n" for r in old))
    code, printed, _ = optima(capsys, out, Path("tasks"))
    assert code == 0 and "0 records written, 2 already there" in printed, printed
    assert read_dataset(out)[0] == old


def test_a_task_recorded_twice_is_refused_with_both_lines(tmp_path, capsys, tasks):
    """Finding 2: duplicate rows (two runs at once, or a resume from another folder by an
    earlier version) were read as two records of one task. Now refused, naming both lines."""
    out = tmp_path / "o.jsonl"
    assert optima(capsys, out, tasks)[0] == 0
    a, b = out.read_text().splitlines(keepends=True)
    content = a + b + a
    out.write_text(content)
    code, _, err = optima(capsys, out, tasks)
    assert_rejected(code, err, "o.jsonl: line 3 records task", "again (line 1 has it)",
                    "one record per task", "--force")  # fmt: skip
    assert out.read_text() == content
    with pytest.raises(ValueError, match="line 3 records task"):
        read_dataset(out)
    assert optima(capsys, out, tasks, extra=("--force",))[0] == 0
    assert len(read_dataset(out)[0]) == 2


def test_one_dataset_has_one_n_max(tmp_path, capsys, tasks):
    """Finding 3: a run with another --n-max on new tasks appended to the file without a word
    (an ``optimum: null`` of a smaller budget beside the others); the refusal for one task did
    not say whether the wrenches or the n_max differed."""
    out = tmp_path / "o.jsonl"
    assert optima(capsys, out, tasks / "a.json", extra=("--n-max", "4"))[0] == 0
    held = out.read_bytes()
    code, _, err = optima(capsys, out, tasks / "b.json")  # n_max 3
    assert_rejected(code, err, str(out), "n_max 4", "n_max is 3", "one n_max")
    assert out.read_bytes() == held
    code, _, err = optima(capsys, out, tasks / "a.json")
    assert_rejected(code, err, "another n_max (4) than this run's (3)")
    assert "other wrenches" not in err.splitlines()[-1]
    (tasks / "a.json").write_text(OTHER)  # the task file changed since
    code, _, err = optima(capsys, out, tasks / "a.json", extra=("--n-max", "4"))
    assert_rejected(code, err, "with other wrenches (digest")
    assert "another n_max" not in err.splitlines()[-1]
    assert out.read_bytes() == held
    code, printed, _ = optima(capsys, out, tasks / "b.json", extra=("--force",))
    assert code == 0 and "1 records written" in printed
    assert [r["n_max"] for r in read_dataset(out)[0]] == [3]


def test_a_complete_last_record_without_newline_is_kept(tmp_path, capsys, tasks):
    """Finding 6: a last line without a newline was deleted whenever it began as records do,
    even a complete record of a task this run does not recompute."""
    out = tmp_path / "o.jsonl"
    assert optima(capsys, out, tasks)[0] == 0
    whole = out.read_bytes()
    out.write_bytes(whole[:-1])  # an editor stripped the final newline
    assert len(read_dataset(out)[0]) == 2
    code, printed, _ = optima(capsys, out, tasks / "a.json")
    assert code == 0 and "0 records written, 1 already there" in printed, printed
    assert "dropped" not in printed and out.read_bytes() == whole
    out.write_bytes(whole[:-1])  # a resume that appends: the kept record is ended first
    (tasks / "c.json").write_text('{"wrenches": [[0, 0, 5, 0, 0, 0]]}')
    code, printed, _ = optima(capsys, out, tasks)
    assert code == 0 and "1 records written, 2 already there" in printed, printed
    assert out.read_bytes().startswith(whole) and len(read_dataset(out)[0]) == 3


@pytest.mark.parametrize("content", [
    '{"task": "buy milk", "due": "friday"}',  # JSON, complete, not a record
    '{"task": "buy milk"}\n{"task": "call mum"}',
    '{"task": "x", "name": "y"}\n',
])  # fmt: skip
def test_a_file_of_other_lines_is_refused_and_kept(tmp_path, capsys, tasks, content):
    """Finding 6: the user's one-line file beginning as records do was truncated without
    --force. A file whose lines are not records is refused and left as it was."""
    out = tmp_path / "mine.jsonl"
    out.write_text(content)
    code, _, err = optima(capsys, out, tasks)
    assert_rejected(code, err, "mine.jsonl: line 1 is not an optima record", "--force")
    assert out.read_text() == content and not lock_path(out).exists()


BAD_ARGUMENTS = [
    ({"n_max": 0}, "n_max must be >= 1, got 0"),
    ({"n_max": -1}, "n_max must be >= 1, got -1"),
    ({"n_max": 17}, "n_max must be <= 16, got 17"),
    ({"n_max": 2.5}, "n_max must be an integer, got 2.5"),
    ({"n_max": True}, "n_max must be an integer, got True"),
    ({"n_max": "5"}, "n_max must be an integer, got '5'"),
    ({"engine": 2}, "engine must be an Engine"),
    ({"fresh": "yes"}, "fresh must be True or False"),
    ({"progress": 1}, "progress must be True or False"),
    ({"sources": [("t",)]}, "sources: entry 1 must be (task id, task)"),
    ({"sources": [(3, None)]}, "sources: entry 1 must be (task id, task)"),
]


@pytest.mark.parametrize("change, message", BAD_ARGUMENTS)
def test_build_dataset_checks_its_arguments_before_making_anything(tmp_path, tasks, change,
                                                                   message):  # fmt: skip
    """Finding 7: build_dataset(n_max=0) created an empty --out and failed every task on its
    own (returning normally); a ValueError naming the argument now comes first."""
    out = tmp_path / "sub" / "o.jsonl"
    arguments = {"sources": [("a.json", load_task(tasks / "a.json"))], "out": out, "n_max": 3,
                 "engine": Engine(1), "fresh": False, "progress": False, **change}  # fmt: skip
    with pytest.raises(ValueError) as caught:
        build_dataset(**arguments)
    assert str(caught.value).startswith(message), caught.value
    assert not os.path.lexists(out.parent) and not lock_path(out).exists()


def test_a_lock_that_cannot_be_made_says_why(tmp_path, capsys, tasks, monkeypatch):
    """Finding 8: filelock reads a lock file it cannot create in an existing folder (ENOENT, as
    /proc answers) as contention, and the run said "being written by another run"."""
    out = tmp_path / "o.jsonl"
    real_open = os.open

    def refusing_open(path, flags, *args, **kwargs):
        if os.fspath(path).endswith(".o.jsonl.lock"):
            raise OSError(errno.ENOENT, os.strerror(errno.ENOENT), os.fspath(path))
        return real_open(path, flags, *args, **kwargs)

    monkeypatch.setattr(os, "open", refusing_open)
    code, _, err = optima(capsys, out, tasks)
    assert_rejected(code, err, "--out: cannot make the lock file", ".o.jsonl.lock",
                    "No such file or directory")  # fmt: skip
    assert "another run" not in err
    monkeypatch.setattr(os, "open", real_open)
    (tmp_path / ".o.jsonl.lock").mkdir()  # a folder where the lock file goes
    code, _, err = optima(capsys, out, tasks)
    assert_rejected(code, err, "cannot make the lock file", ".o.jsonl.lock", "Is a directory")


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="/proc is Linux's")
def test_an_out_in_proc_is_refused_by_the_folder_check(capsys, tasks):
    """/proc takes no new file, also for root (whom os.access would let in): the folder check
    tries to create one, so the refusal names the folder before any lock or search."""
    code, _, err = optima(capsys, Path("/proc/foo.jsonl"), tasks)
    assert_rejected(code, err, "--out", "folder /proc is not writable")
    assert "another run" not in err
