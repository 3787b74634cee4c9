"""The folders a ``train.py`` run fills, as it checks and claims them before any work.

A run writes its model and record into its run folder (``--out``; :data:`~agents.training.
RUN_FILES`) and its checkpoints and logs into its log folder, ``--tensorboard/<log_name>``
(:data:`~agents.training.LOG_FILES`; the run folder itself when it lies in ``--tensorboard``).
The log folder is named after the run folder's last two names, so two run folders may share one
(``sweepA/lr/run`` and ``sweepB/lr/run``): a log folder holding another run's logs is refused
unless ``--force``, and so is one in the run folder. A ``--resume`` that continues its own run
(the model lies in that log folder, or its run folder's ``config.json`` records it as
``log_dir``) goes on in it. What a run writes is recorded in each folder's manifest
(:class:`~modquad_gym.core.outputs.ClaimedDir`), so that a later ``--force`` removes it, with
all of a replaced log folder's ``train/``, ``bc/`` and ``ppo/`` (a killed run recorded no files
there); a model the run reads (``--resume``, ``--init-from``) is never removed.
"""

from __future__ import annotations

import argparse
import json
import os
from contextlib import suppress
from pathlib import Path
from typing import NamedTuple

from agents.training import LOG_FILES, RUN_FILES, log_name
from modquad_gym.core.outputs import MANIFEST_NAME, ClaimedDir
from modquad_gym.scoring.options import REPORT_FILES


class Held(NamedTuple):
    """One folder a run claims: the names refused there without ``force``, the option that
    names it, the files and the folders (every file in them) it records in the manifest."""

    folder: Path
    names: tuple[str, ...]
    force: bool
    what: str
    files: tuple[str, ...]
    folders: tuple[str, ...]


def log_folder(out: Path, tensorboard: Path) -> Path:
    """The log folder of the run folder ``out`` (resolved)."""
    return (Path(tensorboard) / log_name(Path(out), Path(tensorboard))).resolve()


def continues(resume: Path | None, log: Path) -> bool:
    """Whether the ``--resume`` model continues the run whose log folder is ``log``: it lies in
    ``log`` (a checkpoint, ``best_model.zip``), or its run folder's ``config.json`` records
    ``log``'s ``train/`` as its ``log_dir``."""
    if resume is None:
        return False
    model = Path(resume).resolve()
    if log in model.parents:
        return True
    try:
        record = json.loads((model.parent / "config.json").read_text(encoding="utf-8"))
        return (model.parent / record["log_dir"]).resolve() == log / "train"
    except (OSError, ValueError, KeyError, TypeError):
        return False


def held_folders(args: argparse.Namespace, runs: list[Path]) -> list[Held]:
    """Every folder the run folders ``runs`` of this command fill (none with
    ``--publish-run``): each run folder, and its log folder where that lies elsewhere."""
    held = []
    for out in runs:
        log = log_folder(out, args.tensorboard)
        own = continues(args.resume, log)
        logs = () if own else LOG_FILES  # a log folder of the run it continues: no refusal
        report = Path(out) / "report" if args.seeds else Path(args.report_dir)
        inside = not args.no_report and report.resolve() == (Path(out) / "report").resolve()
        files = RUN_FILES + tuple(f"report/{n}" for n in REPORT_FILES if inside)
        if log == Path(out).resolve():
            held.append(Held(out, RUN_FILES + logs, args.force, "--out", files, LOG_FILES))
            continue
        held.append(Held(out, RUN_FILES, args.force, "--out", files, ()))
        held.append(Held(log, logs, args.force and not own, "--tensorboard", (), LOG_FILES))
    return held


def kept(args: argparse.Namespace) -> tuple[Path, ...]:
    """The models this run reads, which ``--force`` never removes."""
    return tuple(Path(p) for p in (args.resume, args.init_from) if p is not None)


def cleared(held: Held) -> tuple[str, ...]:
    """The folders of ``held`` that its ``--force`` empties whole (every file, recorded or not:
    a run killed by SIGKILL never recorded its PPO events): those refused without it, so never
    the ``ppo/`` a ``--resume`` of the folder's own run goes on in."""
    return tuple(name for name in held.folders if name in held.names)


def record(claim: ClaimedDir, held: Held, walk: bool = True) -> None:
    """Put ``held``'s files in ``claim``'s manifest, and with ``walk`` every file under its
    folders (what training wrote there: checkpoints, logs), so that ``--force`` removes them."""
    for name in held.files:
        claim.path(name)
    for name in held.folders if walk else ():
        top = claim.folder / name
        if top.is_dir() and not top.is_symlink():
            for path in sorted(top.rglob("*")):
                if path.is_symlink() or path.is_file():
                    claim.path(path.relative_to(claim.folder))


def undo_unwritten(claim: ClaimedDir, held: Held) -> None:
    """After a run that stopped before it wrote anything (a refusal inside training, an early
    interruption): remove ``claim``'s manifest, which names files that do not exist, and the
    empty folders of ``held`` training made (``train/``), so that the same command runs again
    unrefused; nothing where any recorded file, or any file under those folders, exists."""
    if any(os.path.lexists(claim.folder / name) for name in claim.written):
        return
    tops = [claim.folder / name for name in held.folders]
    if any(files for top in tops for _, _, files in os.walk(top)):
        return
    (claim.folder / MANIFEST_NAME).unlink(missing_ok=True)
    for top in tops:
        for root, _, _ in sorted(os.walk(top), key=lambda walked: -len(walked[0])):
            with suppress(OSError):  # only while empty
                os.rmdir(root)
