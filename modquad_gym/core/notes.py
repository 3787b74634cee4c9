"""The library's diagnostics (notes a user should see, not a command's output) go through
:mod:`logging`, to the logger ``modquad_gym`` and its children.

As Hugging Face's libraries do, the package gives that logger one handler of its own, which
writes each message as one line to whatever ``sys.stderr`` is at that moment, and does not pass
records on to the root logger: a note reads the same in a command, a script or a notebook,
whatever another library did to the root logger. Silence the notes with
``logging.getLogger("modquad_gym").setLevel(logging.ERROR)``; send them to your own handlers
with ``.propagate = True`` after ``.handlers.clear()``. ``logging`` is imported at the first
note, not with the package.
"""

from __future__ import annotations

import sys

NAME = "modquad_gym"
"""The package's logger."""


def package_logger():
    """The logger ``modquad_gym``, with its stderr handler (module docstring) added once."""
    import logging

    class CurrentStderr(logging.StreamHandler):
        """Writes to the ``sys.stderr`` of the moment (a redirected or captured stream too)."""

        @property
        def stream(self):
            return sys.stderr

        @stream.setter
        def stream(self, _value) -> None:
            pass

    log = logging.getLogger(NAME)
    if not any(type(h).__name__ == "CurrentStderr" for h in log.handlers):
        handler = CurrentStderr()
        handler.setFormatter(logging.Formatter("%(message)s"))
        log.addHandler(handler)
        log.propagate = False
    return log


def note(message: str, module: str = NAME) -> None:
    """Log ``message`` as a warning of ``module``'s logger (a child of ``modquad_gym``)."""
    import logging

    package_logger()
    logging.getLogger(module).warning(message)
