"""Atomic writes: a file is filled under a temporary name beside it and moved into place in one
step, so a reader (or a second run) never sees it half-written and an interruption leaves the old
file. :mod:`.outputs` checks a destination first and re-exports these."""

from __future__ import annotations

import csv
import io
import math
import os
import tempfile
from collections.abc import Callable
from pathlib import Path

__all__ = ["atomic_write", "json_ready", "named_os_error", "save_figure", "write_csv", "write_text"]


def atomic_write(path: str | os.PathLike, write: Callable[[Path], None]) -> Path:
    """Call ``write(tmp)`` to fill a temporary file beside ``path``, then move it into place
    in one step. ``path``'s folder is created if needed; the temporary file never survives."""
    path = Path(path)
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        # a short temporary name: a legal name of 250 bytes plus a suffix would be too long
        fd, tmp_name = tempfile.mkstemp(
            prefix=f".{path.name[:32]}.", suffix=".tmp", dir=path.parent
        )
    except OSError as exc:  # a folder that takes no new file (/proc): named by the output
        reason = f"cannot create a file in {path.parent} ({exc.strerror or exc})"
        raise OSError(exc.errno, reason, str(path)) from exc
    os.close(fd)
    tmp = Path(tmp_name)
    try:
        write(tmp)
        os.chmod(tmp, 0o644)
        os.replace(tmp, path)
    except OSError as exc:  # name the output, not the temporary file (or nothing)
        raise named_os_error(exc, path) from exc
    finally:
        tmp.unlink(missing_ok=True)
    return path


def named_os_error(exc: OSError, path: Path) -> OSError:
    """``exc`` (no space left, quota, I/O error, ...) as an OSError of the same kind whose
    file is ``path``: what the user asked for, which the one-line error then names."""
    reason = exc.strerror or " ".join(str(exc).split()) or type(exc).__name__
    return OSError(exc.errno, reason, str(path))  # the subclass of its errno


def json_ready(value):
    """``value`` (dicts, lists and tuples of numbers, strings, ...) with every non-finite float
    replaced by None, so that ``json.dumps`` writes JSON (which has no Infinity or NaN)."""
    if isinstance(value, dict):
        return {k: json_ready(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [json_ready(v) for v in value]
    if isinstance(value, float) and not math.isfinite(value):
        return None
    return value


def write_text(path: str | os.PathLike, text: str) -> Path:
    """Write ``text`` (UTF-8) to ``path`` atomically."""
    return atomic_write(path, lambda tmp: tmp.write_text(text, encoding="utf-8"))


def save_figure(fig, path: str | os.PathLike, dpi: int = 120) -> Path:
    """Save a matplotlib figure atomically, in the format of ``path``'s suffix (PNG if none)."""
    path = Path(path)
    fmt = path.suffix[1:].lower() or "png"
    return atomic_write(path, lambda tmp: fig.savefig(tmp, format=fmt, dpi=dpi))


def write_csv(rows: list[dict], path: str | os.PathLike) -> None:
    """Write dict rows as CSV atomically, creating the folder: the columns are every row's
    keys in the order first seen (a row without one leaves it empty). No rows: a ValueError
    naming ``path`` (a CSV file needs its header, which rows give)."""
    if not rows:
        raise ValueError(f"{path}: no rows to write")
    keys = list(dict.fromkeys(k for row in rows for k in row))
    buffer = io.StringIO(newline="")
    writer = csv.DictWriter(buffer, fieldnames=keys)
    writer.writeheader()
    writer.writerows(rows)
    write_text(path, buffer.getvalue())
