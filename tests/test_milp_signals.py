"""A Ctrl-C or SIGTERM that lands while HiGHS solves one of the milp search's programs ends
``modquad score`` at once (one line, 130 or 143, no output folder, no lock, no worker left
running), not when HiGHS returns: Python runs signal handlers between bytecodes of the main
thread, so HiGHS called there held the signal until its time limit (one call on the mixed tier
ran 52 s). The program is made slow on purpose: a market-split instance (5 rows, 40 binaries)
that HiGHS does not finish within the search's limit, in place of the level's own. And a worker
whose caller is killed (SIGKILL: it cannot kill the worker) ends too, not at its time limit."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]

HARD = """
import numpy as np
import scipy.sparse as sp
from scipy.optimize import Bounds, LinearConstraint


def hard_program():
    rng = np.random.default_rng(0)
    A = rng.integers(0, 100, size=(5, 40)).astype(float)
    d = np.floor(A.sum(1) / 2)
    return np.zeros(40), LinearConstraint(sp.csr_matrix(A), d, d), np.ones(40), Bounds(0, 1)
"""

COMMAND = (
    HARD
    + """
import pathlib, signal, sys
from modquad_gym.search import milp_program

signal.signal(signal.SIGINT, signal.default_int_handler)  # not ignored in a background job


def hard(self, relax):
    pathlib.Path({marker!r}).touch()
    return hard_program()


milp_program.LevelProgram.build = hard
from modquad_gym.cli import main
sys.exit(main(["score", "--tier", "mixed", "--methods", "milp", "--limit", "1",
               "--no-progress", "--out", {out!r}]))
"""
)

PROMPT = 3.0
"""Seconds the command may take to end after the signal (about 0.5 s measured)."""


def _workers_left(token: str) -> list[int]:
    """Processes still running the milp worker with ``token`` in their environment."""
    found = []
    for proc in Path("/proc").glob("[0-9]*"):
        try:
            if (
                b"milp_worker.py" in (proc / "cmdline").read_bytes()
                and token.encode() in (proc / "environ").read_bytes()
            ):
                found.append(int(proc.name))
        except OSError:
            continue
    return found


@pytest.mark.skipif(not Path("/proc").is_dir(), reason="needs /proc (Linux)")
@pytest.mark.parametrize("signum, word, status", [(signal.SIGTERM, "terminated", 143),
                                                  (signal.SIGINT, "interrupted", 130)])  # fmt: skip
def test_a_signal_while_highs_solves_ends_score_at_once(tmp_path, signum, word, status):
    marker, out = tmp_path / "solving", tmp_path / "out"
    path = os.pathsep.join(filter(None, (str(ROOT), os.environ.get("PYTHONPATH"))))
    token = f"MODQUAD_SIGNAL_TEST={tmp_path}"
    env = {**os.environ, "PYTHONPATH": path, "MODQUAD_SIGNAL_TEST": str(tmp_path)}
    code = COMMAND.format(marker=str(marker), out=str(out))
    proc = subprocess.Popen([sys.executable, "-c", code], stdout=subprocess.DEVNULL,
                            stderr=subprocess.PIPE, text=True, env=env, cwd=ROOT)  # fmt: skip
    try:
        deadline = time.monotonic() + 120
        while not marker.exists() and proc.poll() is None and time.monotonic() < deadline:
            time.sleep(0.05)
        assert marker.exists(), f"no program was solved: {proc.poll()}"
        time.sleep(1.0)  # HiGHS is busy with the program
        assert proc.poll() is None
        proc.send_signal(signum)
        t0 = time.monotonic()
        try:
            proc.wait(timeout=10)
        except subprocess.TimeoutExpired:
            pytest.fail("still running 10 s after the signal")
        took = time.monotonic() - t0
    finally:
        proc.kill()
        stderr = proc.communicate()[1]
    assert took < PROMPT, f"ended {took:.1f} s after the signal"
    assert stderr.splitlines() == [f"modquad: {word}"], stderr[-2000:]
    assert proc.returncode == status
    assert not out.exists()  # neither a half-written report nor the lock
    assert not _workers_left(token)


KILLED = (
    HARD
    + """
from modquad_gym.search import milp_worker

c, cons, integrality, bounds = hard_program()
milp_worker.solve(dict(c=c, constraints=cons, integrality=integrality, bounds=bounds), 60)
"""
)


@pytest.mark.skipif(not Path("/proc").is_dir(), reason="needs /proc (Linux)")
def test_a_worker_whose_caller_is_killed_ends():
    path = os.pathsep.join(filter(None, (str(ROOT), os.environ.get("PYTHONPATH"))))
    token = f"MODQUAD_SIGNAL_TEST=killed-{os.getpid()}"
    env = {**os.environ, "PYTHONPATH": path, "MODQUAD_SIGNAL_TEST": token.split("=")[1]}
    proc = subprocess.Popen([sys.executable, "-c", KILLED], env=env, cwd=ROOT)
    try:
        deadline = time.monotonic() + 60
        while not _workers_left(token) and time.monotonic() < deadline:
            time.sleep(0.05)
        assert _workers_left(token), "no worker started"
        time.sleep(2.0)  # booted, and HiGHS busy with the program
        assert proc.poll() is None
    finally:
        proc.kill()
        proc.wait()
    t0 = time.monotonic()
    while _workers_left(token) and time.monotonic() - t0 < 5.0:
        time.sleep(0.05)
    left = _workers_left(token)
    for pid in left:
        os.kill(pid, signal.SIGKILL)
    assert not left, "the worker outlived its caller by 5 s"


def _paper_task():
    from modquad_gym.scoring.tiers import get_tier

    return get_tier("current").load_suites(limit=1)["heldout_paper"][0]


def test_a_search_waits_for_no_other_threads_worker():
    """While another thread holds the worker (a large program of another search), a small
    program of the main thread is solved in its own process, as before the worker took the main
    thread's programs: the same certified answer as alone, not a level left undecided."""
    import threading

    import modquad_gym as mq
    from modquad_gym.search import milp_worker

    task = _paper_task()
    alone = mq.make_solver("milp", n_max=7, time_limit=30).solve(task)
    held, release = threading.Event(), threading.Event()

    def hold():
        with milp_worker._lock:
            held.set()
            release.wait(60)

    thread = threading.Thread(target=hold, daemon=True)
    thread.start()
    held.wait(10)
    try:
        beside = mq.make_solver("milp", n_max=7, time_limit=30).solve(task)
    finally:
        release.set()
        thread.join()
    assert alone.certified and beside.certified
    assert beside.n_modules == alone.n_modules


def test_a_worker_that_dies_leaves_its_level_undecided(monkeypatch, capsys):
    """A worker killed or crashed mid-solve (the OOM killer, a user) is a level left undecided,
    as a time-out is: an uncertified answer by both doors, never a traceback."""
    import modquad_gym as mq
    from modquad_gym.cli import main
    from modquad_gym.search import milp_worker

    def died(kwargs, seconds):
        raise milp_worker.WorkerError("the milp worker (HiGHS) ended with code -9")

    monkeypatch.setattr(milp_worker, "busy", lambda: False)
    monkeypatch.setattr(milp_worker, "booted", lambda: True)
    monkeypatch.setattr(milp_worker, "solve", died)
    result = mq.make_solver("milp", n_max=7, time_limit=10).solve(_paper_task())
    assert result.structure is None and not result.certified
    capsys.readouterr()
    assert main(["solve", "--task", "example:paper_seed0", "--method", "milp", "--quiet"]) == 0
    assert "Traceback" not in capsys.readouterr().err
