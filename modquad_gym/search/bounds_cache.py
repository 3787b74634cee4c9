"""The level bounds' disk cache (:mod:`.bounds`): one ``.npz`` per (module type, fault, n) that
holds the (2, P) array, the format it was written in and a SHA-256 of its numbers.

A level bound that is too low rules out a level that holds the answer, and the search then
reports a wrong "certified minimum". So a cached file is used only when it reads back as
written: the format is :data:`FORMAT`, the array is finite non-negative float64 of shape
(2, P) and its checksum matches. Anything else (a file of earlier code, another shape or type,
numbers changed since it was written, bytes that are no ``.npz``) reads as absent, and the
bounds are recomputed and the file rewritten. The checksum finds damage and stale files, not a
forger: the cache folder is the user's own.
"""

from __future__ import annotations

import hashlib
import os
import zipfile
from pathlib import Path

import numpy as np

from modquad_gym.core.outputs import atomic_write

__all__ = ["FORMAT", "checksum", "read_cached", "usable", "write_cached"]

FORMAT = 1
"""The cache's format. Raise it when :func:`~.bounds.compute_level_bounds` changes what it
computes: the files of earlier code then read as absent and are recomputed."""


def usable(bounds: object, columns: int) -> bool:
    """Whether ``bounds`` is a level-bound array: float64 of shape (2, ``columns``), finite
    and non-negative (each entry is a sum of non-negative terms)."""
    return (
        isinstance(bounds, np.ndarray)
        and bounds.dtype == np.float64
        and bounds.shape == (2, columns)
        and bool(np.isfinite(bounds).all() and (bounds >= 0).all())
    )


def checksum(bounds: np.ndarray) -> str:
    """SHA-256 (hex) of the format, the shape and the little-endian float64 numbers."""
    h = hashlib.sha256(f"level bounds {FORMAT} {bounds.shape}".encode())
    h.update(np.ascontiguousarray(bounds, dtype="<f8").tobytes())
    return h.hexdigest()


def read_cached(path: str | os.PathLike, columns: int) -> np.ndarray | None:
    """The bounds cached in ``path``, or None when there is no such file or it does not read
    back as :func:`write_cached` wrote it (format, shape, type, checksum)."""
    try:
        data = np.load(path, allow_pickle=False)
        if not isinstance(data, np.lib.npyio.NpzFile):
            return None  # an .npy array or a pickle: not this cache's format
        with data:
            if set(data.files) != {"bounds", "format", "sha256"}:
                return None
            bounds, fmt, digest = data["bounds"], data["format"], data["sha256"]
    except (OSError, ValueError, EOFError, KeyError, zipfile.BadZipFile):
        return None
    if fmt.shape != () or fmt.dtype.kind not in "iu" or int(fmt) != FORMAT:
        return None
    if not usable(bounds, columns) or digest.shape != () or digest.dtype.kind != "U":
        return None
    return bounds if str(digest) == checksum(bounds) else None


def write_cached(path: str | os.PathLike, bounds: np.ndarray) -> Path:
    """Write ``bounds`` to ``path`` atomically with the format and its checksum."""

    def write(tmp: Path) -> None:
        with tmp.open("wb") as fh:
            np.savez(fh, bounds=bounds, format=np.int64(FORMAT), sha256=np.str_(checksum(bounds)))

    return atomic_write(path, write)
