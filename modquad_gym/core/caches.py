"""Where compiled code and library caches go, for a user who cannot write everywhere.

The compiled kernels are declared ``@njit(cache=True)``: numba stores them beside the sources
(``__pycache__``) or in the user's cache folder (``~/.cache/numba``), and raises "cannot cache
function" at import when neither is writable (a package installed read-only, no writable HOME).
Matplotlib, likewise, warns in two lines and makes a new temporary folder on every run when
``~/.config/matplotlib`` is not writable. Importing this module, first thing in
``modquad_gym/__init__.py``, checks those places and, for each that is not writable and whose
variable (``NUMBA_CACHE_DIR``, ``MPLCONFIGDIR``) is not set, points the library at a private
folder in the temporary directory, saying so in one line the first time. It imports neither
library. Before that it checks the numba settings that would stop numba's import with a
traceback, or that numba would ignore (:data:`NUMBA_SETTINGS`).

The private folder has a predictable name (:func:`private_folder`), so another local user could
make it first; numba's cache index files are pickles, which would then run their code in this
process. A folder there is adopted only when it is a real folder (no link) owned by this user
and writable by nobody else (:func:`private`); otherwise a fresh ``tempfile.mkdtemp`` folder
serves this run, and the note says why.

numba checks a cached kernel against its own source file only, not against the compiled
functions and constants of other files linked into it; so, last, the import deletes this
package's cached kernels wherever those sources changed (:mod:`.kernel_caches`).
"""

from __future__ import annotations

import contextlib
import os
import stat
import sys
import tempfile
from collections.abc import Callable
from pathlib import Path

from modquad_gym.core.kernel_caches import numba_user_folder, refresh

PACKAGE = Path(__file__).resolve().parents[1]
SOURCES = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
"""The package folder as numba names its sources' folders (not resolved: their ``__file__``)."""


def _writable(folder: Path) -> bool:
    """Whether files can be created in ``folder`` (created if missing), as numba checks it."""
    try:
        folder.mkdir(parents=True, exist_ok=True)
        tempfile.TemporaryFile(dir=folder).close()
    except OSError:
        return False
    return True


def matplotlib_folder() -> Path:
    """Matplotlib's config folder: ``$XDG_CONFIG_HOME/matplotlib`` or ``~/.config/matplotlib``
    on Linux and FreeBSD, ``~/.matplotlib`` elsewhere (matplotlib's own rule, not
    platformdirs')."""
    if sys.platform.startswith(("linux", "freebsd")):
        base = os.environ.get("XDG_CONFIG_HOME") or os.path.expanduser("~/.config")
        return Path(base) / "matplotlib"
    return Path(os.path.expanduser("~/.matplotlib"))


def default_places() -> dict[str, list[Callable[[], Path]]]:
    """For each variable, the places its library tries before giving up, in order (each a
    function, so that a later place is looked up only when the earlier ones fail)."""
    return {
        "NUMBA_CACHE_DIR": [
            lambda: PACKAGE / "envs" / "assembly" / "__pycache__",
            numba_user_folder,
        ],
        "MPLCONFIGDIR": [matplotlib_folder],
    }


def private_folder(variable: str) -> Path:
    """The folder in the temporary directory used for ``variable`` when its places are not
    writable."""
    uid = os.getuid() if hasattr(os, "getuid") else "user"
    return Path(tempfile.gettempdir()) / f"modquad_gym-{variable.lower()}-{uid}"


def private(folder: Path) -> str | None:
    """None when ``folder`` is this user's own: a folder (not a link) owned by this uid, not
    writable by its group or others; else what is wrong with it, in words."""
    try:
        info = os.lstat(folder)
    except OSError as exc:
        return exc.strerror or type(exc).__name__
    if not stat.S_ISDIR(info.st_mode):
        return "not a folder"
    if info.st_uid != os.getuid():
        return f"owned by uid {info.st_uid}"
    if info.st_mode & (stat.S_IWGRP | stat.S_IWOTH):
        return f"writable by others (mode {stat.S_IMODE(info.st_mode):o})"
    return None


def _private_place(variable: str) -> tuple[Path | None, str]:
    """The folder for ``variable`` (None when none can be made) and the words the note adds:
    :func:`private_folder` when it is this user's own, else a fresh ``mkdtemp`` folder, removed
    when the process ends (no later run would find it)."""
    folder = private_folder(variable)
    with contextlib.suppress(OSError):
        folder.mkdir(mode=0o700)
    wrong = private(folder)
    if wrong is None:
        return folder, ""
    try:
        fresh = tempfile.mkdtemp(prefix=f"modquad_gym-{variable.lower()}-")
    except OSError:
        return None, ""  # nothing writable at all: the library says so itself
    import atexit
    import shutil

    atexit.register(shutil.rmtree, fresh, ignore_errors=True)
    return Path(fresh), f" ({folder} is not used: {wrong})"


def configure() -> dict[str, str]:
    """Set each variable whose library could not write otherwise; {variable: folder} set."""
    if sys.platform == "win32":
        return {}
    chosen: dict[str, str] = {}
    fresh = False
    why = []
    for variable, places in default_places().items():
        if os.environ.get(variable) or any(_writable(place()) for place in places):
            continue
        existed = private_folder(variable).exists()
        folder, wrong = _private_place(variable)
        if folder is None:
            continue
        fresh = fresh or not existed or bool(wrong)
        why.append(wrong)
        os.environ[variable] = chosen[variable] = str(folder)
    if "NUMBA_CACHE_DIR" in chosen and "numba" in sys.modules:  # imported before us
        sys.modules["numba"].core.config.reload_config()
    if chosen and fresh:
        where = ", ".join(f"{k}={v}{w}" for (k, v), w in zip(chosen.items(), why, strict=True))
        from modquad_gym.core.notes import note  # logging only when there is a note

        note(
            f"modquad_gym: note: the package folder or HOME is not writable; caches go to {where}",
            __name__,
        )
    return chosen


NUMBA_SETTINGS = {
    "NUMBA_NUM_THREADS": ("numba's thread count: an integer >= 1", lambda v: int(v) >= 1),
    "NUMBA_OPT": (
        "numba's optimisation level: 0, 1, 2, 3 or max",
        lambda v: v.strip() in ("0", "1", "2", "3", "max"),
    ),  # fmt: skip
    "NUMBA_DISABLE_JIT": ("an integer (0: compile, 1: no compilation)", lambda v: int(v) >= 0),
}
"""The numba variables checked before numba is imported: their meaning and a test of a value.
Out of range, numba's import stops with a traceback (``NUMBA_NUM_THREADS=0``); unparsable,
numba prints a warning with a traceback and ignores the value."""


class SettingError(ValueError):
    """A setting in the environment that the libraries below would crash on or ignore."""


def setting_error(environ=os.environ) -> str | None:
    """One line naming the first variable of :data:`NUMBA_SETTINGS` whose value is not valid,
    or None."""
    for name, (meaning, valid) in NUMBA_SETTINGS.items():
        value = environ.get(name)
        if value is None:
            continue
        try:
            ok = valid(value)
        except ValueError:
            ok = False
        if not ok:
            return f"{name}={value!r} in the environment: expected {meaning} (or unset it)"
    return None


def _command_name() -> str | None:
    """The command this process is, whose errors are one line and exit code 2: ``modquad``
    (the console script, or ``python -m modquad_gym.cli``) or ``python train.py``; None for a
    program that imports the package."""
    argv = list(getattr(sys, "orig_argv", ())) or sys.argv
    script = Path(sys.argv[0]).name if sys.argv else ""
    if script == "modquad" or "modquad_gym.cli" in argv:
        return "modquad"
    return "python train.py" if script == "train.py" else None


def check_settings() -> None:
    """Stop on a setting of :func:`setting_error` before numba is imported: for a command
    (``modquad``, ``python train.py``) one line ``NAME: error: ...`` and exit code 2, for a
    program importing the package a :class:`SettingError` naming the variable."""
    message = setting_error()
    if message is None:
        return
    command = _command_name()
    if command is not None:
        print(f"{command}: error: {message}", file=sys.stderr)
        raise SystemExit(2)
    raise SettingError(message)


check_settings()
CHOSEN = configure()
"""The variables set at import (empty when the libraries' own places serve)."""
with contextlib.suppress(OSError):  # never stop the import: at worst numba's own rule holds
    refresh(SOURCES)
