"""numba's on-disk cache keyed by the package's compiled sources (core/kernel_caches.py).

numba checks a cached function against its own file only; a kernel calling a compiled function
of another file, or reading a constant imported from one, kept the old code after that file
changed. These tests build small packages in a temporary folder: stale cache files go, a fresh
cache and everything that is not this package's numba files stay, ``NUMBA_CACHE_DIR`` is
followed as numba follows it, processes importing at once do not fail; end to end, a change in
a callee's file (a copy of modquad_gym, a tiny package) reaches the cached caller.
"""

from __future__ import annotations

import ast
import os
import shutil
import subprocess
import sys
import time
from pathlib import Path

import pytest

import modquad_gym
from modquad_gym.core import kernel_caches as kc
from modquad_gym.core.caches import SOURCES

PY = f"py{sys.version_info[0]}{sys.version_info[1]}"
CALLER = "from numba import njit\nfrom pkg.consts import K\n\n\n@njit(cache=True)\ndef f(x):\n"


def fake_package(tmp_path: Path) -> Path:
    """pkg/: a cached module ``a`` reading K from ``consts`` (no kernel), an unrelated ``b``."""
    root = tmp_path / "pkg"
    root.mkdir()
    (root / "__init__.py").write_text("")
    (root / "a.py").write_text(CALLER + "    return K\n")
    (root / "consts.py").write_text("K = 1\n")
    (root / "b.py").write_text("X = 2\n")
    return root


def touch(folder: Path, *names: str) -> list[Path]:
    folder.mkdir(parents=True, exist_ok=True)
    for name in names:
        (folder / name).write_bytes(b"x")
    return [folder / name for name in names]


def run_refresh(root: Path, environ=None) -> set[str]:
    return {Path(p).name for p in kc.refresh(str(root), {} if environ is None else environ)}


def test_stale_files_go_the_stamp_is_renewed_and_others_stay(tmp_path):
    """An old stamp: this package's .nbi/.nbc files go (modules a and b alike); a link, a
    foreign module's file, numba's temporary file, a .pyc and a text file stay."""
    root = fake_package(tmp_path)
    cache = root / "__pycache__"
    stale = [f"a.f-6.{PY}.nbi", f"a.f-6.{PY}.1.nbc", f"b.g-1.{PY}t.nbi", f"a.C.m-9.{PY}.2.nbc"]
    kept = [f"numpy.f-6.{PY}.nbi", f"a.f-6.{PY}.nbi.tmp.0123abcd", "a.cpython-311.pyc", "a.txt"]
    touch(cache, *stale, *kept)
    outside = touch(tmp_path / "elsewhere", "target.nbi")[0]
    (cache / f"a.h-9.{PY}.nbi").symlink_to(outside)
    kc.write_stamp(str(cache), {"sources": "old", "stats": "old", "folders": "."})
    assert run_refresh(root) == set(stale)
    assert sorted(p.name for p in cache.iterdir() if p.name != kc.STAMP) == sorted(
        [*kept, f"a.h-9.{PY}.nbi"]
    )
    assert outside.exists() and (cache / f"a.h-9.{PY}.nbi").is_symlink()
    stamp = kc.read_stamp(str(cache))
    assert stamp["sources"] != "old" and stamp["stats"] == kc.scan(str(root))[1]
    assert stamp["folders"] == "."


def test_a_cache_folder_that_is_a_link_is_left_alone(tmp_path):
    """``__pycache__`` a link to another folder: nothing there is deleted or written."""
    root = fake_package(tmp_path)
    stale = touch(tmp_path / "real", f"a.f-6.{PY}.nbi")
    (root / "__pycache__").symlink_to(tmp_path / "real")
    assert run_refresh(root) == set()
    assert [p.name for p in (tmp_path / "real").iterdir()] == [stale[0].name]


def test_unchanged_sources_delete_nothing(tmp_path):
    """A fresh cache stays, also after the sources' times change with the same contents; a
    change in the constants' module (not compiled itself, imported by a kernel's) removes it."""
    root = fake_package(tmp_path)
    run_refresh(root)
    fresh = touch(root / "__pycache__", f"a.f-6.{PY}.nbi", f"a.f-6.{PY}.1.nbc")
    assert run_refresh(root) == set()
    before = kc.read_stamp(str(root / "__pycache__"))
    os.utime(root / "a.py", ns=(1, 10**9))
    assert run_refresh(root) == set() and all(p.exists() for p in fresh)
    after = kc.read_stamp(str(root / "__pycache__"))
    assert after["sources"] == before["sources"] and after["stats"] != before["stats"]
    (root / "b.py").write_text("X = 3\n")  # not compiled, not imported by a kernel
    assert run_refresh(root) == set()
    (root / "consts.py").write_text("K = 2\n")
    assert run_refresh(root) == {p.name for p in fresh}


def test_the_compiled_sources_are_the_kernels_and_what_they_import():
    """modquad_gym's: every file with ``cache=True``, the walk's callee and the tolerance
    constants the kernels read; nothing the kernels do not import (the CLI, the searches)."""
    sources = kc.compiled_sources(SOURCES, kc.scan(SOURCES)[0])
    assert {"oracle/walk.py", "oracle/basis.py", "oracle/tolerance.py"} <= set(sources)
    assert {"envs/assembly/exact.py", "search/supports.py"} <= set(sources)
    assert not any(p.startswith(("cli/", "search/anytime", "viz/")) for p in sources)


def defined_in(module: str, name: str) -> str:
    """The file (relative to the package) that defines ``name`` of package module ``module``,
    through its re-exports."""
    path = Path(SOURCES, *module.split(".")[1:])
    if path.is_dir():
        if (path / f"{name}.py").exists() or (path / name).is_dir():  # a submodule
            return str(Path(path, f"{name}.py").relative_to(SOURCES))
        path = path / "__init__.py"
    else:
        path = path.with_suffix(".py")
    for node in ast.parse(path.read_text()).body:
        if isinstance(node, ast.ImportFrom) and (node.module or "").startswith("modquad_gym"):
            if any((alias.asname or alias.name) == name for alias in node.names):
                original = next(a.name for a in node.names if (a.asname or a.name) == name)
                return defined_in(node.module, original)
    return str(path.relative_to(SOURCES))


def kernel_names(tree: ast.Module) -> set[str]:
    """The names the compiled functions of a module read (decorated ``@njit(...)`` or passed
    to ``njit(...)(f)``)."""
    compiled = {
        node.args[0].id
        for node in ast.walk(tree)
        if isinstance(node, ast.Call) and isinstance(node.func, ast.Call)
        and getattr(node.func.func, "id", "") == "njit" and isinstance(node.args[0], ast.Name)
    }  # fmt: skip
    names = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.FunctionDef) and (
            node.name in compiled
            or any("njit" in ast.unparse(decorator) for decorator in node.decorator_list)
        ):
            names |= {n.id for n in ast.walk(node) if isinstance(n, ast.Name)}
    return names


def test_a_name_a_kernel_reads_is_defined_in_a_compiled_source():
    """What numba freezes into a kernel from another module (a compiled function, a constant)
    comes from a file of the digest: imported from where it is defined, or re-exported by a
    package whose modules all count."""
    sources = kc.compiled_sources(SOURCES, kc.scan(SOURCES)[0])
    read, missing = set(), []
    for rel, text in sources.items():
        tree = ast.parse(text)
        used = kernel_names(tree)
        for node in ast.walk(tree):
            if isinstance(node, ast.ImportFrom) and (node.module or "").startswith("modquad_gym"):
                for alias in node.names:
                    if (alias.asname or alias.name) not in used:
                        continue
                    where = defined_in(node.module, alias.name).replace(os.sep, "/")
                    read.add(f"{alias.name} ({where})")
                    if where not in sources:
                        missing.append(f"{rel}: {alias.name} from {where}")
    assert "ACCEPT (oracle/tolerance.py)" in read and "invert (oracle/basis.py)" in read
    assert not missing, missing


def test_numba_cache_dir_holds_the_stamp_and_only_our_files_go(tmp_path):
    """With NUMBA_CACHE_DIR the package's folder there is numba's own name for it; another
    folder's file of the same module name stays, nothing is written beside the sources."""
    from numba.core.caching import _CacheLocator

    root = fake_package(tmp_path)
    chosen = tmp_path / "numba-cache"
    ours = chosen / _CacheLocator.get_suitable_cache_subpath(str(root / "a.py"))
    assert kc.location(str(root), {"NUMBA_CACHE_DIR": str(chosen)}) == str(ours)
    stale = touch(ours, f"a.f-6.{PY}.nbi", f"consts.k-1.{PY}.1.nbc")
    foreign = touch(chosen / "pkg_0123456789abcdef", f"a.f-6.{PY}.nbi")
    assert run_refresh(root, {"NUMBA_CACHE_DIR": str(chosen)}) == {p.name for p in stale}
    assert all(p.exists() for p in foreign)
    assert kc.read_stamp(str(ours))["folders"] == "."
    assert not (root / "__pycache__").exists()


def test_processes_refreshing_at_once_do_not_fail(tmp_path):
    """Four processes purge the same stale files at the same moment: all exit 0, the files
    are gone and one valid stamp remains."""
    root = fake_package(tmp_path)
    cache = root / "__pycache__"
    touch(cache, *[f"a.f{i}-6.{PY}.{n}.nbc" for i in range(300) for n in (1, 2)])
    start = time.time() + 2.0
    code = (
        f"import time\nfrom modquad_gym.core.kernel_caches import refresh\n"
        f"while time.time() < {start}: time.sleep(0.001)\nrefresh({str(root)!r}, {{}})\n"
    )
    env = {**os.environ, "PYTHONPATH": str(Path(SOURCES).parent)}
    runs = [
        subprocess.Popen([sys.executable, "-c", code], env=env, stderr=subprocess.PIPE, text=True)
        for _ in range(4)
    ]
    errors = [run.communicate(timeout=60)[1] for run in runs]
    assert [run.returncode for run in runs] == [0] * 4, errors
    assert [p.name for p in cache.iterdir()] == [kc.STAMP]
    assert kc.read_stamp(str(cache))["sources"]


PROBE = """
import numpy as np
import modquad_gym
from modquad_gym.oracle.walk import vertex_basis
M = np.zeros((3, 3))
print(vertex_basis(np.eye(3), np.eye(3)[0], np.array([1, 2]), np.zeros(3, np.bool_), M, M.copy()))
"""


def run_copy(folder: Path, code: str, *path: Path) -> str:
    """The last line ``code`` prints, run in a fresh interpreter in ``folder`` (with ``path``
    first on sys.path) and numba's own cache places."""
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(map(str, (*path, folder)))}
    env.pop("NUMBA_CACHE_DIR", None)
    run = subprocess.run(
        [sys.executable, "-c", code], cwd=folder, env=env, capture_output=True, text=True,
        timeout=120,
    )  # fmt: skip
    assert run.returncode == 0, run.stderr
    return run.stdout.strip()


@pytest.mark.slow
def test_a_callee_change_reaches_the_cached_caller(tmp_path):
    """A copy of the package: ``walk.vertex_basis`` (cached) calls ``basis.invert``; after
    ``basis._TINY`` becomes huge, invert finds every matrix singular, and the cached caller
    must say so (it kept the old invert before). Then a tiny package whose kernel reads a
    constant of a module that is not compiled: the new value reaches it."""
    shutil.copytree(
        Path(modquad_gym.__file__).parent, tmp_path / "modquad_gym",
        ignore=shutil.ignore_patterns("__pycache__", "data"),
    )  # fmt: skip
    assert run_copy(tmp_path, PROBE) == "True"
    basis = tmp_path / "modquad_gym" / "oracle" / "basis.py"
    basis.write_text(basis.read_text().replace("\n_TINY = 1e-13", "\n_TINY = 1e300"))
    assert run_copy(tmp_path, PROBE) == "False"
    tiny = tmp_path / "tiny"
    tiny.mkdir()
    fake_package(tiny)
    code = (
        f"from modquad_gym.core.kernel_caches import refresh\nrefresh({str(tiny / 'pkg')!r})\n"
        "from pkg.a import f\nprint(f(0))"
    )
    assert run_copy(tiny, code, tmp_path) == "1"
    (tiny / "pkg" / "consts.py").write_text("K = 7\n")
    assert run_copy(tiny, code, tmp_path) == "7"


def test_the_stamp_is_as_readable_as_any_file_the_user_makes(tmp_path):
    """Another user of a shared install reads the stamp (0600 made them purge each other's
    kernels at every import): its mode is 0666 less the umask."""
    root = fake_package(tmp_path)
    old = os.umask(0o022)
    try:
        run_refresh(root)
    finally:
        os.umask(old)
    assert (root / "__pycache__" / kc.STAMP).stat().st_mode & 0o777 == 0o644


def test_a_stamp_path_that_is_no_file_leaves_its_folder_alone(tmp_path):
    """A FIFO at the stamp path: the import does not wait on it (a process with a time
    limit), deletes nothing there and leaves the FIFO; a directory likewise, at every run."""
    root = fake_package(tmp_path)
    cache = root / "__pycache__"
    stale = touch(cache, f"a.f-6.{PY}.nbi")[0]
    os.mkfifo(cache / kc.STAMP)
    code = (
        f"from modquad_gym.core.kernel_caches import refresh\nprint(refresh({str(root)!r}, {{}}))"
    )
    env = {**os.environ, "PYTHONPATH": str(Path(SOURCES).parent)}
    run = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True,
                         timeout=60)  # fmt: skip
    assert (run.returncode, run.stdout.strip()) == (0, "[]"), run.stderr
    assert stale.exists() and (cache / kc.STAMP).is_fifo()
    (cache / kc.STAMP).unlink()
    (cache / kc.STAMP).mkdir()
    assert run_refresh(root) == set() and run_refresh(root) == set() and stale.exists()


def test_a_stamp_over_the_size_bound_is_not_one(tmp_path):
    """A stamp padded past MAX_STAMP (its header still valid) is not read: the folder is
    purged and a stamp of a few hundred bytes written."""
    root = fake_package(tmp_path)
    run_refresh(root)
    cache = root / "__pycache__"
    stale = touch(cache, f"a.f-6.{PY}.nbi")[0]
    with open(cache / kc.STAMP, "ab") as stamp:
        stamp.truncate(kc.MAX_STAMP + 1)
    assert kc.read_stamp(str(cache)) == {}
    assert run_refresh(root) == {stale.name}
    assert (cache / kc.STAMP).stat().st_size < 1000


def linked_package(tmp_path: Path) -> tuple[Path, Path]:
    """pkg/ whose only kernel lives in sub/, a link to a folder outside it (with a link back
    to pkg inside: a loop)."""
    root = tmp_path / "pkg"
    root.mkdir()
    (root / "__init__.py").write_text("")
    (root / "consts.py").write_text("K = 1\n")
    real = tmp_path / "real_sub"
    real.mkdir()
    (real / "__init__.py").write_text("")
    (real / "k.py").write_text(CALLER + "    return K\n")
    (real / "back").symlink_to(root)
    (root / "sub").symlink_to(real)
    return root, real


def test_a_linked_source_folder_is_digested_and_purged(tmp_path):
    """Python imports pkg.sub through its link and numba caches beside it: its kernel is in the
    digest, and a change of the constant it reads deletes its cache files there."""
    root, real = linked_package(tmp_path)
    assert kc.scan(str(root))[0] == {".": ["__init__", "consts"], "sub": ["__init__", "k"]}
    run_refresh(root)
    stale = touch(real / "__pycache__", f"k.f-6.{PY}.nbi")[0]
    assert run_refresh(root) == set()
    (root / "consts.py").write_text("K = 2\n")
    assert run_refresh(root) == {stale.name} and not stale.exists()


def test_no_cache_folder_is_made_where_numba_caches_nothing(tmp_path):
    """With NUMBA_CACHE_DIR only the kernel folder's subfolder is made (not the package
    root's), and an import where nothing changed stays on the fast path with it."""
    root, _ = linked_package(tmp_path)
    chosen = tmp_path / "numba-cache"
    environ = {"NUMBA_CACHE_DIR": str(chosen)}
    run_refresh(root, environ)
    assert [p.name.rpartition("_")[0] for p in chosen.iterdir()] == ["sub"]
    assert not (root / "__pycache__").exists()
    assert kc._fresh(str(root), kc.scan(str(root))[0], kc.scan(str(root))[1], environ)[0]
