"""Time and peak memory of a benchmark run, and runs in fresh processes (so that a run's peak
resident memory is its own, and no cache of an earlier run helps it)."""

from __future__ import annotations

import multiprocessing as mp
import os
import resource
import threading
import time


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
    own = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    return result, seconds, max(peak[0], own)


def fresh(fn, *args):
    """``fn(*args)`` in a fresh spawned process (``fn`` must be importable: a module-level
    function)."""
    with mp.get_context("spawn").Pool(1) as pool:
        return pool.apply(fn, args)


if __name__ == "__main__":
    from benchmarks.common import refuse_as_script

    raise SystemExit(refuse_as_script("measure"))
