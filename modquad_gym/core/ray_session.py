"""An embedded Ray's session folder, removed when that Ray shuts down.

``ray.init`` keeps its logs, sockets and state in ``<temp>/ray/session_<date>_<pid>`` (``/tmp/ray``
unless ``RAY_TMPDIR`` says otherwise; about 200 KB after one short run) and never removes it, so
every run with ``--workers N`` left one more. :func:`start_local` starts a Ray of this process and
returns that folder; :func:`shutdown` stops Ray and removes it, unless Ray reported an error (a
worker that died, a failed task: its logs are kept, and a note says where). Ray's temporary root
stays its default (its socket paths must stay short); a cluster the user connected to keeps its
own folders.
"""

from __future__ import annotations

import inspect
import os
import shutil
from contextlib import suppress
from pathlib import Path
from typing import Any

from modquad_gym.core.notes import note


def start_local(ray: Any, workers: int, options: dict) -> Path | None:
    """A new embedded Ray of ``workers`` CPUs (``address="local"``: even when ``RAY_ADDRESS``
    names a cluster elsewhere), started with ``options``; its session folder (None where Ray
    does not say)."""
    context = ray.init(address="local", num_cpus=workers, **options)
    folder = (getattr(context, "address_info", None) or {}).get("session_dir")
    return Path(folder) if folder else None


def shutdown(ray: Any, session: Path | None = None, failed: bool = False) -> None:
    """``ray.shutdown()``; then, for a Ray this process started (``session``: its folder, from
    :func:`start_local`), that folder is removed, and the ``session_latest`` link beside it when
    it points there. Only after a run without errors from Ray (``failed``: a worker died, a task
    failed; Ray's message then points to the logs of that folder, which stays and a note names),
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
    shutil.rmtree(session, ignore_errors=True)
    latest = session.parent / "session_latest"
    with suppress(OSError):  # none, or another Ray's by now: left alone
        if os.readlink(latest) == str(session):
            latest.unlink()
