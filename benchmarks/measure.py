"""Time and peak memory of a benchmark run, and runs in fresh processes (so that a run's peak
resident memory is its own, and no cache of an earlier run helps it)."""

from __future__ import annotations

import multiprocessing as mp
import os
import resource
import signal
import sys
import threading
import time
from multiprocessing.connection import wait

from modquad_gym.core.interrupts import deferred_signals


def tree_rss_mb(root: int) -> float:
    """Resident memory of process ``root`` and all its descendants (MB, from /proc)."""
    children: dict[int, list[int]] = {}
    for entry in os.listdir("/proc"):
        if entry.isdigit():
            try:
                with open(f"/proc/{entry}/stat") as fh:
                    ppid = int(fh.read().rsplit(")", 1)[1].split()[1])
            except (OSError, IndexError, ValueError):
                continue
            children.setdefault(ppid, []).append(int(entry))
    total, stack = 0.0, [root]
    while stack:
        pid = stack.pop()
        stack.extend(children.get(pid, []))
        try:
            with open(f"/proc/{pid}/status") as fh:
                for line in fh:
                    if line.startswith("VmRSS:"):
                        total += int(line.split()[1]) / 1024
        except OSError:
            pass
    return total


def own_peak_mb() -> float:
    """This process's own peak resident memory (MB). On Linux ``VmHWM``: ``ru_maxrss`` there keeps
    the size of the process this one was started from (a spawned child of a 2.4 GB parent reads
    2.4 GB), so a small run would report its driver's size. Elsewhere ``ru_maxrss``."""
    try:
        with open("/proc/self/status") as fh:
            return next(int(ln.split()[1]) for ln in fh if ln.startswith("VmHWM:")) / 1024
    except (OSError, StopIteration, ValueError):
        rss = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
        return rss / 2**20 if sys.platform == "darwin" else rss / 1024  # bytes there, KB here


def warm_search(search=None) -> None:
    """Run ``search`` (default :func:`modquad_gym.search.exhaustive_search`) once, untimed, so
    that a timed run that follows pays for neither imports nor loading numba's kernels from
    their disk cache (about 0.4 s): a lone vertical force that needs the lift of one module
    more than the plain-Python levels hold (:data:`~modquad_gym.geometry.polyominoes.PLAIN_UP_TO`),
    so the compiled enumeration and evaluation run. A different task from the timed one: no
    cache of it helps the run."""
    import numpy as np

    import modquad_gym as mq
    from modquad_gym.geometry.polyominoes import PLAIN_UP_TO

    if search is None:
        from modquad_gym.search import exhaustive_search as search
    one_lift = mq.Structure([(0, 0)]).configuration_matrix()[2].clip(min=0).sum()
    search(np.array([[0, 0, (PLAIN_UP_TO + 0.5) * one_lift, 0, 0, 0]]), n_max=PLAIN_UP_TO + 1)


def measured(fn, *args) -> tuple[object, float, float]:
    """(result, seconds, peak MB of this process and its descendants, sampled every 0.2 s;
    at least this process's own peak resident memory so far)."""
    peak = [0.0]
    done = threading.Event()

    def sample() -> None:
        while not done.is_set():
            peak[0] = max(peak[0], tree_rss_mb(os.getpid()))
            done.wait(0.2)

    sampler = threading.Thread(target=sample, daemon=True)
    sampler.start()
    t0 = time.perf_counter()
    try:
        result = fn(*args)
    finally:
        seconds = time.perf_counter() - t0
        done.set()
        sampler.join()
    return result, seconds, max(peak[0], own_peak_mb())


def fresh(fn, *args):
    """``fn(*args)`` in a fresh spawned process (``fn`` must be importable: a module-level
    function)."""
    return fresh_map(fn, [args], 1)[0]


def fresh_map(fn, jobs: list[tuple], workers: int, on_result=None, on_part=None) -> list:
    """``[fn(*job) for job in jobs]``, each job in a fresh spawned process, at most ``workers``
    at a time; ``on_result(i, result)`` is called here as job ``i`` finishes and
    ``on_part(i, value)`` for each :func:`report_part` of it meanwhile (e.g. to write rows as
    they come). An exception in a job is raised here. However this ends (Ctrl-C, SIGTERM, an
    error), no job's process outlives it: the running ones are terminated, and each exits by
    itself if this process is killed (:func:`_child`)."""
    ctx = mp.get_context("spawn")
    pending, running, results = list(enumerate(jobs)), {}, [None] * len(jobs)
    try:
        while pending or running:
            while pending and len(running) < workers:
                i, job = pending.pop(0)
                receive, send = ctx.Pipe(duplex=False)
                proc = ctx.Process(target=_child, args=(send, os.getpid(), fn, job), daemon=True)
                with deferred_signals():  # started whole, and known, before a stop is handled
                    proc.start()
                    running[receive] = (i, proc)
                send.close()
            for conn in wait(list(running)):
                i, proc = running[conn]
                try:
                    kind, value = conn.recv()
                except EOFError:  # the process died without an answer
                    proc.join()
                    kind, value = (
                        "error",
                        RuntimeError(f"a job's process died (exit {proc.exitcode})"),
                    )
                if kind == "part":
                    if on_part is not None:
                        on_part(i, value)
                    continue
                del running[conn]
                proc.join()
                if kind == "error":
                    raise value
                results[i] = value
                if on_result is not None:
                    on_result(i, value)
    finally:
        for _, proc in running.values():
            proc.terminate()
        for _, proc in running.values():
            proc.join()
    return results


_parts = None
"""In a job's process: the connection :func:`report_part` sends on (None elsewhere)."""


def report_part(value) -> None:
    """From a job of :func:`fresh_map`: hand ``value`` (e.g. one task's row) to the parent's
    ``on_part`` now, so it is kept if the job is stopped. Nothing happens outside a job."""
    if _parts is not None:
        _parts.send(("part", value))


def _child(conn, parent: int, fn, args: tuple) -> None:
    """A job's process: Ctrl-C is its parent's to handle (which terminates it), and a watcher
    ends it when the parent is gone (killed, even by SIGKILL), so no orphan keeps computing."""
    global _parts
    signal.signal(signal.SIGINT, signal.SIG_IGN)

    def watch() -> None:
        while os.getppid() == parent:
            time.sleep(0.5)
        os._exit(1)

    threading.Thread(target=watch, daemon=True).start()
    _parts = conn
    try:
        answer = ("done", fn(*args))
    except Exception as exc:  # raised in the parent
        answer = ("error", exc)
    try:
        conn.send(answer)
    except Exception as exc:  # an answer that does not pickle
        conn.send(("error", RuntimeError(f"{fn.__name__}: {type(exc).__name__}: {exc}")))
    conn.close()


if __name__ == "__main__":
    from benchmarks.common import refuse_as_script

    raise SystemExit(refuse_as_script("measure"))
