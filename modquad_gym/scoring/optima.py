"""A dataset of certified optima: per task, the minimum module count and every optimal structure.

One JSON object per line (``modquad optima``), appended as each task finishes (completion
order), each line flushed and fsynced before the next, so an interrupted run loses nothing it
had written. Keys of a record:

``task``        where the task came from: its file, or ``SUITE#i`` for the i-th task of a suite
``name``        the task's name
``digest``      16 hex digits of SHA-256 over f_max and the wrenches (float64): the task's identity
``n_max``       the module budget searched
``optimum``     the certified minimum module count, or null when no structure of up to n_max works
``structures``  every optimal structure as a list of [x, y] cells (up to translation), in
                canonical order (:mod:`modquad_gym.geometry.polyominoes`); the first
                :data:`MAX_STRUCTURES` when there are more
``count``       how many optimal structures there are
``evaluated``, ``oracle_calls``, ``seconds``   the work it took
``proof``       how infeasibility was proven without a search, when it was

Resuming: a rerun into the same file reads the records there and skips the tasks they hold (same
``task``, ``digest`` and ``n_max``); a last line cut short by an interruption is dropped and
recomputed. A record for the same task with other wrenches or another n_max is refused (the file
would mix two datasets). The work is spread by :mod:`modquad_gym.core.distributed`.

One run writes a file at a time: it holds a lock on the hidden file ``.NAME.lock`` beside it
(:func:`lock_path`, the ``filelock`` package: ``flock`` on POSIX, ``msvcrt`` on Windows), and a
second run on the same file is refused, ``--force`` or not. The lock file stays (deleting it
would let a third run lock a new file while the second still holds the old one).
"""

from __future__ import annotations

import contextlib
import hashlib
import json
import os
from collections.abc import Sequence
from dataclasses import dataclass, field
from functools import partial
from pathlib import Path

import numpy as np

from modquad_gym.core.distributed import Engine, Failed
from modquad_gym.core.outputs import named_os_error
from modquad_gym.search import optimal_level
from modquad_gym.tasks import TaskRequirement

KEYS = ("task", "name", "digest", "n_max", "optimum", "structures", "count", "evaluated",
        "oracle_calls", "seconds")  # fmt: skip
"""Keys every record has (``proof`` too when it applies)."""


MAX_STRUCTURES = 10_000
"""Most structures a record lists (in canonical order); ``count`` counts them all. A level
where every structure is optimal (level 12 holds 505,861) would otherwise be a line of tens of
megabytes and a gigabyte of memory."""


def task_digest(task: TaskRequirement) -> str:
    """The task's identity in a dataset: SHA-256 of f_max and the wrenches, 16 hex digits."""
    h = hashlib.sha256(np.float64(task.f_max).tobytes())
    h.update(np.ascontiguousarray(task.wrenches, dtype="<f8").tobytes())
    return h.hexdigest()[:16]


def optimum_record(n_max: int, source: tuple[str, TaskRequirement]) -> dict:
    """The record of one task (the unit of work of a dataset)."""
    task_id, task = source
    optima = optimal_level(task, n_max=n_max, max_keys=MAX_STRUCTURES)
    record = {
        "task": task_id,
        "name": task.name,
        "digest": task_digest(task),
        "n_max": n_max,
        "optimum": optima.n_modules,
        "structures": [[list(cell) for cell in key] for key in optima.keys],
        "count": optima.count,
        "evaluated": optima.evaluated,
        "oracle_calls": optima.oracle_calls,
        "seconds": round(optima.seconds, 6),
    }
    if optima.proof:
        record["proof"] = optima.proof
    return record


RECORD_START = b'{"task": '
"""How every record line begins (``task`` is the first key): an unfinished last line that does not
is not an interrupted record, and the file is not a dataset."""


def read_dataset(path: str | os.PathLike, fh=None) -> tuple[list[dict], int]:
    """(records, bytes of complete lines) of a dataset file (or of the open binary file ``fh``);
    a last line with no newline (an interrupted write) is not counted. A file that is not a
    dataset (a complete line that is not a record, a line longer than
    :data:`MAX_RECORD_BYTES`, an unfinished last line that does not begin as records do) is a
    ValueError naming the file and line: nothing the user saved is taken for a dataset. Read
    line by line, so memory stays at one line."""
    with contextlib.ExitStack() as stack:
        if fh is None:
            fh = stack.enter_context(open(path, "rb"))
        fh.seek(0)
        records: list[dict] = []
        end = 0
        for number, line in enumerate(iter(lambda: fh.readline(MAX_RECORD_BYTES + 1), b""), 1):
            if not line.endswith(b"\n"):
                if len(line) <= MAX_RECORD_BYTES and RECORD_START.startswith(
                    line[: len(RECORD_START)]
                ):
                    break  # an interrupted last record
                raise ValueError(f"{path}: line {number} is not an optima record{NOT_A_DATASET}")
            try:
                record = json.loads(line)
            except (json.JSONDecodeError, UnicodeDecodeError, RecursionError):
                record = None
            if not isinstance(record, dict) or not set(KEYS) <= set(record):
                raise ValueError(f"{path}: line {number} is not an optima record{NOT_A_DATASET}")
            records.append(record)
            end += len(line)
    return records, end


MAX_RECORD_BYTES = 256 * 2**20
"""Longest record line read back (a record lists at most ``MAX_STRUCTURES`` structures)."""
NOT_A_DATASET = " (not an optima dataset: give a new --out, or --force to replace the file)"


@dataclass
class DatasetRun:
    """What :func:`build_dataset` did: records written now, tasks found already done, tasks
    that failed (not written, so a rerun tries them again)."""

    written: int = 0
    skipped: int = 0
    failed: list[Failed] = field(default_factory=list)
    dropped_bytes: int = 0


def build_dataset(
    sources: Sequence[tuple[str, TaskRequirement | Failed]],
    out: str | os.PathLike,
    n_max: int,
    engine: Engine,
    *,
    progress: bool = False,
    fresh: bool = False,
) -> DatasetRun:
    """Append the record of every task of ``sources`` ((task id, task or the Failed of its
    loading)) that ``out`` does not hold yet, computing them on ``engine``. ``fresh`` (the
    CLI's ``--force``) empties ``out`` first, once its lock is held: a run that another one is
    writing is refused, never cut short."""
    out = Path(out)
    ids = [task_id for task_id, _ in sources]
    if len(set(ids)) != len(ids):
        twice = next(i for i in ids if ids.count(i) > 1)
        raise ValueError(f"task {twice!r} is given twice")
    run = DatasetRun(failed=[s for _, s in sources if isinstance(s, Failed)])
    out.parent.mkdir(parents=True, exist_ok=True)
    with _writer_lock(out), open(out, "a+b") as fh:
        if fresh:
            fh.truncate(0)
        done, end = read_dataset(out, fh)
        run.dropped_bytes = fh.seek(0, os.SEEK_END) - end
        fh.truncate(end)  # an interrupted last line is recomputed
        todo = _pending(sources, {r["task"]: r for r in done}, n_max, out)
        run.skipped = sum(isinstance(t, TaskRequirement) for _, t in sources) - len(todo)

        def append(_i: int, record) -> None:
            if isinstance(record, Failed):
                run.failed.append(record)
                return
            try:
                fh.write(json.dumps(record).encode() + b"\n")
                fh.flush()
                os.fsync(fh.fileno())
            except OSError as exc:  # no space left, ...: say which file
                raise named_os_error(exc, out) from exc
            run.written += 1

        engine.map(
            partial(optimum_record, n_max),
            todo,
            labels=[task_id for task_id, _ in todo],
            catch=True,
            progress=progress,
            desc="optima",
            on_result=append,
        )
    with contextlib.suppress(OSError):  # make the file's entry durable too
        fd = os.open(out.parent, os.O_RDONLY)
        try:
            os.fsync(fd)
        finally:
            os.close(fd)
    return run


def lock_path(out: str | os.PathLike) -> Path:
    """The lock file of the dataset ``out``: ``.NAME.lock`` in its folder."""
    out = Path(out)
    return out.with_name(f".{out.name}.lock")


@contextlib.contextmanager
def _writer_lock(out: Path):
    """Hold the lock of ``out`` for the block; a ValueError when another run holds it."""
    from filelock import FileLock, Timeout

    try:
        with FileLock(lock_path(out), timeout=0):
            yield
    except Timeout:
        raise ValueError(f"--out: {out} is being written by another run") from None


def _pending(sources, done: dict[str, dict], n_max: int, out: Path) -> list:
    todo = []
    for task_id, task in sources:
        if isinstance(task, Failed):
            continue
        record = done.get(task_id)
        if record is None:
            todo.append((task_id, task))
        elif record["digest"] != task_digest(task) or record["n_max"] != n_max:
            raise ValueError(
                f"--out: {out} holds task {task_id!r} with other wrenches or another n_max "
                f"({record['n_max']}); write to a new file or give --force to start over"
            )
    return todo
