"""Compiled kernels on disk are keyed by the package's compiled sources, not only their own file.

numba keys a cached function (``@njit(cache=True)``) by its own source file alone, yet it links
into the cached machine code every compiled function it calls and freezes every global it reads,
from whatever module they come. After an edit or a ``git pull`` that changes only such a callee
or constant (a function of ``oracle/walk.py``, a threshold of ``oracle/tolerance.py``), the
unchanged callers' cached code would keep running the old one, silently.

So :func:`refresh` (run by :mod:`.caches` at import) digests the *compiled sources*: every
``.py`` file that contains ``cache=True``, and every module of the package such a file imports
from (a package counts as all its modules: its re-exports); a name a kernel uses is imported
from where it is defined or re-exported there (``tests/test_kernel_caches.py`` checks that).
Each folder numba caches this package's modules in (:func:`location`: ``NUMBA_CACHE_DIR`` when
set, else the ``__pycache__`` beside the sources when writable, else numba's user folder) holds
a stamp, :data:`STAMP`, with that digest. Where the stamp's digest differs (or there is no
stamp), the ``*.nbi``/``*.nbc`` files numba names after this package's modules there are deleted
(nothing else, and no link) and the stamp is written anew, atomically, readable as any file the
user makes (the umask's mode), so the users of a shared install agree: the next call of a kernel
compiles it again. Only folders numba caches kernels in get a stamp (none is created for the
rest); the first stamp found, folder by folder, names the others. A stamp also keeps the sizes
and times of every ``.py`` file, so an import where none changed reads no source (about a
millisecond); a changed time with the same contents deletes nothing. Two processes importing at
once both stay correct (a file already deleted is skipped). A cache folder that is a link is
left alone; a process that kept running old code across a change can still write old kernels
after the purge (restart it). A source folder that is a link is followed (Python imports through
it, numba caches beside it). A folder whose stamp path is not a regular file (a directory, a
FIFO, a link) is left alone: no stamp can be kept there, so it is never purged; a stamp over
:data:`MAX_STAMP` bytes is not one.
"""

from __future__ import annotations

import contextlib
import os
import re
import stat
import zlib
from pathlib import Path

STAMP = "modquad_gym-compiled-sources.stamp"
"""The stamp's name in each cache folder (numba's own files end in ``.nbi`` or ``.nbc``)."""

CACHE_FILE = r"([A-Za-z_]\w*)\.\S+-\d+\.py\d+[a-z]*(?:\.nbi|\.\d+\.nbc)"
"""numba's names for the cache files of module M: ``M.<qualname>-<line>.py<XY><abiflags>.nbi``
(the index) and ``...<n>.nbc`` (the data); group 1 is the module's file name."""

MAX_STAMP = 64 * 1024
"""The largest stamp read (a real one is a few hundred bytes)."""


def scan(root: str) -> tuple[dict[str, list[str]], str]:
    """({folder relative to root ("." for root, "/"-separated): its modules' names}, a
    checksum of every ``.py`` file's path, size and modification time)."""
    folders: dict[str, list[str]] = {}
    stats = []
    pending = ["."]
    seen = {os.path.realpath(root)}  # a linked folder is followed once (no loop)
    while pending:
        rel = pending.pop()
        stems = []
        with os.scandir(os.path.join(root, rel)) as entries:
            for entry in entries:
                if entry.is_dir():
                    real = os.path.realpath(entry.path)
                    if entry.name != "__pycache__" and not entry.name.startswith("."):
                        if real not in seen:
                            seen.add(real)
                            pending.append(entry.name if rel == "." else f"{rel}/{entry.name}")
                elif entry.name.endswith(".py"):
                    info = entry.stat()
                    stems.append(entry.name[:-3])
                    stats.append(f"{rel}/{entry.name}\0{info.st_size}\0{info.st_mtime_ns}")
        if stems:
            folders[rel] = sorted(stems)
    checksum = zlib.crc32("\n".join(sorted(stats)).encode("utf-8", "surrogateescape"))
    return folders, f"{checksum:08x}"


def _targets(name: str, module: str, folders: dict[str, list[str]]) -> list[str]:
    """The files (relative to the package) of ``module`` imported in the package ``name``: a
    module's file, or every module of a package (what it re-exports)."""
    parts = module.split(".")[1:]
    rel = "/".join(parts) or "."
    if rel in folders:
        return [f"{rel}/{stem}.py" for stem in folders[rel]]
    folder = "/".join(parts[:-1]) or "."
    return [f"{folder}/{parts[-1]}.py"] if parts[-1] in folders.get(folder, ()) else []


def compiled_sources(root: str, folders: dict[str, list[str]]) -> dict[str, bytes]:
    """{path relative to root: contents} of the compiled sources: the files that contain
    ``cache=True`` and the modules of the package they import from."""
    name = os.path.basename(root)
    package = re.escape(name.encode())
    imports = re.compile(rb"^[ \t]*(?:from|import)[ \t]+(" + package + rb"[\w.]*)", re.MULTILINE)
    files = {}
    for rel, stems in folders.items():
        for stem in stems:
            with open(os.path.join(root, rel, f"{stem}.py"), "rb") as source:
                files[f"{rel}/{stem}.py"] = source.read()
    chosen = {path for path, text in files.items() if b"cache=True" in text}
    for path in list(chosen):
        for module in imports.findall(files[path]):
            chosen.update(_targets(name, module.decode(), folders))
    return {path: files[path] for path in sorted(chosen)}


def numba_user_folder() -> Path:
    """numba's user-wide cache folder: its ``AppDirs(appname="numba", appauthor=False)``, the
    rule platformdirs keeps (``$XDG_CACHE_HOME/numba`` or ``~/.cache/numba`` on Linux,
    ``~/Library/Caches/numba`` on macOS)."""
    import platformdirs  # only when the package folder is not writable (rare): 5 ms

    return Path(platformdirs.user_cache_dir("numba", appauthor=False))


def _sha1(data: bytes) -> str:
    """The hex SHA-1 of data (``_sha1`` loads in a fraction of ``hashlib``'s time)."""
    try:
        from _sha1 import sha1
    except ImportError:  # pragma: no cover - another Python
        from hashlib import sha1
    return sha1(data).hexdigest()


def location(folder: str, environ=os.environ) -> str:
    """The folder numba caches the modules of ``folder`` in (its cache locators, in order):
    ``$NUMBA_CACHE_DIR/<name>_<sha1 of the folder>`` when set, else ``folder/__pycache__`` when
    writable, else the same subfolder of numba's user folder."""
    chosen = environ.get("NUMBA_CACHE_DIR")
    tree = os.path.join(folder, "__pycache__")
    if not chosen and os.access(tree if os.path.isdir(tree) else folder, os.W_OK):
        return tree
    if not chosen:
        chosen = str(numba_user_folder())
    sub = f"{os.path.basename(folder)}_{_sha1(folder.encode('utf-8', 'surrogateescape'))}"
    return os.path.join(chosen, sub)


def blocked(place: str) -> bool:
    """Whether the stamp path in ``place`` is something other than a regular file (no stamp
    can be written there)."""
    try:
        return not stat.S_ISREG(os.lstat(os.path.join(place, STAMP)).st_mode)
    except OSError:
        return False


def read_stamp(place: str) -> dict[str, str]:
    """The stamp in cache folder ``place`` ({} when there is none or it is not one: only a
    regular file of at most :data:`MAX_STAMP` bytes is read, never waiting on a FIFO)."""
    flags = os.O_RDONLY | getattr(os, "O_NONBLOCK", 0) | getattr(os, "O_NOFOLLOW", 0)
    try:
        handle = os.open(os.path.join(place, STAMP), flags)
    except OSError:
        return {}
    try:
        info = os.fstat(handle)
        if not stat.S_ISREG(info.st_mode) or info.st_size > MAX_STAMP:
            return {}
        lines = os.read(handle, MAX_STAMP + 1).decode("utf-8").splitlines()
    except (OSError, UnicodeDecodeError):
        return {}
    finally:
        os.close(handle)
    fields = dict(line.partition(" ")[::2] for line in lines[1:])
    return fields if lines[:1] == ["modquad_gym compiled sources"] else {}


def write_stamp(place: str, fields: dict[str, str]) -> None:
    """Write the stamp in ``place`` atomically (a temporary file renamed over it); nothing when
    the folder cannot be written."""
    text = "".join(f"{key} {value}\n" for key, value in fields.items())
    temporary = os.path.join(place, f".{STAMP}.{os.getpid()}.{os.urandom(6).hex()}")
    try:
        os.makedirs(place, exist_ok=True)
        handle = os.open(temporary, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o666)  # the umask's
    except OSError:
        return
    try:
        with os.fdopen(handle, "w", encoding="utf-8") as file:
            file.write("modquad_gym compiled sources\n" + text)
        os.replace(temporary, os.path.join(place, STAMP))
    except OSError:
        with contextlib.suppress(OSError):
            os.unlink(temporary)


def purge(place: str, modules: list[str]) -> list[str]:
    """Delete the numba cache files of ``modules`` (names of modules of one folder) in cache
    folder ``place``: plain files only, never a link or anything else; their paths (a file
    another process deleted first, or one that cannot be deleted, is skipped)."""
    removed = []
    if os.path.islink(place):
        return removed
    try:
        entries = list(os.scandir(place))
    except OSError:
        return removed
    wanted = set(modules)
    for entry in entries:
        match = re.fullmatch(CACHE_FILE, entry.name)
        if match and match.group(1) in wanted and entry.is_file(follow_symlinks=False):
            with contextlib.suppress(OSError):
                os.unlink(entry.path)
                removed.append(entry.path)
    return removed


def _folder(root: str, rel: str) -> str:
    """The folder ``rel`` of :func:`scan` as numba names it (the source file's folder)."""
    return root if rel == "." else os.path.join(root, *rel.split("/"))


def _left_alone(place: str) -> bool:
    """Whether cache folder ``place`` is not ours to change: a link, or its stamp path blocked."""
    return os.path.islink(place) or blocked(place)


def _fresh(root: str, folders: dict, stats: str, environ) -> tuple[bool, dict[str, str]]:
    """(whether every stamp the last refresh wrote still holds ``stats``, the first stamp
    found in the folders of ``folders``, in order: it names the others)."""
    anchor: dict[str, str] = {}
    for rel in sorted(folders):
        place = location(_folder(root, rel), environ)
        if not _left_alone(place) and (anchor := read_stamp(place)):
            break
    if anchor.get("stats") != stats:
        return False, anchor
    for rel in anchor.get("folders", "").split():
        place = location(_folder(root, rel), environ)
        if not _left_alone(place) and read_stamp(place).get("stats") != stats:
            return False, anchor
    return True, anchor


def refresh(root: str, environ=os.environ) -> list[str]:
    """Delete the cache files of the package at ``root`` compiled from other sources than its
    present ones (the module's docstring); the paths deleted."""
    folders, stats = scan(root)
    fresh, anchor = _fresh(root, folders, stats, environ)
    if fresh:
        return []
    import hashlib  # only after a change (2 ms)

    sources = compiled_sources(root, folders)
    digest = hashlib.sha256()
    for path, text in sources.items():
        digest.update(f"{path}\0{len(text)}\0".encode("utf-8", "surrogateescape") + text)
    cached = sorted({p.rpartition("/")[0] for p, t in sources.items() if b"cache=True" in t})
    fields = {"sources": digest.hexdigest(), "stats": stats, "folders": " ".join(cached)}
    removed = []
    for rel in sorted({".", *cached, *anchor.get("folders", "").split()}):
        if rel not in folders:
            continue
        place = location(_folder(root, rel), environ)
        if _left_alone(place):
            continue
        if read_stamp(place).get("sources") != fields["sources"]:
            removed += purge(place, folders[rel])
        if rel in cached:
            write_stamp(place, fields)
        else:
            with contextlib.suppress(OSError):
                os.unlink(os.path.join(place, STAMP))
    return removed
