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
``task``, ``digest`` and ``n_max``; a task file is matched by its resolved path, so ``t.json``,
``./t.json`` and its absolute path are one task); a last line cut short by an interruption is
dropped and recomputed. Every complete line is checked as a record (:func:`check_record`: each
key's type and range, no other key); a line that is not one is refused with its file and line.
A record for the same task with other wrenches or another n_max is refused (the file would mix
two datasets). Only static tasks (:class:`TaskRequirement`) have a dataset: a dynamic one is
refused before anything is read or written. The work is spread by
:mod:`modquad_gym.core.distributed`.

One run writes a file at a time: it holds a lock on the hidden file ``.NAME.lock`` beside it
(:func:`lock_path`, the ``filelock`` package: ``flock`` on POSIX, ``msvcrt`` on Windows), and a
second run on the same file is refused, ``--force`` or not. The lock file stays (deleting it
would let a third run lock a new file while the second still holds the old one); a run refused
for its inputs makes neither it nor the dataset, since every input is checked first.
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
from modquad_gym.scoring.optima_records import KEYS, MAX_STRUCTURES, check_record
from modquad_gym.search import optimal_level
from modquad_gym.tasks import TaskRequirement

__all__ = [
    "KEYS", "MAX_STRUCTURES", "DatasetRun", "build_dataset", "check_record", "lock_path",
    "optimum_record", "read_dataset", "static_sources", "task_digest", "task_key",
]  # fmt: skip


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
    dataset (a complete line that is not a record as
    :func:`~modquad_gym.scoring.optima_records.check_record` checks it, a line
    longer than :data:`MAX_RECORD_BYTES`, an unfinished last line that does not begin as records
    do) is a ValueError naming the file, the 1-based line and what is wrong: nothing the user
    saved is taken for a dataset. Read line by line, so memory stays at one line."""
    with contextlib.ExitStack() as stack:
        if fh is None:
            fh = stack.enter_context(open(path, "rb"))
        fh.seek(0)
        records: list[dict] = []
        end = 0
        for number, line in enumerate(iter(lambda: fh.readline(MAX_RECORD_BYTES + 1), b""), 1):
            if not line.endswith(b"\n"):
                if len(line) > MAX_RECORD_BYTES:
                    why = f"longer than {MAX_RECORD_BYTES} bytes"
                elif RECORD_START.startswith(line[: len(RECORD_START)]):
                    break  # an interrupted last record
                else:
                    why = "an unfinished last line that does not begin as records do"
                raise ValueError(f"{path}: line {number} is not an optima record: {why}"
                                 f"{NOT_A_DATASET}")  # fmt: skip
            try:
                record = json.loads(line)
            except (json.JSONDecodeError, UnicodeDecodeError, RecursionError):
                raise ValueError(f"{path}: line {number} is not an optima record: not JSON"
                                 f"{NOT_A_DATASET}") from None  # fmt: skip
            try:
                check_record(record)
            except ValueError as exc:
                raise ValueError(f"{path}: line {number} is not an optima record: {exc}"
                                 f"{NOT_A_DATASET}") from None  # fmt: skip
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
    writing is refused, never cut short. Everything is checked before anything is created: a
    dynamic task, a task given twice (also as another path to the same file), an ``out`` that
    is not a dataset or holds a task with other wrenches is a ValueError, Ray starts (or joins
    its cluster) when it is needed, and when no task could be loaded neither ``out`` nor its
    lock is made."""
    out = Path(out)
    tasks = static_sources(sources)
    run = DatasetRun(failed=[s for _, s in sources if isinstance(s, Failed)])
    if not tasks:
        return run  # nothing to compute: nothing is created
    todo = tasks
    if not fresh and out.exists():  # refused here, before the lock file is made
        todo = _pending(tasks, read_dataset(out)[0], n_max, out)
    with engine:
        if engine.use_ray and len(todo) > 1:  # a cluster that refuses the join: nothing made
            engine.cluster_cpus()  # (Ray starts, or joins its cluster, for the whole block)
        created = not os.path.lexists(out)
        out.parent.mkdir(parents=True, exist_ok=True)
        with _writer_lock(out), open(out, "a+b") as fh:
            try:
                _append_missing(run, tasks, out, fh, n_max, engine, progress, fresh)
            except BaseException:
                if created and os.fstat(fh.fileno()).st_size == 0:  # nothing written: none left
                    with contextlib.suppress(OSError):
                        out.unlink()
                raise
    with contextlib.suppress(OSError):  # make the file's entry durable too
        fd = os.open(out.parent, os.O_RDONLY)
        try:
            os.fsync(fd)
        finally:
            os.close(fd)
    return run


def _append_missing(run, tasks, out: Path, fh, n_max, engine, progress, fresh) -> None:
    """Under the lock of ``out`` (open as ``fh``): read what it holds and append the records
    of the tasks it lacks."""
    if fresh:
        fh.truncate(0)
    done, end = read_dataset(out, fh)
    run.dropped_bytes = fh.seek(0, os.SEEK_END) - end
    fh.truncate(end)  # an interrupted last line is recomputed
    todo = _pending(tasks, done, n_max, out)
    run.skipped = len(tasks) - len(todo)

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


def static_sources(sources: Sequence[tuple[str, object]]) -> list[tuple[str, TaskRequirement]]:
    """The (task id, task) of ``sources`` that are loaded tasks (a Failed is left out); a
    ValueError for a dynamic task or anything else that is not a :class:`TaskRequirement`, and
    for a task id given twice, also as another path to the same file (:func:`task_key`)."""
    seen: dict[str, str] = {}
    tasks = []
    for task_id, task in sources:
        key = task_key(task_id)
        if key in seen:
            also = f" (also as {seen[key]!r})" if seen[key] != task_id else ""
            raise ValueError(f"task {task_id!r} is given twice{also}")
        seen[key] = task_id
        if isinstance(task, Failed):
            continue
        if not isinstance(task, TaskRequirement):
            kind = getattr(task, "kind", None)
            what = "a dynamic task" if kind == "dynamic" else f"a {type(task).__name__}"
            raise ValueError(f"optima takes static tasks: {task_id} is {what}")
        tasks.append((task_id, task))
    return tasks


def task_key(task_id: str) -> str:
    """What matches a task id with a record's ``task``: its resolved path (``t.json``,
    ``./t.json``, its absolute path or a link to it are one task file). A suite's ``NAME#i``
    resolves in the current folder on both sides, so equal ids still match."""
    try:
        return os.path.realpath(task_id)
    except (OSError, ValueError):
        return task_id


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


def _pending(tasks, records: list[dict], n_max: int, out: Path) -> list:
    """The (task id, task) of ``tasks`` that ``records`` lack; a ValueError when a record of one
    of them has other wrenches or another n_max."""
    done: dict[str, list[dict]] = {}
    for record in records:
        done.setdefault(task_key(record["task"]), []).append(record)
    todo = []
    for task_id, task in tasks:
        held = done.get(task_key(task_id), [])
        if not held:
            todo.append((task_id, task))
        digest = task_digest(task) if held else None
        for record in held:
            if record["digest"] != digest or record["n_max"] != n_max:
                given = f" (given as {task_id!r})" if record["task"] != task_id else ""
                raise ValueError(
                    f"--out: {out} holds task {record['task']!r}{given} with other wrenches or "
                    f"another n_max ({record['n_max']}); write to a new file or give --force to "
                    "start over"
                )
    return todo
