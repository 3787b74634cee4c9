"""What a command wrote into the folder it claims, and what its ``--force`` removes there.

The manifest (``MANIFEST_NAME``, updated at each new file) names the files a run wrote, so that a
later ``force`` removes those and nothing else of the folder (the user's files stay); the
folders a run fills alone (``train.py``'s ``ppo/``) are emptied whole, for a run killed before
its manifest named their files. :mod:`.outputs` holds the folder and re-exports these.
"""

from __future__ import annotations

import json
import os
from contextlib import suppress
from pathlib import Path

from modquad_gym.core.atomic_files import write_text

__all__ = ["MANIFEST_NAME", "ClaimedDir", "clear_folders", "remove_recorded"]

MANIFEST_NAME = ".modquad-files.json"
"""The files a command wrote into its folder, relative to it: what a later ``--force`` removes."""


class ClaimedDir:
    """An output folder a command holds (:func:`~modquad_gym.core.outputs.claim_output_dir`):
    ``claim.path(name)`` is the
    path of a file it writes there, recorded in the folder's manifest."""

    def __init__(self, folder: Path) -> None:
        self.folder = folder
        self.written: list[str] = []

    def path(self, name: str | os.PathLike) -> Path:
        """``folder / name``, recorded as written by this command (the manifest is updated at
        once, so an interrupted run's files are known too)."""
        key = Path(name).as_posix()
        if key not in self.written:
            self.written.append(key)
            write_text(self.folder / MANIFEST_NAME, json.dumps(self.written, indent=1) + "\n")
        return self.folder / name


def _recorded_entry(folder: Path, name: str) -> Path | None:
    """``folder / name`` where it is an entry to remove: a file, or a symbolic link (the link
    itself, never its target), reached through real folders inside ``folder`` only (no
    absolute name, no ``..``, no link on the way); None otherwise (a folder, nothing)."""
    parts = Path(name).parts
    if not parts or Path(name).is_absolute() or ".." in parts:
        return None
    path = folder
    for part in parts[:-1]:
        path = path / part
        if path.is_symlink() or not path.is_dir():
            return None
    path = path / parts[-1]
    return path if path.is_symlink() or path.is_file() else None


def _kept(path: Path, keep: set[str]) -> bool:
    return bool({os.path.abspath(path), os.path.realpath(path)} & keep)


def remove_recorded(folder: Path, keep: tuple = ()) -> None:
    """Remove the files an earlier run recorded in ``folder``'s manifest (and the folders they
    leave empty); nothing else, and none of ``keep`` (files this run reads, such as a model it
    continues)."""
    try:
        recorded = json.loads((folder / MANIFEST_NAME).read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return
    kept = {f(p) for p in keep for f in (os.path.abspath, os.path.realpath)}
    for name in recorded if isinstance(recorded, list) else ():
        path = _recorded_entry(folder, str(name))
        if path is None or _kept(path, kept):
            continue
        path.unlink()
        for parent in path.parents:
            if parent == folder:
                break
            try:
                parent.rmdir()  # only when empty
            except OSError:
                break
    (folder / MANIFEST_NAME).unlink(missing_ok=True)


def clear_folders(folder: Path, names: tuple[str, ...], keep: tuple = ()) -> None:
    """Empty the run's own folders ``names`` of ``folder`` (``ppo/``): every file and link under
    them goes, recorded or not (a run killed before its manifest named them), but none of
    ``keep``; links are removed, never followed, and a folder that is a link is left alone."""
    kept = {f(p) for p in keep for f in (os.path.abspath, os.path.realpath)}
    for name in names:
        top = folder / name
        if Path(name).is_absolute() or ".." in Path(name).parts or top.is_symlink():
            continue
        for root, dirs, files in os.walk(top, topdown=False):  # links to folders: in dirs
            for entry in (Path(root, n) for n in (*files, *dirs)):
                if (entry.is_symlink() or entry.is_file()) and not _kept(entry, kept):
                    entry.unlink()
            with suppress(OSError):  # only when empty
                os.rmdir(root)
