"""Issue 24, family 6: a user who can write neither the package folder nor HOME still runs every
command; numba's compiled code and matplotlib's cache go to a private temporary folder, with one
note line the first time."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
SCREWDRIVER = ROOT / "examples" / "screwdriver.json"


def _configure_run(tmp_path: Path, body: str) -> subprocess.CompletedProcess:
    """A fresh interpreter with TMPDIR at ``tmp_path`` whose numba and matplotlib places lie
    below a regular file (never writable, not even for root), the two variables unset, then
    ``body``."""
    blocker = tmp_path / "a-file"
    blocker.write_text("")
    code = (
        "import os, sys, tempfile; from pathlib import Path\n"
        "import modquad_gym.core.caches as c\n"
        f"b = Path({str(blocker)!r})\n"
        "c.default_places = lambda: {'NUMBA_CACHE_DIR': [lambda: b / 'n'], "
        "'MPLCONFIGDIR': [lambda: b / 'm']}\n"
        "for v in ('NUMBA_CACHE_DIR', 'MPLCONFIGDIR'): os.environ.pop(v, None)\n"
    ) + body
    env = {**os.environ, "TMPDIR": str(tmp_path), "PYTHONPATH": str(ROOT)}
    env.pop("NUMBA_CACHE_DIR", None)
    run = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, env=env, timeout=120
    )
    assert run.returncode == 0, run.stderr
    return run


def test_unwritable_places_move_the_caches_to_a_private_folder(tmp_path):
    """configure() with numba's and matplotlib's places below a regular file: both variables
    point into TMPDIR, the note is one line, once."""
    run = _configure_run(
        tmp_path,
        "first = c.configure()\n"
        "for v in ('NUMBA_CACHE_DIR', 'MPLCONFIGDIR'): os.environ.pop(v, None)\n"
        "second = c.configure()\n"
        "print(sorted(first) == sorted(second) == ['MPLCONFIGDIR', 'NUMBA_CACHE_DIR'])\n"
        "print(all(Path(p).is_dir() and p.startswith(tempfile.gettempdir()) "
        "for p in first.values()))\n",
    )
    assert run.stdout.split() == ["True", "True"]
    notes = [line for line in run.stderr.splitlines() if "modquad_gym: note" in line]
    assert len(notes) == 1 and "not writable" in notes[0], run.stderr


PRIVATE_NOT_OURS = {
    "writable by others": "os.chmod(pre, 0o777)\n",
    "another owner": "",  # this process's uid seen as one more: the folder is another's
    "a link": "pre.rmdir(); os.symlink(tempfile.mkdtemp(), pre)\n",
}


@pytest.mark.skipif(sys.platform == "win32", reason="no private folder on Windows")
@pytest.mark.parametrize("how", sorted(PRIVATE_NOT_OURS))
def test_a_private_folder_that_is_not_ours_is_not_adopted(tmp_path, how):
    """The predictable folder in TMPDIR, when another user made it first or others may write
    it, could feed numba's pickled cache index to this process: a fresh mkdtemp folder serves
    the run instead, the note says why, and it is removed at exit."""
    uid = "real = os.getuid(); os.getuid = lambda: real + 1\n" if how == "another owner" else ""
    run = _configure_run(
        tmp_path,
        f"{uid}pre = c.private_folder('NUMBA_CACHE_DIR'); pre.mkdir(mode=0o700)\n"
        f"{PRIVATE_NOT_OURS[how]}"
        "chosen = Path(c.configure()['NUMBA_CACHE_DIR']); info = os.lstat(chosen)\n"
        "print(chosen != pre, chosen.parent == pre.parent, info.st_uid == os.geteuid(), "
        "oct(info.st_mode & 0o777))\n"
        "print(chosen)\n",
    )
    checks, chosen = run.stdout.splitlines()
    assert checks.split() == ["True", "True", "True", "0o700"], run.stdout
    notes = [line for line in run.stderr.splitlines() if "modquad_gym: note" in line]
    assert len(notes) == 1 and "is not used" in notes[0], run.stderr
    assert not Path(chosen).exists()  # removed at exit


def test_the_places_checked_are_the_libraries_own(tmp_path, monkeypatch):
    """numba's user cache folder (its own AppDirs) and matplotlib's config folder (its own
    rule) are the ones configure() checks; the bounds' disk cache is platformdirs' user cache
    folder unless MODQUAD_CACHE names one."""
    from numba.misc.appdirs import AppDirs

    from modquad_gym.core.caches import matplotlib_folder, numba_user_folder
    from modquad_gym.search.bounds import _cache_dir

    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "cache"))
    monkeypatch.setenv("XDG_CONFIG_HOME", str(tmp_path / "config"))
    monkeypatch.delenv("MPLCONFIGDIR", raising=False)
    assert numba_user_folder() == Path(AppDirs(appname="numba", appauthor=False).user_cache_dir)
    assert numba_user_folder() == tmp_path / "cache" / "numba"
    code = "import matplotlib; print(matplotlib.get_configdir())"
    run = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         env=dict(os.environ), timeout=60)  # fmt: skip
    assert Path(run.stdout.strip()) == matplotlib_folder() == tmp_path / "config" / "matplotlib"
    monkeypatch.delenv("MODQUAD_CACHE", raising=False)
    assert _cache_dir() == tmp_path / "cache" / "modquad_gym"
    monkeypatch.setenv("MODQUAD_CACHE", str(tmp_path / "mine"))
    assert _cache_dir() == tmp_path / "mine"


def _locked_down_command(tmp_path: Path) -> tuple[list[str], Path]:
    """A shell prefix that runs with the package read-only and HOME not writable, and the
    package root that prefix sees; skips where neither a mount namespace (root) nor file
    permissions (other users) can make the package read-only."""
    if os.geteuid() != 0:
        copy = tmp_path / "pkg"
        shutil.copytree(ROOT / "modquad_gym", copy / "modquad_gym",
                        ignore=shutil.ignore_patterns("__pycache__"))  # fmt: skip
        for folder, dirs, files in os.walk(copy):
            for name in dirs + files:
                os.chmod(Path(folder) / name, 0o555)
        os.chmod(copy, 0o555)
        return [], copy
    unshare = shutil.which("unshare")
    probe = unshare and subprocess.run(
        [unshare, "-m", "--propagation", "private", "true"], capture_output=True
    )
    if not probe or probe.returncode != 0:
        pytest.skip("root without mount namespaces: the package cannot be made read-only")
    mount = f'mount --bind -o ro {ROOT} {ROOT} && exec "$@"'
    return [unshare, "-m", "--propagation", "private", "sh", "-c", mount, "sh"], ROOT


@pytest.mark.parametrize(
    "argv",
    [["--help"], ["solve", "--task", str(SCREWDRIVER), "--n-max", "3", "--json"]],
    ids=["help", "solve"],
)
def test_commands_run_for_a_locked_down_user(tmp_path, argv):
    prefix, package = _locked_down_command(tmp_path)
    home = tmp_path / "home-is-a-file"
    home.write_text("")
    env = {
        **os.environ,
        "HOME": str(home),
        "TMPDIR": str(tmp_path),
        "PYTHONPATH": str(package),
        "PYTHONDONTWRITEBYTECODE": "1",
    }
    for variable in ("NUMBA_CACHE_DIR", "MPLCONFIGDIR", "XDG_CACHE_HOME", "XDG_CONFIG_HOME"):
        env.pop(variable, None)
    run = subprocess.run(
        [*prefix, sys.executable, "-m", "modquad_gym.cli", *argv],
        capture_output=True,
        text=True,
        env=env,
        cwd=tmp_path,
        timeout=300,
    )
    assert run.returncode == 0, run.stderr
    assert "Traceback" not in run.stderr
    assert len(run.stderr.strip().splitlines()) <= 1, run.stderr  # at most the note
    assert list(tmp_path.glob("modquad_gym-numba_cache_dir-*"))
