"""What this machine can give a run: usable CPUs and available memory, checked before long work.

Every check raises :class:`ResourceError` (a ValueError, so the command line prints it as one
line, exit code 2) naming what asked and how much, before anything is allocated or started:
a search estimates its memory from its sizes (:func:`check_memory`), and worker counts are
capped to the cores this process may use (:func:`cap_workers`).
"""

from __future__ import annotations

import os
from pathlib import Path

from modquad_gym.core.notes import note

MEMORY_FRACTION = 0.8
"""Share of the available memory one estimate may take."""

GIB = 2**30


class ResourceError(ValueError):
    """A run that would not fit this machine (memory, processes); the message says how much."""


def usable_cpus() -> int:
    """CPUs this process may run on (its affinity mask, e.g. under taskset or a container)."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except (AttributeError, OSError):
        return max(1, os.cpu_count() or 1)


def _cgroup_room() -> int | None:
    """Bytes left under this process's cgroup v2 memory limit, or None without one."""
    try:
        limit = Path("/sys/fs/cgroup/memory.max").read_text().strip()
        if limit == "max":
            return None
        used = int(Path("/sys/fs/cgroup/memory.current").read_text())
        return max(0, int(limit) - used)
    except (OSError, ValueError):
        return None


def available_memory() -> int | None:
    """Bytes of memory available to a new allocation (``MemAvailable``, within the cgroup's
    limit), or None where the system does not say."""
    room = None
    try:
        for line in Path("/proc/meminfo").read_text().splitlines():
            if line.startswith("MemAvailable:"):
                room = int(line.split()[1]) * 1024
                break
    except (OSError, ValueError, IndexError):
        room = None
    cgroup = _cgroup_room()
    if cgroup is not None:
        room = cgroup if room is None else min(room, cgroup)
    return room


def check_memory(needed: int | float, what: str) -> None:
    """Refuse ``what`` when its estimated ``needed`` bytes exceed :data:`MEMORY_FRACTION` of the
    available memory (or are beyond any machine, 2**60 bytes, where the system does not say)."""
    room = available_memory()
    limit = 2**60 if room is None else MEMORY_FRACTION * room
    if needed > limit:
        have = "" if room is None else f", and {room / GIB:,.1f} GiB are available"
        try:
            size = f"about {needed / GIB:,.3g} GiB"
        except OverflowError:  # an int beyond any float: far beyond any machine
            size = "more than 1e300 GiB"
        raise ResourceError(f"{what} needs {size} of memory{have}")


def cap_workers(workers: int, what: str = "--workers") -> int:
    """``workers`` for processes on this machine, capped to its usable CPUs with a one-line
    note on stderr (more processes than cores only add memory and switching)."""
    cpus = usable_cpus()
    if workers <= cpus:
        return workers
    note(
        f"modquad: note: {what} {workers}: this machine has {cpus} usable CPU(s); "
        f"running {cpus} at a time",
        __name__,
    )
    return cpus
