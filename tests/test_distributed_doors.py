"""Review 23 (distributed): the exhaustive search takes workers only where it splits levels
(an engine for a search that runs in this process is refused in both doors), and Ray's start
is not the exhaustive search's ``seconds`` (``ray_start_seconds`` beside it), in both doors.
No Ray is started here: the engine's start is replaced by a pause and its tasks run serially."""

from __future__ import annotations

import json
import time

import numpy as np
import pytest

import modquad_gym.core.distributed as distributed
import modquad_gym.search.exhaustive as exhaustive
from modquad_gym.cli import main
from modquad_gym.core.distributed import Engine, run_item
from modquad_gym.geometry.module import palette
from modquad_gym.search import exhaustive_search
from modquad_gym.tasks import PlantedTasks, TaskRequirement

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
