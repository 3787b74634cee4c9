"""Review 23 (distributed), in both doors where there are two: the exhaustive search takes
workers only where it splits levels (an engine for a search that runs in this process is
refused), Ray's start is not its ``seconds`` (``ray_start_seconds`` beside it), a Ray start
interrupted or failed leaves no session folder of this process, a Ray that is installed but
cannot be imported is named with the reason, and a cluster address that is not a string, or
names a port outside 1-65535, is refused. No Ray is started here: the engine's start is
replaced (a pause, a fake Ray) and its tasks run serially."""

from __future__ import annotations

import json
import os
import time
from pathlib import Path

import numpy as np
import pytest

import modquad_gym.core.distributed as distributed
import modquad_gym.search.exhaustive as exhaustive
from modquad_gym.cli import main
from modquad_gym.core.distributed import Engine, run_item
from modquad_gym.geometry.module import palette
from modquad_gym.search import exhaustive_search
from modquad_gym.tasks import PlantedTasks, TaskRequirement

ROOT = Path(__file__).resolve().parents[1]
PAUSE = 1.0
"""Seconds the replaced Ray start takes (the first time only, as a running Ray starts at once)."""


def planted(n: int = 8, seed: int = 1) -> np.ndarray:
    return PlantedTasks(n_modules=n, n_wrenches=12, boundary_fraction=1.0)(
        np.random.default_rng(seed)
    ).wrenches


@pytest.fixture
def slow_start(monkeypatch):
    """Engine.start pauses PAUSE s the first time and starts nothing; Ray's tasks run here in
    item order; levels of 1000 structures or more are split. Yields the starts counted."""
    starts = []

    def start(self):
        if not starts:
            time.sleep(PAUSE)
        starts.append(self)

    def run_ray(self, fn, items, labels, catch, max_retries):
        for i, item in enumerate(items):
            yield i, run_item(fn, item, str(i), catch)

    monkeypatch.setattr(Engine, "start", start)
    monkeypatch.setattr(Engine, "_run_ray", run_ray)
    monkeypatch.setattr(distributed, "ray_installed", lambda: True)
    monkeypatch.setattr(distributed, "ray_problem", lambda: None, raising=False)
    monkeypatch.setattr(exhaustive, "PARALLEL_FROM", 1000)
    return starts


def test_rays_start_is_not_the_split_searchs_seconds(slow_start):
    """Python door: the split search's seconds leave the start out, ray_start_seconds has it;
    the answer is the serial one."""
    W = planted()
    serial = exhaustive_search(W, n_max=8, chunk=97)
    split = exhaustive_search(W, n_max=8, chunk=97, engine=Engine(2))
    assert slow_start, "no level was split: the test tests nothing"
    assert split.structure.key == serial.structure.key
    assert split.ray_start_seconds >= PAUSE and split.seconds < PAUSE, split
    assert split.to_dict()["ray_start_seconds"] >= PAUSE
    slow_start.clear()  # a level of one range (the default chunk) runs here: Ray not started
    whole = exhaustive_search(W, n_max=8, engine=Engine(2))
    assert (
        not slow_start
        and whole.ray_start_seconds == 0
        and "ray_start_seconds" not in (whole.to_dict())
    )


def test_solve_json_of_a_split_search_reports_rays_start_beside_seconds(slow_start, tmp_path,
                                                                        capsys):  # fmt: skip
    """CLI door: `modquad solve --method exhaustive --workers 2 --json` of one task."""
    path = tmp_path / "big.npy"
    np.save(path, planted())
    argv = ["solve", "--task", str(path), "--method", "exhaustive", "--n-max", "8",
            "--option", "chunk=97", "--workers", "2", "--json", "--quiet"]  # fmt: skip
    assert main(argv) == 0
    record = json.loads(capsys.readouterr().out)
    assert slow_start and record["n_modules"] == 8
    assert record["ray_start_seconds"] >= PAUSE and record["seconds"] < PAUSE, record


def test_an_engine_for_a_search_that_runs_here_is_refused_naming_engine():
    """Several module types, or a task whose rotor wrenches depend on the structure: the search
    runs in this process, so an engine of several workers is refused, not silently unused."""
    W = planted(4)
    types = palette("t45,flat")
    with pytest.raises(ValueError, match=r"^engine Engine\(workers=2, .*\): the exhaustive "
                       r"search over several module types runs in this process"):  # fmt: skip
        exhaustive_search(W, n_max=5, modules=types, engine=Engine(2))
    heavy = TaskRequirement(W, kind="external")
    with pytest.raises(ValueError, match=r"^engine .*depend on the structure \(kind external\)"):
        exhaustive_search(heavy, n_max=5, engine=Engine(2))
    alone = exhaustive_search(W, n_max=5, modules=types, engine=Engine(1))  # runs here anyway
    assert alone.n_modules == exhaustive_search(W, n_max=5, modules=types).n_modules


@pytest.mark.parametrize(
    "extra", [["--modules", "t45,flat"], ["--ray-address", "auto", "--modules", "t45,flat"]]
)
def test_solve_refuses_workers_for_a_search_that_runs_here(extra, tmp_path, capsys):
    """CLI door: one line naming the option and why, exit code 2, as for greedy."""
    path = tmp_path / "t.npy"
    np.save(path, planted(4))
    argv = ["solve", "--task", str(path), "--method", "exhaustive", "--n-max", "5", *extra,
            "--json"]  # fmt: skip
    if "--ray-address" not in extra:
        argv += ["--workers", "2"]
    assert main(argv) == 2
    captured = capsys.readouterr()
    option = "--ray-address auto" if "--ray-address" in extra else "--workers 2"
    assert captured.err.splitlines() == [
        f"modquad: error: {option}: the exhaustive search over several module types runs in "
        "this process: workers share several --task files, or the levels of one task's "
        "one-type search"
    ]
    assert captured.out == ""


# ------------------------------------------------------------------ Ctrl-C while Ray starts (F1)
class _InterruptedRay:
    """A Ray whose ``init`` makes this process's session folder (and points ``session_latest``
    at it), then is interrupted (or fails) before it returns."""

    def __init__(self, root, exc: BaseException):
        self.root, self.exc, self.calls = root, exc, []

    def is_initialized(self) -> bool:
        return False

    def init(self, **options):
        self.calls.append("init")
        session = self.root / f"session_2026-12-01_10-00-00_{time.time_ns() % 10**6}_{os.getpid()}"
        (session / "logs").mkdir(parents=True)
        (self.root / "session_latest").symlink_to(session)
        raise self.exc

    def shutdown(self, **options):
        self.calls.append("shutdown")


@pytest.mark.parametrize("exc", [KeyboardInterrupt(), RuntimeError("raylet failed to start")])
def test_an_interrupted_ray_start_leaves_no_session_folder_of_this_run(exc, tmp_path,
                                                                      monkeypatch):  # fmt: skip
    """The folder ``ray.init`` made for this process goes, with its ``session_latest`` link, and
    Ray is shut down; this process's earlier folder and another process's stay."""
    root = tmp_path / "ray"
    earlier = root / f"session_2026-11-30_09-00-00_000001_{os.getpid()}"
    other = root / "session_2026-12-01_10-00-00_000002_1"
    for folder in (earlier, other):
        folder.mkdir(parents=True)
    monkeypatch.setenv("RAY_TMPDIR", str(tmp_path))
    monkeypatch.delenv("RAY_ADDRESS", raising=False)
    fake = _InterruptedRay(root, exc)
    monkeypatch.setattr(distributed, "import_optional", lambda name: fake)
    monkeypatch.setattr(distributed, "ray_installed", lambda: True)
    monkeypatch.setattr(distributed, "ray_problem", lambda: None, raising=False)
    with pytest.raises(type(exc)):
        with Engine(2) as engine:
            engine.start()
    assert sorted(p.name for p in root.iterdir()) == sorted([earlier.name, other.name])
    assert fake.calls[0] == "init" and "shutdown" in fake.calls


# ------------------------------------------------------------------ a Ray that cannot import (F6)
BROKEN_RAY = """
import importlib.abc, importlib.machinery, sys
class Broken(importlib.abc.MetaPathFinder, importlib.abc.Loader):
    def find_spec(self, name, path, target=None):
        if name == "ray":
            return importlib.machinery.ModuleSpec("ray", self)
    def create_module(self, spec):
        return None
    def exec_module(self, module):
        raise ImportError("libfoo.so: cannot open shared object file")
sys.meta_path.insert(0, Broken())
from modquad_gym.cli import main
for extra in ([], ["--ray-address", "127.0.0.1:6379"]):
    code = main(["solve", "--task", sys.argv[1], "--n-max", "5", "--workers", "2", "--json",
                 *extra])
    print("rc", code, file=sys.stderr)
"""


def test_a_ray_that_fails_to_import_is_named_with_the_reason(tmp_path):
    """Installed but broken (its import raises): with --workers the run goes on serially after
    a note naming the reason, as without Ray; with a cluster address it is one error line."""
    import subprocess
    import sys

    path = tmp_path / "t.npy"
    np.save(path, planted(4))
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    env.pop("RAY_ADDRESS", None)
    run = subprocess.run([sys.executable, "-c", BROKEN_RAY, str(path)], env=env, cwd=tmp_path,
                         capture_output=True, text=True, timeout=120)  # fmt: skip
    reason = "ray could not be imported: libfoo.so: cannot open shared object file"
    assert run.stderr.splitlines() == [
        f"modquad: note: {reason}; running serially",
        "rc 0",
        f"modquad: error: a Ray cluster was asked for (127.0.0.1:6379) but {reason}",
        "rc 2",
    ], run.stderr
    assert json.loads(run.stdout)["n_modules"] == 4


# ------------------------------------------------------------------ addresses (F8)
def test_an_address_that_is_not_a_string_or_a_port_out_of_range_is_refused(capsys):
    with pytest.raises(ValueError, match=r"^address 5: expected a Ray cluster address as a "
                       r"string"):  # fmt: skip
        Engine(2, 5)
    for port in ("0", "65536", "99999"):
        with pytest.raises(ValueError, match=rf"ray://127.0.0.1:{port} .*: port {port} is "
                           r"outside 1-65535$"):  # fmt: skip
            Engine(2, f"ray://127.0.0.1:{port}")
    argv = ["solve", "--task", "example:screwdriver", "--workers", "2", "--ray-address",
            "127.0.0.1:99999"]  # fmt: skip
    assert main(argv) == 2
    assert capsys.readouterr().err.splitlines() == [
        "modquad: error: Ray address 127.0.0.1:99999 (--ray-address / RAY_ADDRESS): port 99999 "
        "is outside 1-65535"
    ]
