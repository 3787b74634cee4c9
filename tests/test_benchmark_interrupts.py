"""A Ctrl-C or SIGTERM that lands while a ``python -m benchmarks.NAME`` script is still loading
ends it as ``modquad`` ends: one line ``python -m benchmarks.NAME: interrupted`` (``terminated``)
and exit status 130 (143), no traceback (benchmarks/__init__.py). The signal is made
deterministic as in test_interrupt_startup: a sitecustomize on the path installs an import hook
that, when the named module is first imported, raises KeyboardInterrupt, or sends the signal and
turns it into an ImportError as numpy's import does when cut short."""

from __future__ import annotations

import os
import signal as signal_module
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
SCRIPT = "benchmarks.fault_delay"
"""Any script: each imports numpy (through benchmarks.common) before its own code runs."""

HOOK = """
import signal
import sys

signal.signal(signal.SIGINT, signal.default_int_handler)  # not ignored in a background job


class Hook:
    def find_spec(self, name, path=None, target=None):
        if name == {target!r}:
            {action}


sys.meta_path.insert(0, Hook())
"""

RAISE = "raise KeyboardInterrupt"
SWALLOWED = """try:
                signal.raise_signal(signal.{signal})
            except KeyboardInterrupt:
                raise ImportError('PyCapsule_Import could not import a module') from None"""


def _run(tmp_path: Path, target: str, action: str) -> subprocess.CompletedProcess:
    """``python -m SCRIPT --help`` from the checkout, the hook on ``target`` in place."""
    (tmp_path / "sitecustomize.py").write_text(HOOK.format(target=target, action=action))
    path = os.pathsep.join(filter(None, (str(tmp_path), str(ROOT), os.environ.get("PYTHONPATH"))))
    return subprocess.run([sys.executable, "-m", SCRIPT, "--help"], capture_output=True,
                          text=True, env={**os.environ, "PYTHONPATH": path}, cwd=ROOT,
                          timeout=120)  # fmt: skip


def test_a_ctrl_c_while_a_script_imports_numpy_is_one_line_and_130(tmp_path):
    proc = _run(tmp_path, "numpy", RAISE)
    assert proc.stderr.splitlines() == [f"python -m {SCRIPT}: interrupted"], proc.stderr[-2000:]
    assert proc.returncode == 130


@pytest.mark.parametrize("signal, word, status", [("SIGINT", "interrupted", 130),
                                                  ("SIGTERM", "terminated", 143)])  # fmt: skip
@pytest.mark.parametrize("target", ["numpy", "modquad_gym"])
def test_a_signal_while_a_script_loads_is_one_line(tmp_path, signal, word, status, target):
    """``numpy``: turned into an ImportError, as numpy's import does; ``modquad_gym``: while
    benchmarks/__init__.py itself sets the handlers up (the signal waits for them)."""
    proc = _run(tmp_path, target, SWALLOWED.format(signal=signal))
    assert proc.stderr.splitlines() == [f"python -m {SCRIPT}: {word}"], proc.stderr[-2000:]
    assert proc.returncode == status


def test_any_other_failure_while_a_script_loads_keeps_its_traceback(tmp_path):
    proc = _run(tmp_path, "numpy", "raise RuntimeError('not an interrupt')")
    assert proc.stderr.startswith("Traceback (most recent call last):"), proc.stderr[-2000:]
    assert proc.stderr.splitlines()[-1] == "RuntimeError: not an interrupt"
    assert proc.returncode == 1


def test_importing_the_package_sets_nothing_up():
    """Only ``python -m benchmarks.NAME`` gets the hook and the handlers, not an import."""
    code = "import signal, sys, benchmarks; print(sys.excepthook is sys.__excepthook__, " \
        "signal.getsignal(signal.SIGTERM) is signal.SIG_DFL)"  # fmt: skip
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env,
                         cwd=ROOT, timeout=60, check=True).stdout  # fmt: skip
    assert out.split() == ["True", "True"]


def test_a_signal_the_caller_blocked_stays_blocked(tmp_path):
    """The set-up holds SIGINT and SIGTERM back only while it runs, then gives the caller's mask
    back: a SIGTERM the caller had blocked stays blocked (it was unblocked)."""
    (tmp_path / "sitecustomize.py").write_text(
        "import atexit, signal\n"
        "atexit.register(lambda: print('blocked', sorted(int(s) for s in "
        "signal.pthread_sigmask(signal.SIG_BLOCK, []))))\n"
    )
    path = os.pathsep.join(filter(None, (str(tmp_path), str(ROOT), os.environ.get("PYTHONPATH"))))
    block = lambda: signal_module.pthread_sigmask(  # noqa: E731
        signal_module.SIG_BLOCK, {signal_module.SIGTERM}
    )
    proc = subprocess.run([sys.executable, "-m", SCRIPT, "--help"], capture_output=True,
                          text=True, env={**os.environ, "PYTHONPATH": path}, cwd=ROOT,
                          timeout=120, preexec_fn=block)  # fmt: skip
    assert proc.returncode == 0, proc.stderr[-2000:]
    (line,) = [ln for ln in proc.stdout.splitlines() if ln.startswith("blocked")]
    blocked = eval(line.removeprefix("blocked "))
    assert int(signal_module.SIGTERM) in blocked and int(signal_module.SIGINT) not in blocked
