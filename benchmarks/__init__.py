"""The project's measurement scripts (not in the wheel): each runs as ``python -m benchmarks.NAME``
from the repository root, writes its report under ``results/`` and names its command there.

:func:`benchmarks.common.scripts` lists them with what each measures.

A script run so ends on Ctrl-C or SIGTERM as ``modquad`` does, wherever the signal lands (its
imports, or code its ``main`` does not guard): one line ``python -m benchmarks.NAME:
interrupted`` (``terminated``) on stderr and exit status 130 (143), no traceback. Python imports
this package before the script's own code, so that is set up here, and only then: a plain
``import benchmarks`` changes nothing.
"""

import sys


def _script() -> str:
    """The module ``python -m`` runs: ``__main__``'s once Python runs it, the one named after
    ``-m`` while Python still looks for it."""
    spec = getattr(sys.modules.get("__main__"), "__spec__", None)
    if spec is not None:
        return spec.name
    argv = getattr(sys, "orig_argv", [])
    return next((b for a, b in zip(argv, argv[1:]) if a == "-m"), "")


def _stop_hook(kind, exc, tb, _before=sys.excepthook) -> None:
    """``sys.excepthook`` of a script: an interrupt (as the CLI judges one) ends it with its one
    line and exit status; every other exception goes to the hook that was there before."""
    try:
        from modquad_gym.core.interrupts import interrupted, stopped
    except BaseException:  # cut short itself: the exception as Python shows it
        return _before(kind, exc, tb)
    name = _script()
    if not (name.split(".")[0] == "benchmarks" and interrupted(exc)):
        return _before(kind, exc, tb)
    raise SystemExit(stopped(f"python -m {name}", exc))  # Python exits with it, after cleanup


if sys.argv[:1] == ["-m"]:  # python -m benchmarks.NAME, while Python looks for the module
    import signal

    sys.excepthook = _stop_hook
    _mask = getattr(signal, "pthread_sigmask", lambda how, signals: None)
    _held = _mask(signal.SIG_BLOCK, {signal.SIGINT, signal.SIGTERM})  # until handlers are set
    try:
        from modquad_gym.core.interrupts import sigterm_as_interrupt

        _SIGNALS = sigterm_as_interrupt()  # SIGTERM as Ctrl-C, Ctrl-C noted, for the whole run
        _SIGNALS.__enter__()
    finally:  # the caller's mask back (a signal it had blocked stays blocked); one that came
        if _held is not None:  # meanwhile and is not blocked there is raised now
            _mask(signal.SIG_SETMASK, _held)
