"""A dataset of certified optima: per task, the minimum module count and every optimal structure.

One JSON object per line (``modquad optima``), appended as each task finishes (completion
order), each line flushed and fsynced before the next, so an interrupted run loses nothing it
had written. Keys of a record:

``task``        where the task came from: its file as given, or ``SUITE#i`` for the i-th task
                of a suite
``path``        for a task file: the file, resolved, relative to the dataset's folder
``name``        the task's name
``digest``      16 hex digits of SHA-256 over f_max and the wrenches (float64): the task's identity
``n_max``       the module budget searched (one for the whole file)
``palette``     with module types (``modquad optima --modules``): their names, one palette for
                the whole file; absent for the T-module alone
``optimum``     the certified minimum module count, or null when no structure of up to n_max works
``structures``  every optimal structure as a list of [x, y] cells (up to translation), in
                canonical order (:mod:`modquad_gym.geometry.polyominoes`); the first
                :data:`MAX_STRUCTURES` when there are more
``modules``     with ``palette``: each listed structure's module type names, in its cells' order
``count``       how many optimal structures there are
``evaluated``, ``oracle_calls``, ``seconds``   the work it took
``proof``       how infeasibility was proven without a search, when it was

Resuming: a rerun into the same file reads the records there and skips the tasks they hold
(:mod:`.optima_file`: a task file is matched by its resolved path, so ``t.json``, ``./t.json``,
its absolute path and a link to it are one task, from any working folder; a record without
``path``, as earlier versions wrote them, by its ``task`` resolved in the current folder). A
last line cut short by an interruption (not JSON) is dropped and recomputed; a complete record
on a last line without a newline is kept. Every line is checked as a record (:func:`check_record`:
each key's type and range, no other key), and a line that is not one, or a second record of one
task, is refused with its file and line. A file holds one n_max: a run with another one is
refused, and so is a record of one of the run's tasks with other wrenches (the file would mix
two datasets). Only static tasks (:class:`TaskRequirement`) have a dataset: a dynamic one is
refused before anything is read or written. The work is spread by
:mod:`modquad_gym.core.distributed`.

One run writes a file at a time: it holds a lock on the hidden file ``.NAME.lock`` beside the
file the path resolves to (:func:`lock_path`, the ``filelock`` package: ``flock`` on POSIX,
``msvcrt`` on Windows), and a second run on the same file, by any path or link, is refused,
``--force`` or not. The lock file stays (deleting it would let a third run lock a new file
while the second still holds the old one); a run refused for its inputs makes neither it nor
the dataset, since every input is checked first.
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
from modquad_gym.core.outputs import check_output_file, named_os_error
from modquad_gym.core.validation import check_flag, check_int
from modquad_gym.scoring.optima_file import (
    dataset_folder,
    lock_path,
    read_dataset,
    record_key,
    stored_path,
    task_key,
    writer_lock,
)
from modquad_gym.scoring.optima_records import KEYS, MAX_STRUCTURES, check_record
from modquad_gym.search import optimal_level
from modquad_gym.search.problem import EXACT_MODULES, check_palette
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


def optimum_record(
    n_max: int, source: tuple[str, TaskRequirement], modules=None, progress: bool = False
) -> dict:
    """The record of one task (the unit of work of a dataset); ``modules``, a palette, makes
    its structures typed (``palette`` and ``modules`` keys); ``progress`` shows the search's
    bar per level on stderr."""
    task_id, task = source
    typed = {} if modules is None else {"modules": list(modules)}
    optima = optimal_level(task, n_max=n_max, max_keys=MAX_STRUCTURES, progress=progress, **typed)
    cells = [[p[0] if typed else p for p in key] for key in optima.keys]
    record = {
        "task": task_id,
        "name": task.name,
        "digest": task_digest(task),
        "n_max": n_max,
        **({"palette": [m.name for m in modules]} if typed else {}),
        "optimum": optima.n_modules,
        "structures": [[list(cell) for cell in key] for key in cells],
        **({"modules": [[m.name for _, m in key] for key in optima.keys]} if typed else {}),
        "count": optima.count,
        "evaluated": optima.evaluated,
        "oracle_calls": optima.oracle_calls,
        "seconds": round(optima.seconds, 6),
    }
    if optima.proof:
        record["proof"] = optima.proof
    return record


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
    modules=None,
) -> DatasetRun:
    """Append the record of every task of ``sources`` ((task id, task or the Failed of its
    loading)) that ``out`` does not hold yet, computing them on ``engine``. ``fresh`` (the
    CLI's ``--force``) empties ``out`` first, once its lock is held: a run that another one is
    writing is refused, never cut short. Everything is checked before anything is created:
    ``n_max`` (1 to EXACT_MODULES), ``engine``, the flags, ``out`` (a file that can be
    written), a dynamic task, a task given twice (also as another path to the same file), an
    ``out`` that is not a dataset, holds another n_max or a task with other wrenches is a
    ValueError; Ray starts (or joins its cluster) when it is needed, and when no task could be
    loaded neither ``out`` nor its lock is made. ``modules`` (a palette, as for the searches)
    types the structures; a file holds one palette (another one is refused as n_max is).
    ``progress`` shows a bar over the tasks on stderr and, for a task searched in this process
    (a serial ``engine``, or a single task), its search's bar per level."""
    n_max = check_int(n_max, "n_max", low=1, high=EXACT_MODULES)
    palette = None if modules is None else check_palette(None, modules)
    if not isinstance(engine, Engine):
        raise ValueError(f"engine must be an Engine (core.distributed), got {engine!r:.60}")
    progress, fresh = check_flag(progress, "progress"), check_flag(fresh, "fresh")
    out = check_output_file(out, force=True, what="out")
    tasks = static_sources(sources)
    run = DatasetRun(failed=[s for _, s in sources if isinstance(s, Failed)])
    if not tasks:
        return run  # nothing to compute: nothing is created
    todo = tasks
    if not fresh and out.exists():  # refused here, before the lock file is made
        todo = _pending(tasks, read_dataset(out)[0], (n_max, palette), out)
    with engine:
        if engine.use_ray and len(todo) > 1:  # a cluster that refuses the join: nothing made
            engine.cluster_cpus()  # (Ray starts, or joins its cluster, for the whole block)
        created = not os.path.lexists(out)
        out.parent.mkdir(parents=True, exist_ok=True)
        with writer_lock(out), open(out, "a+b") as fh:
            try:
                _append_missing(run, tasks, out, fh, (n_max, palette), engine, progress, fresh)
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


def _append_missing(run, tasks, out: Path, fh, budget, engine, progress, fresh) -> None:
    """Under the lock of ``out`` (open as ``fh``): read what it holds and append the records
    of the tasks it lacks (``budget``: n_max and palette), each with its task file's
    ``path``."""
    if fresh:
        fh.truncate(0)
    done, end = read_dataset(out, fh)
    run.dropped_bytes = fh.seek(0, os.SEEK_END) - end
    fh.truncate(end)  # an interrupted last line is recomputed
    if end:
        fh.seek(end - 1)
        if fh.read(1) != b"\n":
            fh.write(b"\n")  # a complete last record without its newline: kept, ended
    todo = _pending(tasks, done, budget, out)
    run.skipped = len(tasks) - len(todo)
    base = dataset_folder(out)
    paths = {task_id: stored_path(task_id, base) for task_id, _ in todo}

    def append(_i: int, record) -> None:
        if isinstance(record, Failed):
            run.failed.append(record)
            return
        if paths.get(record["task"]):
            record = {"task": record["task"], "path": paths[record["task"]], **record}
        try:
            fh.write(json.dumps(record).encode() + b"\n")
            fh.flush()
            os.fsync(fh.fileno())
        except OSError as exc:  # no space left, ...: say which file
            raise named_os_error(exc, out) from exc
        run.written += 1

    here = not engine.use_ray or len(todo) == 1  # as Engine.map runs them: shown from here
    engine.map(
        partial(optimum_record, budget[0], modules=budget[1], progress=progress and here),
        todo,
        labels=[task_id for task_id, _ in todo],
        catch=True,
        progress=progress,
        desc="optima",
        on_result=append,
    )


def static_sources(sources: Sequence[tuple[str, object]]) -> list[tuple[str, TaskRequirement]]:
    """The (task id, task) of ``sources`` that are loaded tasks (a Failed is left out); a
    ValueError for an entry that is not a (task id, task) pair, a dynamic task or anything else
    that is not a :class:`TaskRequirement`, and for a task id given twice, also as another path
    to the same file (:func:`task_key`)."""
    seen: dict[str, str] = {}
    tasks = []
    for i, source in enumerate(sources, 1):
        if not (isinstance(source, (tuple, list)) and len(source) == 2 and source[0]
                and isinstance(source[0], str) and "\0" not in source[0]):  # fmt: skip
            raise ValueError(f"sources: entry {i} must be (task id, task), got {source!r:.60}")
        task_id, task = source
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


def _pending(tasks, records: list[dict], budget: tuple, out: Path) -> list:
    """The (task id, task) of ``tasks`` that ``records`` lack; a ValueError when a record of one
    of them has other wrenches or another n_max or palette (``budget``), or any record another
    n_max or palette."""
    n_max, palette = budget
    names = None if palette is None else [m.name for m in palette]
    base = dataset_folder(out)
    done = {record_key(record, base): record for record in records}  # one each: read_dataset
    todo = []
    for task_id, task in tasks:
        record = done.get(task_key(task_id))
        if record is None:
            todo.append((task_id, task))
            continue
        other = []
        if record["digest"] != (digest := task_digest(task)):
            other.append(f"other wrenches (digest {record['digest']}) than the task's ({digest})")
        if record["n_max"] != n_max:
            other.append(f"another n_max ({record['n_max']}) than this run's ({n_max})")
        if record.get("palette") != names:
            other.append(f"another palette ({record.get('palette')}) than this run's ({names})")
        if other:
            given = f" (given as {task_id!r})" if record["task"] != task_id else ""
            raise ValueError(
                f"--out: {out} holds task {record['task']!r}{given} with {' and '.join(other)}; "
                "write to a new file or give --force to start over"
            )
    for key, value in (("n_max", n_max), ("palette", names)):
        mixed = next((record for record in records if record.get(key) != value), None)
        if mixed is not None:
            raise ValueError(
                f"--out: {out} holds records of {key} {mixed.get(key)} (task {mixed['task']!r}), "
                f"this run's {key} is {value}: a dataset has one {key}; write to a new file or "
                "give --force to start over"
            )
    return todo
