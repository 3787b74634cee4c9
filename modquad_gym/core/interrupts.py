"""How a command ends: Ctrl-C and SIGTERM the same way, one line on stderr and exit 130 (Ctrl-C)
or 143 (SIGTERM), never a traceback or a native crash dump; an expected failure as one line
(:func:`one_line`) with exit 2.

SIGTERM is raised in the main thread as :class:`Terminated`, a ``KeyboardInterrupt``, so the
cleanup written for Ctrl-C (``finally`` blocks: worker processes stopped, Ray shut down, the rows
finished so far kept) runs for both.
"""

from __future__ import annotations

import os
import signal
import sys
import threading
from collections.abc import Callable, Iterator
from contextlib import contextmanager

from modquad_gym.core.extras import EXTRA_OF, missing_extra_message

__all__ = [
    "Terminated",
    "deferred_signals",
    "exit_status",
    "failure_line",
    "interrupted",
    "keep_sigterm",
    "one_line",
    "run_command",
    "sigterm_as_interrupt",
    "stop_line",
    "stopped",
]


class Terminated(KeyboardInterrupt):
    """The process received SIGTERM."""


_terminated: list[bool] = []
"""Whether SIGTERM came (a library may turn the exception into a plain KeyboardInterrupt, or,
as numpy's import cut short does, into an ImportError)."""


_interrupted: list[bool] = []
"""Whether Ctrl-C came (a library may turn the exception into another: numpy, its import cut
short, raises ImportError)."""


def _raise_terminated(signum, frame) -> None:
    _terminated.append(True)
    raise Terminated()


def _raise_interrupted(signum, frame) -> None:
    _interrupted.append(True)
    signal.default_int_handler(signum, frame)


@contextmanager
def sigterm_as_interrupt() -> Iterator[None]:
    """Within the block SIGTERM raises :class:`Terminated` in the main thread, and a Ctrl-C is
    noted as it raises KeyboardInterrupt (where Python's own handler had it: not where ignored);
    the previous handlers come back after it (nothing changes when called from another thread,
    where Python cannot set handlers)."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    before = signal.getsignal(signal.SIGTERM)
    note = signal.getsignal(signal.SIGINT) is signal.default_int_handler
    _terminated.clear()
    signal.signal(signal.SIGTERM, _raise_terminated)
    if note:
        _interrupted.clear()
        signal.signal(signal.SIGINT, _raise_interrupted)
    try:
        yield
    finally:
        if before is not None:
            signal.signal(signal.SIGTERM, before)
        if note:
            signal.signal(signal.SIGINT, signal.default_int_handler)


@contextmanager
def keep_sigterm() -> Iterator[None]:
    """Keep this process's SIGTERM handler across the block: a library started in it (Ray's
    ``ray.init`` installs a native handler that prints a crash dump) does not replace it.
    SIGTERM is held back during the block (where the platform allows) and delivered to that
    handler after it."""
    main = threading.current_thread() is threading.main_thread()
    before = signal.getsignal(signal.SIGTERM) if main else None
    hold = main and hasattr(signal, "pthread_sigmask")
    if hold:
        signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGTERM})
    try:
        yield
    except SystemExit as exc:  # Ray's own handler, while it was in place: sys.exit(SIGTERM)
        if exc.code != signal.SIGTERM:
            raise
        _terminated.append(True)
        raise Terminated() from None
    finally:
        if main and before is not None:
            signal.signal(signal.SIGTERM, before)
        if hold:  # a SIGTERM that came meanwhile reaches the handler now
            signal.pthread_sigmask(signal.SIG_UNBLOCK, {signal.SIGTERM})


@contextmanager
def deferred_signals() -> Iterator[None]:
    """Ctrl-C and SIGTERM wait until the block ends, then reach the handlers they would have
    reached: a step that must not be cut in half (a child process being started, whose half-sent
    start-up data makes it print a traceback) finishes first. Nothing changes outside the main
    thread."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    came: list[int] = []
    before = {s: signal.signal(s, lambda signum, frame: came.append(signum))
              for s in (signal.SIGINT, signal.SIGTERM)}  # fmt: skip
    try:
        yield
    finally:
        for s, handler in before.items():
            signal.signal(s, handler)
        for s in came:
            os.kill(os.getpid(), s)


def exit_status(exc: BaseException) -> int:
    """143 for SIGTERM, 130 for Ctrl-C (128 + the signal's number, as shells report them)."""
    return 128 + signal.SIGTERM if _was_terminated(exc) else 130


def _was_terminated(exc: BaseException) -> bool:
    return isinstance(exc, Terminated) or bool(_terminated)


def stop_line(prog: str, exc: BaseException) -> str:
    """The one line an interrupted command prints."""
    return f"{prog}: {'terminated' if _was_terminated(exc) else 'interrupted'}"


def interrupted(exc: BaseException) -> bool:
    """Whether ``exc`` ends a command as a Ctrl-C or SIGTERM does: a KeyboardInterrupt, or an
    ImportError after a Ctrl-C or SIGTERM came in :func:`sigterm_as_interrupt` (numpy's import,
    cut short by either, raises ImportError, not the KeyboardInterrupt)."""
    return isinstance(exc, KeyboardInterrupt) or (
        isinstance(exc, ImportError) and bool(_interrupted or _terminated)
    )


def stopped(prog: str, exc: BaseException) -> int:
    """An interrupted command's end: its line (:func:`stop_line`) on stderr, its status returned.

    CPython notes a KeyboardInterrupt that left code run by ``exec`` of a string (dataclasses,
    namedtuple and numba make their code so) and, under ``python -m``, ends the process by
    SIGINT (status -2, not this one) even though the interrupt was caught; running ``exec`` of
    a string again clears that note."""
    print(stop_line(prog, exc), file=sys.stderr)
    exec("")
    return exit_status(exc)


def one_line(exc: BaseException) -> str:
    """An expected failure as one line naming the file or option."""
    if isinstance(exc, OSError) and exc.filename and exc.strerror:
        return f"{exc.filename}: {exc.strerror}"
    if isinstance(exc, ModuleNotFoundError) and (exc.name or "").split(".")[0] in EXTRA_OF:
        return missing_extra_message(exc.name)
    return " ".join(str(exc).split()) or type(exc).__name__


def failure_line(exc: BaseException) -> str:
    """A failure that may be unexpected (a worker's, an outside agent's) as one line: an expected
    one (ValueError, OSError: they name their file or option) as :func:`one_line`, anything else
    with its type in front."""
    text = one_line(exc)
    if isinstance(exc, (ValueError, OSError)) or text == type(exc).__name__:
        return text
    return f"{type(exc).__name__}: {text}"


def run_command(main: Callable[[list[str] | None], object], prog: str, argv=None) -> int:
    """``main(argv)`` run as a command: 0 when it finishes (or the status it returns), 2 for a
    refused option or an expected failure (a missing optional package, a file that cannot be
    read or written: one line ``PROG: error: ...``, :class:`~.options.OneLineParser`) or a reader
    that closed the output (``| head``), 130 when interrupted (Ctrl-C) and 143 on SIGTERM (one
    line each: the command's ``finally`` blocks stop its workers and keep what it finished)."""
    try:
        with sigterm_as_interrupt():
            try:
                code = main(argv)
            except SystemExit as exc:  # argparse: --help (0) or a refused option (2)
                code = exc.code if isinstance(exc.code, int) else 0 if exc.code is None else 2
            sys.stdout.flush()  # a reader gone before the end is found here, not at exit
    except KeyboardInterrupt as exc:
        return stopped(prog, exc)
    except BrokenPipeError:  # stop writing (no second error at exit), say so once
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        print(f"{prog}: error: output closed before the end (broken pipe)", file=sys.stderr)
        return 2
    except (ValueError, OSError, ImportError, MemoryError, OverflowError) as exc:
        if interrupted(exc):
            return stopped(prog, exc)
        print(f"{prog}: error: {one_line(exc)}", file=sys.stderr)
        return 2
    return code if isinstance(code, int) else 0  # some return their rows
