"""Work that outgrows one process, on Ray: batches of independent items and ordered scans.

This module alone imports Ray (lazily, so ``import modquad_gym`` stays light). An
:class:`Engine` runs a function over items either in this process or as Ray tasks:

* serial: ``workers=1``, a batch of one item, or Ray not installed or failing to import (a
  one-line note on stderr when more workers were asked for, naming the import's failure; an
  explicit cluster address without Ray is an error, ``ray could not be imported: <reason>``
  for a broken install; the import is tried when the engine is made);
* a cluster: ``address=`` (the CLI's ``--ray-address``) or the ``RAY_ADDRESS`` variable; every
  node needs modquad_gym installed, and ``workers`` then caps the tasks in flight (default:
  every CPU of the cluster);
* otherwise an embedded Ray on this machine, ``ray.init(num_cpus=workers)``, shut down when the
  engine closes, its session folder removed unless a task failed in Ray (:mod:`.ray_session`; a
  Ray already running in this process, the user's own ``ray.init``, is used and left running).

Results come back in the order of the items whatever the order of completion, so a batch gives
the same answers for any number of workers. Faults are Ray's business: a task whose worker dies
is resubmitted by Ray (``max_retries``); an exception raised by the function itself is not
retried, and with ``catch=True`` it comes back as a :class:`Failed` record naming the item, so
one malformed task file does not sink a batch. Progress bars follow ``ray.wait``.
"""

from __future__ import annotations

import importlib.util
import os
import re
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass
from itertools import chain, islice
from typing import Any

from modquad_gym.core.bars import progress_bar
from modquad_gym.core.extras import import_optional, missing_extra_message
from modquad_gym.core.interrupts import failure_line, keep_sigterm, one_line
from modquad_gym.core.notes import note
from modquad_gym.core.ray_address import (
    ADDRESS_VARIABLE,
    check_reachable,
    given_address,
    token_hint,
)
from modquad_gym.core.ray_session import shutdown, start_local
from modquad_gym.core.resources import cap_workers, usable_cpus
from modquad_gym.core.validation import check_int

DEFAULT_RETRIES = 3
"""Resubmissions of a task whose worker process died (Ray's ``max_retries``)."""

__all__ = ["ADDRESS_VARIABLE", "DEFAULT_RETRIES", "Engine", "Failed", "first_in_order", "map_tasks",
           "ray_installed"]  # fmt: skip


@dataclass(frozen=True)
class Failed:
    """An item whose function raised (or whose worker kept dying): its label and the error as
    one line."""

    label: str
    error: str

    def __str__(self) -> str:
        return f"{self.label}: {self.error}"


def ray_installed() -> bool:
    return importlib.util.find_spec("ray") is not None


def ray_problem() -> str | None:
    """Why Ray cannot run here, as one line (not installed; installed but its import fails,
    ``ray could not be imported: <reason>``), or None: an engine asking for workers imports it."""
    if not ray_installed():
        return missing_extra_message("ray")
    try:
        import_optional("ray")
    except Exception as exc:  # a broken install (a shared library, a dependency): said as such
        reason = one_line(exc) if isinstance(exc, ImportError) else failure_line(exc)
        return f"ray could not be imported: {reason}"
    return None


def run_item(fn: Callable, item: Any, label: str, catch: bool) -> Any:
    """Run one item (in this process or in a Ray worker): the same code on both paths."""
    if not catch:
        return fn(item)
    try:
        return fn(item)
    except Exception as exc:  # reported per item, the batch goes on
        return Failed(label, failure_line(exc))


class Engine:
    """Where a batch runs: serially here, an embedded Ray, or a Ray cluster (module docstring).

    Args:
        workers: parallel tasks (>= 1); None: ``local_default`` on this machine (every core
            when that is None too), every CPU of the cluster when one is given.
        address: a Ray cluster address (``auto``, ``HOST:PORT``, ``ray://HOST:10001``); None
            reads ``RAY_ADDRESS``.
        local_default: workers when none are given and no cluster is.
        option: how the caller names ``workers`` in its one-line notes (``--workers``).
        check_address: check now that the cluster address answers (False where the work may
            need no Ray, such as one task of a method that runs in one process: an unreachable
            ``RAY_ADDRESS`` then does not block it; the check comes when Ray is first started).

    On this machine the workers are capped to its usable CPUs (a note says so); a cluster
    address must answer before anything starts (one line, at once, when nothing listens).

    Use it as a context manager so Ray, started at the first batch that needs it, serves every
    batch of the block and is shut down at its end; the methods also work outside one (Ray
    started and stopped per call). A serial batch or one of a single item never starts Ray.
    """

    def __init__(
        self,
        workers: int | None = None,
        address: str | None = None,
        *,
        local_default: int | None = None,
        option: str = "workers",
        check_address: bool = True,
    ) -> None:
        self.address = given_address(address) or os.environ.get(ADDRESS_VARIABLE) or None
        if workers is not None:
            workers = check_int(workers, option, low=1)
            if address and workers == 1:  # given here, not by RAY_ADDRESS: it would be ignored
                name = "--ray-address" if option.startswith("--") else "address"
                raise ValueError(
                    f"{name} {address}: not used with {option} 1, which runs everything in this "
                    "process; leave out one of them"
                )
            if not self.address and workers > 1:
                workers = cap_workers(workers, option)
        elif not self.address:
            workers = local_default or usable_cpus()
        self.workers = workers
        why = ray_problem() if workers != 1 else None
        self.use_ray = workers != 1 and why is None
        if why is not None:
            if self.address:
                raise ImportError(f"a Ray cluster was asked for ({self.address}) but {why}")
            if ray_installed():  # installed but broken: the reason, then the same fallback
                note(f"modquad: note: {why}; running serially", __name__)
            else:
                note(
                    "modquad: note: Ray is not installed, running serially "
                    "(pip install 'modquad_gym[distributed]' to use several workers)",
                    __name__,
                )
        self._unchecked = bool(self.use_ray and self.address)
        if self._unchecked and check_address:
            check_reachable(self.address)
            self._unchecked = False
        self._started, self._session = False, None  # _session: the folder of a Ray started here
        self._failed = False  # a task failed in Ray: its session folder (the logs) stays
        self._depth = 0

    def __repr__(self) -> str:
        where = "serial" if not self.use_ray else (self.address or "embedded Ray")
        return f"Engine(workers={self.workers}, {where})"

    # --- Ray's life cycle --------------------------------------------------------------------
    def __enter__(self) -> Engine:
        self._depth += 1
        return self

    def __exit__(self, *exc: object) -> None:
        self._depth -= 1
        if self._depth == 0 and self._started:
            with keep_sigterm():  # ray.shutdown resets SIGTERM to the default: killed silently
                shutdown(import_optional("ray"), self._session, self._failed)  # and its folder
            self._started, self._session, self._failed = False, None, False

    def start(self) -> None:
        """Start (or join) Ray now; nothing when it runs already (idempotent). The batches call
        it at the first one that needs Ray; a caller that must not count Ray's start as its
        own work (the anytime search's clock) calls it first. Ray stays up until the outermost
        ``with`` block ends."""
        ray = import_optional("ray")
        if ray.is_initialized():
            return
        options = {"include_dashboard": False, "log_to_driver": False, "logging_level": "ERROR"}
        with keep_sigterm():  # SIGTERM stays one line, not Ray's native crash dump
            if self.address:
                if self._unchecked:  # not checked up front: before Ray's minute of retries
                    check_reachable(self.address)
                    self._unchecked = False
                try:
                    ray.init(address=self.address, **options)
                except (ConnectionError, RuntimeError, TimeoutError) as exc:
                    raise ConnectionError(
                        f"Ray cluster {self.address}: {failure_line(exc)}{token_hint()}"
                    ) from None
            else:  # a new embedded Ray even when RAY_ADDRESS names a cluster elsewhere
                self._started = True  # an interrupt from here on: the block's end shuts down
                self._session = start_local(ray, self.workers, options)
        self._started = True

    def cluster_cpus(self) -> int:
        """CPUs Ray can use (1 on the serial path)."""
        if not self.use_ray:
            return 1
        with self:
            self.start()
            return int(import_optional("ray").cluster_resources().get("CPU", 1))

    # --- running -----------------------------------------------------------------------------
    def map(
        self,
        fn: Callable[[Any], Any],
        items: Iterable[Any],
        *,
        labels: Sequence[str] | None = None,
        catch: bool = False,
        progress: bool = False,
        desc: str = "tasks",
        on_result: Callable[[int, Any], None] | None = None,
        max_retries: int = DEFAULT_RETRIES,
    ) -> list[Any]:
        """``[fn(item) for item in items]``, in item order, on this engine.

        ``catch``: an exception raised by ``fn`` becomes a :class:`Failed` (labelled by
        ``labels[i]``, default the item's index) instead of stopping the batch. ``on_result(i,
        result)`` is called in this process as each item finishes (in completion order), e.g.
        to append it to a file. ``fn`` must be picklable (a module-level function, or a
        closure, which Ray ships by value).
        """
        items = list(items)
        results: list[Any] = [None] * len(items)
        bar = progress_bar(progress, desc, "task", total=len(items))
        try:
            for i, result in self._run(fn, items, labels, catch, max_retries):
                results[i] = result
                if on_result is not None:
                    on_result(i, result)
                if bar is not None:
                    bar.update(1)
        finally:
            if bar is not None:
                bar.close()
        return results

    def first(
        self,
        fn: Callable[[Any], Any],
        items: Iterable[Any],
        accept: Callable[[Any], bool],
        *,
        on_result: Callable[[int, Any], None] | None = None,
        max_retries: int = DEFAULT_RETRIES,
    ) -> list[Any]:
        """Results of items 0..k, where k is the first item (in item order) whose result is
        accepted, or of every item when none is. Items after k still running are cancelled, so
        the answer is the same for any number of workers and any timing. ``items`` may be a
        lazy iterable: it is read only as far as the tasks in flight need."""
        done: dict[int, Any] = {}
        best = None
        prefix = 0  # items 0..prefix-1 are all done
        runner = self._run(fn, items, None, False, max_retries)
        try:
            for i, result in runner:
                done[i] = result
                if on_result is not None:
                    on_result(i, result)
                if (best is None or i < best) and accept(result):
                    best = i
                while prefix in done:
                    prefix += 1
                if best is not None and prefix > best:
                    break
        finally:
            runner.close()  # cancels what is still in flight
        return [done[i] for i in range(prefix if best is None else best + 1)]

    def _run(self, fn, items, labels, catch, max_retries):
        """(index, result) pairs in completion order."""
        it = iter(items)
        head = list(islice(it, 2))
        items = chain(head, it)
        if not self.use_ray or len(head) <= 1:
            for i, item in enumerate(items):
                yield i, run_item(fn, item, _label(labels, i), catch)
            return
        with self:
            self.start()
            yield from self._run_ray(fn, items, labels, catch, max_retries)

    def _run_ray(self, fn, items, labels, catch, max_retries):
        """Ray tasks over ``items``: at most ``workers`` in flight on a cluster given a number
        of workers, else twice the CPUs Ray has (the queue stays full, and a lazy ``items`` is
        read only that far ahead)."""
        ray = import_optional("ray")
        remote = ray.remote(num_cpus=1, max_retries=max_retries, retry_exceptions=False)(run_item)
        fn_ref = ray.put(fn)
        cpus = max(1, int(ray.cluster_resources().get("CPU", 1)))
        if self.address and self.workers:
            cap = min(self.workers, 2 * cpus)  # never more in flight than the cluster can run
        else:
            cap = 2 * cpus
        source = enumerate(items)
        index: dict[Any, int] = {}
        pending: list[Any] = []
        more = True
        try:
            while more or pending:
                while more and len(pending) < cap:
                    following = next(source, None)
                    if following is None:
                        more = False
                        break
                    i, item = following
                    ref = remote.remote(fn_ref, item, _label(labels, i), catch)
                    index[ref] = i
                    pending.append(ref)
                if not pending:
                    break
                ready, pending = ray.wait(pending, num_returns=1)
                for ref in ready:
                    i = index.pop(ref)
                    try:
                        result = ray.get(ref)
                    except ray.exceptions.RayError as exc:
                        self._failed = True  # a worker died, ...: Ray's message names its logs
                        if not catch:
                            raise
                        result = Failed(_label(labels, i), ray_error_line(exc))
                    yield i, result
        finally:
            # force: Ray's soft cancel of a task that is just finishing aborts this (driver)
            # process (a RAY_CHECK in TaskManager::CompletePendingTask, Ray 2.60)
            for ref in pending:
                ray.cancel(ref, force=True)


def _label(labels: Sequence[str] | None, i: int) -> str:
    return str(i) if labels is None else labels[i]


def ray_error_line(exc: BaseException) -> str:
    """A Ray failure (worker died past its retries, a function Ray could not run, ...) as one
    line: its cause when Ray knows it, else its first line without terminal colours."""
    cause = getattr(exc, "cause", None)
    if isinstance(cause, BaseException):
        return failure_line(cause)
    first = re.sub(r"\x1b\[[0-9;]*m", "", str(exc)).strip().splitlines()
    return f"{type(exc).__name__}: {first[0] if first else ''}".strip()


def map_tasks(
    fn: Callable[[Any], Any],
    items: Iterable[Any],
    *,
    workers: int | None = 1,
    address: str | None = None,
    **options: Any,
) -> list[Any]:
    """``Engine(workers, address).map(fn, items, **options)``: one batch, Ray started and shut
    down around it when needed (an already running Ray is reused)."""
    with Engine(workers, address) as engine:
        return engine.map(fn, items, **options)


def first_in_order(
    fn: Callable[[Any], Any],
    items: Iterable[Any],
    accept: Callable[[Any], bool],
    *,
    workers: int | None = 1,
    address: str | None = None,
    **options: Any,
) -> list[Any]:
    """``Engine(workers, address).first(fn, items, accept, **options)``."""
    with Engine(workers, address) as engine:
        return engine.first(fn, items, accept, **options)
