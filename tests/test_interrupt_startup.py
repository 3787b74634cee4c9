"""A Ctrl-C or SIGTERM while ``modquad`` is still loading its modules ends it as one during a
command does: one line ``modquad: interrupted`` and exit status 130 (``terminated``, 143), no
traceback. The signal is made deterministic: an import hook raises KeyboardInterrupt (or sends
the signal and turns it into an ImportError, as numpy's import does) when the named module is
first imported, as a signal arriving at that moment would."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]

HOOK = """
import sys

class Interrupt:
    def find_spec(self, name, path=None, target=None):
        if name == {target!r}:
            raise KeyboardInterrupt

sys.meta_path.insert(0, Interrupt())
sys.argv = ["modquad", "solve", "--task", "example:screwdriver", "--quiet"]
"""

ENTRIES = {
    "console script": "from modquad_gym.cli import main\nsys.exit(main())",
    "python -m": "import runpy\nrunpy.run_module('modquad_gym.cli', run_name='__main__', "
    "alter_sys=True)",
}
"""How the command starts: the installed ``modquad`` script's two lines, and ``python -m``."""


def _run(code: str, *args: str, cwd: Path = ROOT) -> subprocess.CompletedProcess:
    """``python ARGS [CODE]`` with this checkout first on the path."""
    path = os.pathsep.join(filter(None, (str(ROOT), os.environ.get("PYTHONPATH"))))
    command = [sys.executable, *args, *([code] if code else [])]
    env = {**os.environ, "PYTHONPATH": path}
    return subprocess.run(command, capture_output=True, text=True, env=env, cwd=cwd, timeout=120)


@pytest.mark.parametrize("entry", sorted(ENTRIES))
@pytest.mark.parametrize("module", ["numpy", "modquad_gym.cli.solve"])
def test_an_interrupt_while_loading_is_one_line_and_130(entry, module):
    """``numpy``: the first heavy library a command loads; ``modquad_gym.cli.solve``: the
    command's own module."""
    proc = _run(HOOK.format(target=module) + ENTRIES[entry], "-c")
    assert proc.stderr.splitlines() == ["modquad: interrupted"], proc.stderr[-2000:]
    assert proc.returncode == 130


def test_an_interrupt_while_train_py_loads_is_one_line_and_130():
    """``python train.py``: a Ctrl-C while the training code (torch, SB3) loads."""
    start = f"import runpy\nrunpy.run_path({str(ROOT / 'train.py')!r}, run_name='__main__')"
    proc = _run(HOOK.format(target="agents.cli") + start, "-c")
    assert proc.stderr.splitlines() == ["python train.py: interrupted"], proc.stderr[-2000:]
    assert proc.returncode == 130


SIGNALLED = """
import signal
import sys

signal.signal(signal.SIGINT, signal.default_int_handler)  # not ignored in a background job


class Swallowed:
    def find_spec(self, name, path=None, target=None):
        if name == {target!r}:
            try:
                signal.raise_signal(signal.{signal})
            except KeyboardInterrupt:
                raise ImportError('PyCapsule_Import could not import module "datetime"') from None

sys.meta_path.insert(0, Swallowed())
sys.argv = ["modquad", "solve", "--task", "example:screwdriver", "--quiet"]
"""
"""A signal whose KeyboardInterrupt the import turns into an ImportError, as numpy's import
does when a Ctrl-C or SIGTERM cuts it short."""

ENDS = {"SIGINT": ("interrupted", 130), "SIGTERM": ("terminated", 143)}
"""Each signal's line and exit status."""


@pytest.mark.parametrize("entry", sorted(ENTRIES))
@pytest.mark.parametrize("signal", sorted(ENDS))
@pytest.mark.parametrize("module", ["numpy", "modquad_gym.cli.solve"])
def test_a_signal_made_an_import_error_while_loading_is_one_line(entry, signal, module):
    """The CLI's own start-up (``numpy``) and the command's module loaded in ``run_command``."""
    proc = _run(SIGNALLED.format(target=module, signal=signal) + ENTRIES[entry], "-c")
    word, status = ENDS[signal]
    assert proc.stderr.splitlines() == [f"modquad: {word}"], proc.stderr[-2000:]
    assert proc.returncode == status


def test_a_sigterm_made_an_import_error_while_train_py_loads_is_one_line_and_143():
    start = f"import runpy\nrunpy.run_path({str(ROOT / 'train.py')!r}, run_name='__main__')"
    proc = _run(SIGNALLED.format(target="agents.cli", signal="SIGTERM") + start, "-c")
    assert proc.stderr.splitlines() == ["python train.py: terminated"], proc.stderr[-2000:]
    assert proc.returncode == 143


STOPS = {
    "through exec": 'exec("raise KeyboardInterrupt")',
    "made an ImportError": "swallowed()",
}
"""A command's Ctrl-C: raised in code run by ``exec`` of a string (numba, dataclasses and
namedtuple build code so: CPython notes it and, under ``python -m``, ends the process by SIGINT,
-2, whatever status is returned); turned into an ImportError by a library (numpy's import, cut
short, raises ``PyCapsule_Import could not import module "datetime"``)."""

COMMAND = """
import signal
import sys

from modquad_gym.core.interrupts import run_command

signal.signal(signal.SIGINT, signal.default_int_handler)  # not ignored in a background job


def swallowed(sent=signal.SIGINT):
    try:
        signal.raise_signal(sent)
    except KeyboardInterrupt:
        raise ImportError('PyCapsule_Import could not import module "datetime"') from None


sys.exit(run_command(lambda _: {stop}, "stops"))
"""


@pytest.mark.parametrize("stop", sorted(STOPS))
def test_a_caught_interrupt_under_python_m_is_one_line_and_130(tmp_path, stop):
    (tmp_path / "stops.py").write_text(COMMAND.format(stop=STOPS[stop]))
    proc = _run("", "-m", "stops", cwd=tmp_path)
    assert proc.stderr.splitlines() == ["stops: interrupted"], proc.stderr[-2000:]
    assert proc.returncode == 130


def test_a_sigterm_made_an_import_error_in_a_command_is_one_line_and_143(tmp_path):
    """Not ``error:`` with exit 2, as an ImportError of its own would be."""
    (tmp_path / "stops.py").write_text(COMMAND.format(stop="swallowed(signal.SIGTERM)"))
    proc = _run("", "-m", "stops", cwd=tmp_path)
    assert proc.stderr.splitlines() == ["stops: terminated"], proc.stderr[-2000:]
    assert proc.returncode == 143
