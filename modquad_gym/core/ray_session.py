"""An embedded Ray's session folder, removed when that Ray shuts down.

``ray.init`` keeps its logs, sockets and state in ``<temp>/ray/session_<date>_<pid>`` (``/tmp/ray``
unless ``RAY_TMPDIR`` says otherwise; about 200 KB after one short run) and never removes it, so
every run with ``--workers N`` left one more. :func:`start_local` starts a Ray of this process and
returns that folder (and, when ``ray.init`` is interrupted or fails, removes the folder it made);
:func:`shutdown` stops Ray and removes it, unless a task failed in Ray (a worker that kept dying
past its retries, a task Ray could not run: its logs are kept, and a note says where; a worker
whose task Ray's retry then finished fails nothing, and its logs go with the folder). Ray's
temporary root stays its default (its socket paths must stay short); a cluster the user
connected to keeps its own folders.
"""

from __future__ import annotations

import inspect
import os
import shutil
import sys
import tempfile
from contextlib import suppress
from pathlib import Path
from typing import Any

from modquad_gym.core.notes import note


def start_local(ray: Any, workers: int, options: dict) -> Path | None:
    """A new embedded Ray of ``workers`` CPUs (``address="local"``: even when ``RAY_ADDRESS``
    names a cluster elsewhere), started with ``options``; its session folder (None where Ray
    does not say). A ``ray.init`` that raises or is interrupted (Ctrl-C while Ray starts)
    leaves no folder of this process behind: Ray is shut down and the session folder it made,
    ``session_<date>_<this pid>``, not there before, is removed."""
    root = ray_temp_root()
    before = own_sessions(root)
    try:
        context = ray.init(address="local", num_cpus=workers, **options)
    except BaseException:
        _abandon(ray, own_sessions(root) - before)
        raise
    folder = (getattr(context, "address_info", None) or {}).get("session_dir")
    return Path(folder) if folder else None


def ray_temp_root() -> Path:
    """Where an embedded Ray puts its session folders: ``ray`` in ``RAY_TMPDIR``, else (Linux)
    ``TMPDIR``, else ``/tmp`` (Ray's own rule, ``get_default_ray_temp_dir``)."""
    for name in ("RAY_TMPDIR", "TMPDIR"):
        if os.environ.get(name) and (name == "RAY_TMPDIR" or sys.platform.startswith("linux")):
            return Path(os.environ[name]) / "ray"
    return Path("/tmp/ray") if os.name == "posix" else Path(tempfile.gettempdir()) / "ray"


def own_sessions(root: Path) -> set[Path]:
    """The session folders of this process under ``root`` (Ray names each
    ``session_<date>_<pid of the process that started it>``)."""
    with suppress(OSError):
        return set(root.glob(f"session_*_{os.getpid()}"))
    return set()


def _abandon(ray: Any, new: set[Path]) -> None:
    """After a failed or interrupted ``ray.init``: whatever of Ray started is shut down, and the
    session folders ``new`` (this process's, made by that call) are removed."""
    with suppress(Exception):
        ray.shutdown()
    for folder in new:
        _remove(folder)


def _remove(session: Path) -> None:
    """Remove ``session`` and the ``session_latest`` link beside it when it points there."""
    shutil.rmtree(session, ignore_errors=True)
    latest = session.parent / "session_latest"
    with suppress(OSError):  # none, or another Ray's by now: left alone
        if os.readlink(latest) == str(session):
            latest.unlink()


def shutdown(ray: Any, session: Path | None = None, failed: bool = False) -> None:
    """``ray.shutdown()``; then, for a Ray this process started (``session``: its folder, from
    :func:`start_local`), that folder is removed, and the ``session_latest`` link beside it when
    it points there. Only after a run in which no task failed in Ray (``failed``: a worker died
    past its retries, a task Ray could not run; Ray's message then points to the logs of that
    folder, which stays and a note names),
    only where Ray can wait until its processes have exited (``wait_for_processes``, recent Ray),
    so that none writes there afterwards, and only a folder named ``session_*``; otherwise the
    folder stays, as Ray leaves it."""
    waits = "wait_for_processes" in inspect.signature(ray.shutdown).parameters
    if session is None or failed or not waits or not session.name.startswith("session_"):
        ray.shutdown()
        if session is not None and failed:
            note(f"modquad: note: Ray reported an error; its logs are kept in {session / 'logs'}",
                 __name__)  # fmt: skip
        return
    ray.shutdown(wait_for_processes=True)
    _remove(session)
