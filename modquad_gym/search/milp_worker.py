"""HiGHS in a worker process that is killed at the deadline: the ``milp`` search's hard time limit.

HiGHS does not check its ``time_limit`` inside every presolve rule. On the 1 M-nonzero program of
level 52 of ``planted-16-64`` it spent 22 s of a 0.87 s limit in ``HPresolve::dominatedColumns``
(scipy 1.17's HiGHS 1.12; highspy's 1.16: 8.5 s). No option helps (``presolve_rule_off`` with
every bit set still ran 15 s) and no callback is called there; only presolve off kept the limit,
which changes every solve. So :class:`~.milp_program.LevelProgram` solves a large program here:
:func:`solve` sends it to a long-lived worker (a plain ``python`` running this file, started on
first use, so a user's script without a ``__main__`` guard is never re-imported) and waits for
the answer until HiGHS's own limit plus :data:`GRACE`; past that it kills the worker (the next
solve starts a new one) and the caller treats the level as undecided.

It also keeps a Ctrl-C or SIGTERM prompt: Python runs signal handlers in the main thread between
bytecodes, so a signal that lands while HiGHS runs in that thread waits until HiGHS returns (one
call on the ``mixed`` tier ran 52 s of its 60 s limit). Waiting on the worker, the handler runs at
once and the worker is killed. So in the main thread every program is solved here once the
worker has booted (:func:`in_main_thread`, :func:`booted`; :func:`start` boots it early, beside
the caller's own work); while it boots (about 0.5 s) the caller tries a small program in its
own process for at most :data:`BOOT_TRY` seconds, a bound on the wait for a signal there, and
while another thread holds it (:func:`busy`) solves a small one in its own process.
"""

from __future__ import annotations

import atexit
import os
import pickle
import queue
import subprocess
import sys
import threading
import time

GRACE = 0.5
"""Seconds the worker gets past HiGHS's own time limit (which it usually keeps) before it is
killed."""

BOOT_TRY = 0.5
"""Seconds a small program is tried in the caller's main thread while the worker boots (as
long as a boot: 0.43-0.57 s measured); unfinished, it goes to the worker."""

_BOOT = (
    "import signal; signal.signal(signal.SIGINT, signal.SIG_IGN); "  # Ctrl-C is the caller's,
    # who kills it: ignored from the first statement, before the imports a Ctrl-C could cut
    "import runpy, sys; runpy.run_path(sys.argv[1], run_name='__main__')"
)
_READY = "ready"
_lock = threading.Lock()
_worker: _Worker | None = None


class WorkerError(RuntimeError):
    """The worker ended without an answer before the deadline (a crash, not a time-out)."""


class _Worker:
    """One worker process; its replies (unpickled by a reader thread) arrive in ``replies``,
    ``None`` once its output ends."""

    def __init__(self) -> None:
        self.pid = os.getpid()  # a forked child must not share its parent's worker
        self.proc = subprocess.Popen(
            [sys.executable, "-c", _BOOT, __file__], stdin=subprocess.PIPE, stdout=subprocess.PIPE
        )
        self.replies: queue.SimpleQueue = queue.SimpleQueue()
        self.ready = False
        threading.Thread(target=self._read, daemon=True).start()

    def send(self, kwargs: dict) -> None:
        try:
            pickle.dump(kwargs, self.proc.stdin, pickle.HIGHEST_PROTOCOL)
            self.proc.stdin.flush()
        except OSError as e:
            raise WorkerError(f"the milp worker (HiGHS) ended: {e}") from None

    def _read(self) -> None:
        try:
            while True:
                self.replies.put(pickle.load(self.proc.stdout))
        except Exception:  # end of output: the worker ended or was killed
            self.replies.put(None)

    def reply(self, until: float) -> object:
        """The next reply, ``TimeoutError`` at ``until`` (perf_counter), ``WorkerError`` when
        the worker ended without one."""
        try:
            out = self.replies.get(timeout=max(until - time.perf_counter(), 0.0))
        except queue.Empty:
            raise TimeoutError from None
        if out is None:
            raise WorkerError(f"the milp worker (HiGHS) ended with code {self.proc.wait()}")
        return out

    def kill(self) -> None:
        self.proc.kill()
        self.proc.wait()

    def close(self) -> None:
        """End it: closing its input ends its loop."""
        try:
            self.proc.stdin.close()
            self.proc.wait(timeout=1.0)
        except (OSError, subprocess.TimeoutExpired):
            self.kill()


def in_main_thread() -> bool:
    """Whether the caller runs where Python runs signal handlers (the main thread): there a
    program goes to the worker, so that a Ctrl-C or SIGTERM does not wait for HiGHS."""
    return threading.current_thread() is threading.main_thread()


def _current() -> _Worker:
    """This process's worker, started when there is none (or it ended); ``_lock`` held."""
    global _worker
    if _worker is None or _worker.pid != os.getpid() or _worker.proc.poll() is not None:
        _worker = _Worker()
    return _worker


def start() -> None:
    """In the main thread, start the worker now without waiting for it (nothing when one runs
    or another thread is solving): its boot (about 0.5 s, scipy's import) overlaps the caller's
    own set-up."""
    if in_main_thread() and _lock.acquire(blocking=False):
        try:
            _current()
        finally:
            _lock.release()


def busy() -> bool:
    """Whether another thread holds the worker now (a caller then solves a small program in its
    own process rather than wait for it)."""
    return _lock.locked()


def booted() -> bool:
    """Whether this process's worker is ready for a program (one is started when there is
    none or it ended; nothing is waited for)."""
    if not _lock.acquire(blocking=False):
        return False  # another thread is solving
    try:
        worker = _current()
        if not worker.ready:
            worker.ready = worker.reply(time.perf_counter()) == _READY
        return worker.ready
    except (TimeoutError, WorkerError):  # still booting, or it ended (the next call restarts)
        return False
    finally:
        _lock.release()


def solve(kwargs: dict, seconds: float) -> tuple[int, object, str] | None:
    """``(status, x, message)`` of :func:`scipy.optimize.milp` on ``kwargs``, run in the
    worker with HiGHS's ``time_limit`` set to what is left of ``seconds`` once the worker is
    ready; None when it has no answer ``GRACE`` seconds after that (it is killed then; one still
    starting is kept). A worker that ends without an answer raises :class:`WorkerError`; an
    interrupt (Ctrl-C, SIGTERM) kills it and goes on at once."""
    global _worker
    until = time.perf_counter() + seconds + GRACE
    if not _lock.acquire(timeout=seconds + GRACE):
        return None
    try:
        worker = _current()
        try:
            if not worker.ready:
                try:
                    worker.reply(until - GRACE)  # the ready signal: its imports are done
                except TimeoutError:
                    return None  # it goes on starting, for the next solve
                worker.ready = True
            left = until - GRACE - time.perf_counter()
            options = {**kwargs.get("options", {}), "time_limit": max(left, 1e-3)}
            worker.send({**kwargs, "options": options})
            return worker.reply(until)
        except BaseException:  # a time-out, a crash, an interrupt: its state is unknown
            worker.kill()
            _worker = None
            raise
    except TimeoutError:
        return None
    finally:
        _lock.release()


@atexit.register
def _close() -> None:
    if _worker is not None and _worker.pid == os.getpid():
        _worker.close()


def _follow(parent: int) -> None:
    """End this worker once its caller is gone (killed, so never killing it; HiGHS, which lets
    this thread run, would go on to its time limit)."""
    while os.getppid() == parent:
        time.sleep(0.25)
    os._exit(0)


def serve() -> None:
    """The worker's loop: a pickled ``milp`` keyword dict in, ``(status, x, message)`` out,
    until its input ends or its caller is gone. HiGHS's own output goes to stderr, never into
    the replies."""
    threading.Thread(target=_follow, args=(os.getppid(),), daemon=True).start()
    out = os.fdopen(os.dup(1), "wb")
    os.dup2(2, 1)
    from scipy.optimize import milp

    pickle.dump(_READY, out)
    out.flush()
    while True:
        try:
            kwargs = pickle.load(sys.stdin.buffer)
        except EOFError:
            return
        res = milp(**kwargs)
        pickle.dump((int(res.status), res.x, str(res.message)), out, pickle.HIGHEST_PROTOCOL)
        out.flush()


if __name__ == "__main__":
    serve()
