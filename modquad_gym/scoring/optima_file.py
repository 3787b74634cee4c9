"""The file of an optima dataset (:mod:`modquad_gym.scoring.optima`): reading it back line by
line, matching its records with the tasks of a run, and the lock one writer holds on it.

A record names its task twice: ``task`` as the user gave it (a label) and, for a task file,
``path``: the file resolved and written relative to the dataset's own (resolved) folder. So
resuming from another working folder, or after moving the dataset's folder together with its
task files, still finds the records; a record without ``path`` (written before records had
one, or a suite's ``NAME#i``) is matched by its ``task`` resolved in the current folder.
"""

from __future__ import annotations

import contextlib
import json
import os
from pathlib import Path

from modquad_gym.scoring.optima_records import check_record

__all__ = [
    "MAX_RECORD_BYTES", "RECORD_START", "dataset_folder", "lock_path", "read_dataset",
    "record_key", "stored_path", "task_key", "writer_lock",
]  # fmt: skip

RECORD_START = b'{"task": '
"""How every record line begins (``task`` is the first key): an unfinished last line that is
not JSON and does not begin so is not an interrupted record, and the file is not a dataset."""
MAX_RECORD_BYTES = 256 * 2**20
"""Longest record line read back (a record lists at most ``MAX_STRUCTURES`` structures)."""
NOT_A_DATASET = " (not an optima dataset: give a new --out, or --force to replace the file)"


def read_dataset(path: str | os.PathLike, fh=None) -> tuple[list[dict], int]:
    """(records, bytes of the records' lines) of a dataset file (or of the open binary file
    ``fh``). A last line with no newline is an interrupted write when it is not JSON and
    begins as records do: it is not counted (the writer drops it); a complete record there
    is kept. A file that is not a dataset (a line that is not a record as
    :func:`~modquad_gym.scoring.optima_records.check_record` checks it, a line longer than
    :data:`MAX_RECORD_BYTES`, an unfinished last line that is neither) or that records one task
    twice (:func:`record_key`) is a ValueError naming the file, the
    1-based line and what is wrong: nothing the user saved is taken for a dataset, nor any
    task counted twice. Read line by line, so memory stays at one line."""
    with contextlib.ExitStack() as stack:
        if fh is None:
            fh = stack.enter_context(open(path, "rb"))
        fh.seek(0)
        base = dataset_folder(path)
        records: list[dict] = []
        lines: dict[str, int] = {}
        end = 0
        for number, line in enumerate(iter(lambda: fh.readline(MAX_RECORD_BYTES + 1), b""), 1):
            record = _record(path, number, line)
            if record is None:
                break  # an interrupted last record
            key = record_key(record, base)
            if key in lines:
                raise ValueError(
                    f"{path}: line {number} records task {record['task']!r} again (line "
                    f"{lines[key]} has it): a dataset holds one record per task (two runs wrote "
                    "it at once, or an earlier version resumed it from another folder); keep one "
                    "of the two lines, or give --force to start over"
                )
            lines[key] = number
            records.append(record)
            end += len(line)
    return records, end


def _record(path, number: int, line: bytes) -> dict | None:
    """The record of one line; None for an interrupted last line; else a ValueError."""
    last = not line.endswith(b"\n")
    if last and len(line) > MAX_RECORD_BYTES:
        raise _not_a_record(path, number, f"longer than {MAX_RECORD_BYTES} bytes")
    try:
        record = json.loads(line)
    except (json.JSONDecodeError, UnicodeDecodeError, RecursionError):
        if last and RECORD_START.startswith(line[: len(RECORD_START)]):
            return None
        why = "an unfinished last line that does not begin as records do" if last else "not JSON"
        raise _not_a_record(path, number, why) from None
    try:
        return check_record(record)
    except ValueError as exc:
        raise _not_a_record(path, number, str(exc)) from None


def _not_a_record(path, number: int, why: str) -> ValueError:
    return ValueError(f"{path}: line {number} is not an optima record: {why}{NOT_A_DATASET}")


def dataset_folder(out: str | os.PathLike) -> str:
    """The resolved folder of the dataset ``out``: what a record's ``path`` is relative to."""
    return os.path.dirname(os.path.realpath(out))


def task_key(task_id: str) -> str:
    """What matches a task id with a record: its resolved path (``t.json``, ``./t.json``, its
    absolute path or a link to it are one task file). A suite's ``NAME#i`` resolves in the
    current folder on both sides, so equal ids still match."""
    try:
        return os.path.realpath(task_id)
    except (OSError, ValueError):
        return task_id


def record_key(record: dict, base: str) -> str:
    """What matches ``record`` (of the dataset whose folder is ``base``) with a task id's
    :func:`task_key`: the file its ``path`` names, else its ``task`` resolved here."""
    if "path" in record:
        return task_key(os.path.join(base, record["path"]))
    return task_key(record["task"])


def stored_path(task_id: str, base: str) -> str | None:
    """A record's ``path`` for the task id ``task_id`` in the dataset whose folder is ``base``:
    the file resolved, relative to ``base`` (absolute on another drive); None when ``task_id``
    names no file (a suite's ``NAME#i``)."""
    if not os.path.isfile(task_id):
        return None
    real = os.path.realpath(task_id)
    try:
        return os.path.relpath(real, base)
    except ValueError:
        return real


def lock_path(out: str | os.PathLike) -> Path:
    """The lock file of the dataset ``out``: ``.NAME.lock`` beside the file ``out`` resolves
    to, so a symbolic link to a dataset (or another spelling of its path) has the same lock."""
    real = Path(os.path.realpath(out))
    return real.with_name(f".{real.name}.lock")


@contextlib.contextmanager
def writer_lock(out: Path):
    """Hold the lock of ``out`` for the block: a ValueError when another run holds it, and one
    naming the lock file and the reason when it cannot be made (a folder that is not writable,
    a lock path that is a folder or a link), which filelock reports as contention."""
    from filelock import FileLock, Timeout

    lock = lock_path(out)
    flags = os.O_RDWR | os.O_CREAT | getattr(os, "O_NOFOLLOW", 0) | getattr(os, "O_NONBLOCK", 0)
    try:
        os.close(os.open(lock, flags, 0o644))
    except OSError as exc:
        reason = exc.strerror or type(exc).__name__
        raise ValueError(f"--out: cannot make the lock file {lock} of {out}: {reason}") from None
    try:
        with FileLock(lock, timeout=0):
            yield
    except Timeout:
        raise ValueError(f"--out: {out} is being written by another run") from None
