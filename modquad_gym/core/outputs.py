"""Safe output files: check a destination before long work, write it atomically, never replace
what the user saved unless asked.

Every command that writes goes through here, so two runs into one place never leave a mixed or
half-written file (each write goes to a temporary file in the same folder, then ``os.replace``),
and an existing file is replaced only with ``force=True``. A command that fills a folder claims it
(:func:`claim_output_dir`, or :func:`hold_output_dir` for a folder it shares with others): a
second run into the same folder is refused while the first runs (one process may hold a folder
twice: it is one run), and ``force`` removes only the files an earlier run of the command
recorded there, and what lies in the folders it fills alone (:mod:`.manifests`).
"""

from __future__ import annotations

import os
import stat
import tempfile
import threading
from collections.abc import Iterator
from contextlib import contextmanager, suppress
from pathlib import Path

from modquad_gym.core.atomic_files import (
    atomic_write,
    json_ready,
    named_os_error,
    save_figure,
    write_csv,
    write_text,
)
from modquad_gym.core.manifests import MANIFEST_NAME, ClaimedDir, clear_folders, remove_recorded
from modquad_gym.core.options import EMPTY_PATH
from modquad_gym.core.validation import NOT_REGULAR

__all__ = [
    "LOCK_NAME",
    "MANIFEST_NAME",
    "ClaimedDir",
    "OutputError",
    "atomic_write",
    "check_name_length",
    "check_output_dir",
    "claim_output_dir",
    "hold_output_dir",
    "json_ready",
    "check_output_file",
    "check_outputs",
    "named_os_error",
    "save_figure",
    "write_csv",
    "write_text",
]


class OutputError(ValueError):
    """An output path that cannot be written (exists, read-only, not a folder, ...)."""


def _dangling(path: Path) -> bool:
    """A symbolic link whose target does not exist (``exists()`` says False: it follows links)."""
    return path.is_symlink() and not path.exists()


def _refuse_dangling_folder(folder: Path, what: str) -> None:
    """A folder on the way that is a dangling symbolic link: creating it fails late, after the
    work (``mkdir`` finds the link), or creates folders where the link points."""
    for p in (folder, *folder.parents):
        if _dangling(p):
            raise OutputError(
                f"{what}: {p} is a symbolic link to {os.readlink(p)}, which does not exist"
            )
        if p.exists():
            return


def _writable(folder: Path) -> bool:
    """Whether a file can be created (and removed) in ``folder``: tried, not asked of
    ``os.access``, which says yes to root where nothing can be created (/proc, /sys)."""
    try:
        fd, name = tempfile.mkstemp(prefix=".modquad-probe.", dir=folder)
    except OSError:
        return False
    os.close(fd)
    with suppress(OSError):
        os.unlink(name)
    return True


def _check_writable_dir(folder: Path, what: str) -> None:
    _refuse_dangling_folder(folder, what)
    if not folder.exists():
        parent = next((p for p in folder.parents if p.exists()), None)
        if parent is None or not parent.is_dir() or not _writable(parent):
            raise OutputError(f"{what}: cannot create folder {folder} (parent not writable)")
        return
    if not folder.is_dir():
        raise OutputError(f"{what}: {folder} exists and is not a folder")
    if not _writable(folder):
        raise OutputError(f"{what}: folder {folder} is not writable")


def _refuse_special(path: Path, what: str) -> None:
    """A device, pipe or socket is never an output: writing /dev/full fails late, /dev/null
    loses the result, and replacing either would break the system."""
    try:
        mode = path.stat().st_mode
    except OSError:
        return  # nothing there (or unreachable: the folder check says so)
    if not (stat.S_ISREG(mode) or stat.S_ISDIR(mode)):
        raise OutputError(f"{what}: {path} is {NOT_REGULAR}")


def _name_max(folder: Path) -> int:
    """The longest file name (bytes) the file system of ``folder`` (or its nearest existing
    parent) takes; 255 where the system does not say."""
    existing = next((p for p in (folder, *folder.parents) if p.exists()), Path("."))
    try:
        return os.pathconf(existing, "PC_NAME_MAX")
    except (OSError, ValueError, AttributeError):  # no pathconf (Windows) or no answer
        return 255


def check_name_length(path: str | os.PathLike, what: str = "output") -> None:
    """An OutputError naming ``what`` when a component of ``path`` is longer than its file
    system takes: refused before the work, not after it ("File name too long")."""
    path = Path(path)
    limit = _name_max(path.parent)
    for part in path.parts:
        size = len(os.fsencode(part))
        if size > limit and part != path.anchor:
            raise OutputError(
                f"{what}: the name {part[:40]}... is {size} bytes long; this file system takes "
                f"at most {limit}"
            )


def _not_empty(path: str | os.PathLike, what: str) -> str | os.PathLike:
    """``path``, unless it is an empty string (``Path("")`` is the working folder, which the
    user did not name: ``--out ''``) or no path at all (``out_dir=3.5``: pathlib's TypeError
    would name nothing)."""
    if isinstance(path, str) and not path:
        raise OutputError(f"{what}: {EMPTY_PATH}")
    if not isinstance(path, (str, os.PathLike)):
        raise OutputError(f"{what} must be a path (a str or a PathLike), got {path!r:.60}")
    return path


def _force_hint(what: str) -> str:
    """How the caller asks to replace: ``--force`` for an option (``--out``, or ``output`` of a
    command), ``force=True`` for a Python argument (``path``, ``out_dir``)."""
    return "--force" if what.startswith("--") or what == "output" else "force=True"


def check_output_file(path: str | os.PathLike, force: bool = False, what: str = "output") -> Path:
    """The destination file as a Path, after checking it can be written: its folder exists or
    can be created and is writable, it is not a device, pipe or socket, and it does not exist
    yet (unless ``force``). ``what`` names the path in errors: an option (``--out``), whose
    advice is ``--force``, or a Python argument (``path``), whose advice is ``force=True``.
    Call it before long work starts."""
    path = Path(_not_empty(path, what))
    force_hint = _force_hint(what)
    check_name_length(path, what)
    if path.is_dir():
        raise OutputError(f"{what}: {path} is a folder, expected a file name")
    _refuse_special(path, what)
    if _dangling(path) and not force:  # a link the user made is theirs: replaced only on demand
        raise OutputError(
            f"{what}: {path} is a symbolic link (to {os.readlink(path)}, which does not exist); "
            f"use {force_hint} to replace it"
        )
    if path.exists() and not force:
        raise OutputError(f"{what}: {path} exists (use {force_hint} to replace it)")
    _check_writable_dir(path.parent if str(path.parent) else Path("."), what)
    return path


def check_outputs(outputs: dict[str, str | os.PathLike | None], force: bool = False) -> dict:
    """Every output file of one command checked together, before any work or write: each as
    :func:`check_output_file` (``outputs`` maps the option, e.g. ``"--out"``, to its path, or
    to None when not given), and no two naming the same file (the second would replace the
    first, or be refused after the first was written). Returns {option: Path} of those
    given."""
    checked = {
        what: check_output_file(path, force=force, what=what)
        for what, path in outputs.items()
        if path is not None
    }
    seen: dict[str, str] = {}
    for what, path in checked.items():
        key = os.path.realpath(path)
        if key in seen:
            raise OutputError(
                f"{what}: {path} is also the file of {seen[key]}; give each output its own file"
            )
        seen[key] = what
    return checked


def check_output_dir(
    path: str | os.PathLike, names: tuple[str, ...] = (), force: bool = False, what: str = "--out"
) -> Path:
    """The destination folder as a Path, after checking it is (or can become) a writable folder
    in which none of ``names`` exists yet (unless ``force``); an empty path (which would be
    the working folder) is refused. ``what`` names the folder in errors, as
    :func:`check_output_file`'s."""
    folder = Path(_not_empty(path, what))
    check_name_length(folder, what)
    _check_writable_dir(folder, what)
    for name in names:
        _refuse_special(folder / name, what)
    if not force:  # a dangling symbolic link counts: the user put it there
        taken = [n for n in names if os.path.lexists(folder / n)]
        if taken:
            raise OutputError(
                f"{what}: {folder} already holds {', '.join(taken)} (use {_force_hint(what)} "
                "to replace)"
            )
    return folder


LOCK_NAME = ".modquad.lock"
"""The lock file a running command holds in the folder it fills (:func:`claim_output_dir`)."""


class _Hold:
    """This process's hold of one folder: the holds open on it, its lock, its claim."""

    def __init__(self, key: str, lock) -> None:
        self.key, self.lock, self.count, self.claim = key, lock, 1, None


_HOLDS: dict[str, _Hold] = {}
"""The folders this process holds, by real path: a second hold of one is granted, not refused as
another run's (``train.py --report-dir`` equal to its ``--out``: the report's hold inside the
run's); the lock goes when the last hold ends."""
_HOLDS_GUARD = threading.Lock()


def _take(folder: Path, what: str) -> _Hold:
    """This process's hold of ``folder``: the one open already, counted once more, or a new
    one whose lock is taken at once (an OutputError when another process holds it)."""
    from filelock import FileLock, Timeout

    key = os.path.realpath(folder)
    with _HOLDS_GUARD:
        if key in _HOLDS:
            _HOLDS[key].count += 1
            return _HOLDS[key]
        lock = FileLock(folder / LOCK_NAME, thread_local=False)  # any thread may end it last
        try:
            lock.acquire(timeout=0)
        except Timeout:
            raise OutputError(
                f"{what}: {folder} is being written by another run (it holds "
                f"{folder / LOCK_NAME}); wait for it or choose another folder"
            ) from None
        _HOLDS[key] = _Hold(key, lock)
        return _HOLDS[key]


def _let_go(held: _Hold) -> None:
    """End one hold; the last one removes the lock file and releases the lock (a run that
    opened the file meanwhile re-checks the names)."""
    with _HOLDS_GUARD:
        held.count -= 1
        if held.count == 0:
            del _HOLDS[held.key]
            Path(held.lock.lock_file).unlink(missing_ok=True)
            held.lock.release()


@contextmanager
def hold_output_dir(
    path: str | os.PathLike, names: tuple[str, ...] = (), force: bool = False, what: str = "--out"
) -> Iterator[Path]:
    """Hold the output folder ``path`` for one run: check it as :func:`check_output_dir`, create
    it, and lock it (``LOCK_NAME``, the ``filelock`` package, removed at the end) so that a
    second run into it is refused at once (an OutputError naming ``what`` and the folder)
    instead of mixing or replacing files; the check is repeated under the lock. A folder this
    process holds already is held once more (one process is one run). Nothing is recorded or
    removed: for a folder whose other files are the user's or other commands' (``results``);
    :func:`claim_output_dir` adds the manifest. The folders it created go again if the run
    left them empty (a refused option, an interruption). Yields the folder."""
    folder = check_output_dir(path, names, force, what)
    if ".." in folder.parts:  # x/../y is y: x is neither created nor left behind
        folder = Path(os.path.realpath(folder))
    made = [p for p in (folder, *folder.parents) if not os.path.lexists(p)]  # deepest first
    folder.mkdir(parents=True, exist_ok=True)
    held = _take(folder, what)
    try:
        check_output_dir(folder, names, force, what)  # a run that finished while we checked
        yield folder
    finally:
        _let_go(held)
        with suppress(OSError):  # each only while empty: the first that is not stops it
            for made_here in made:
                made_here.rmdir()


@contextmanager
def claim_output_dir(
    path: str | os.PathLike,
    names: tuple[str, ...] = (),
    force: bool = False,
    what: str = "--out",
    keep: tuple = (),
    clear: tuple[str, ...] = (),
) -> Iterator[ClaimedDir]:
    """Hold the output folder ``path`` for one run as :func:`hold_output_dir` does, and record
    what the run writes there in the folder's manifest (:class:`ClaimedDir`). With ``force``,
    the files an earlier run recorded there are removed first, and everything in ``clear``
    (folders the run fills alone, such as ``ppo/``), but never one of ``keep`` (the files this
    run reads): whatever else the folder holds is the user's. A claim inside a claim of the
    same folder (one process) shares its manifest and removes nothing."""
    with hold_output_dir(path, names, force, what) as folder:
        with _HOLDS_GUARD:
            held = _HOLDS[os.path.realpath(folder)]
            if held.claim is None:
                if force:
                    remove_recorded(folder, keep)
                    clear_folders(folder, clear, keep)
                held.claim = ClaimedDir(folder)
        yield held.claim
