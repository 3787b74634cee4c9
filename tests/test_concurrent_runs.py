"""Runs at once and what they leave behind: a second run into an output folder another run holds
is refused at once (``modquad score``, the seeds and suites scripts, the benchmarks), a training
run's TensorBoard events stay in the log folder it claims, learning without TensorBoard leaves no
``SB3-*`` folder, a file that appears during ``solve --export`` is refused in the command's
words, and an embedded Ray's session folder goes with it."""

from __future__ import annotations

import importlib
import json
from pathlib import Path

import pytest
from test_hardening import another_run_holds, assert_rejected, run_bench, run_main

from modquad_gym.core.interrupts import run_command
from modquad_gym.core.outputs import LOCK_NAME, claim_output_dir


def _no_work(*args, **kwargs):
    raise AssertionError("the work started although another run holds the folder")


def _refused_once(code: int, err: str, folder: Path) -> None:
    """Exit 2, one line (no usage) naming the folder and the run that holds it."""
    lines = err.strip().splitlines()
    assert code == 2 and len(lines) == 1, err
    assert str(folder) in lines[0] and "being written by another run" in lines[0], err


# ----------------------------------------------------------------- one run at a time per folder
def test_score_refuses_an_out_folder_another_run_holds_before_any_work(tmp_path, capsys,
                                                                       monkeypatch):  # fmt: skip
    """A second ``modquad score --out R`` while a run holds R: exit 2 and one line naming R;
    nothing is scored or written (it used to score, replace the first run's report and exit
    0). Once the holder is gone the same command runs."""
    from modquad_gym.scoring import agents

    out = tmp_path / "R"
    argv = ["score", "--methods", "greedy", "--limit", "1", "--no-progress", "--out", str(out)]
    with monkeypatch.context() as m, another_run_holds(out):  # as another run's score holds it
        m.setattr(agents, "run_benchmark", _no_work)
        code, _, err = run_main(capsys, *argv)
        assert sorted(p.name for p in out.iterdir()) == [LOCK_NAME]
    _refused_once(code, err, out)
    code, printed, _ = run_main(capsys, *argv)
    assert code == 0 and "greedy" in (out / "benchmark.csv").read_text()
    assert not (out / LOCK_NAME).exists()  # let go at the end


def test_the_seeds_report_refuses_a_folder_another_run_holds(tmp_path, capsys, monkeypatch):
    from modquad_gym.scoring import seeds

    monkeypatch.setattr(seeds, "find_runs", lambda folders: {"seed-0": tmp_path / "m.zip"})
    monkeypatch.setattr(seeds, "check_runs", lambda *args: None)
    monkeypatch.setattr(seeds, "scored", _no_work)
    out = tmp_path / "report"
    with another_run_holds(out):
        code = run_command(seeds.main, "seeds", [str(tmp_path), "--out", str(out)])
    _refused_once(code, capsys.readouterr().err.removeprefix("seeds: error: "), out)


def test_the_suites_script_refuses_a_folder_another_run_holds(tmp_path, capsys, monkeypatch):
    from modquad_gym.scoring import suites

    monkeypatch.setattr(suites, "build_suite", _no_work)
    with another_run_holds(tmp_path):
        code = run_command(suites.main, "suites", ["--out", str(tmp_path)])
    _refused_once(code, capsys.readouterr().err, tmp_path)


def test_a_benchmark_holds_its_out_folder_until_it_ends(tmp_path, capsys, monkeypatch):
    """``python -m benchmarks.codebase --out D`` while another run holds D: refused at once
    (argparse's usage and error line, exit 2), nothing written; alone it runs, holding D while
    it writes and letting go at the end."""
    from benchmarks import codebase

    with another_run_holds(tmp_path):
        code, _, err = run_bench(capsys, "codebase", "--out", str(tmp_path))
    assert_rejected(code, err, "--out", str(tmp_path), "being written by another run")
    assert not (tmp_path / "codebase.md").exists()
    held, real = [], codebase.write_report

    def write_report(*args, **kwargs):
        held.append((tmp_path / LOCK_NAME).exists())
        return real(*args, **kwargs)

    monkeypatch.setattr(codebase, "write_report", write_report)
    assert run_bench(capsys, "codebase", "--out", str(tmp_path))[0] == 0
    assert held == [True] and (tmp_path / "codebase.md").is_file()
    assert not (tmp_path / LOCK_NAME).exists()


@pytest.mark.parametrize("script", ["scale_suites", "leaderboard"])
def test_benchmarks_that_check_their_own_folders_hold_them(tmp_path, capsys, monkeypatch,
                                                           script):  # fmt: skip
    module = importlib.import_module(f"benchmarks.{script}")
    monkeypatch.setattr(module, "build_band" if script == "scale_suites" else "build", _no_work)
    argv = {"scale_suites": ["--bands", "16"], "leaderboard": ["--tiers", "current"]}[script]
    with another_run_holds(tmp_path):
        code, _, err = run_bench(capsys, script, *argv, "--out", str(tmp_path))
    assert_rejected(code, err, str(tmp_path), "being written by another run")


def test_a_held_folder_goes_again_when_the_run_left_it_empty(tmp_path):
    """The folders a run created to hold its output go when it wrote nothing there (a refused
    option after the hold, an interruption); a folder that was there, or that has files, stays."""
    from modquad_gym.core.outputs import hold_output_dir

    with hold_output_dir(tmp_path / "a" / "b") as folder:
        assert (folder / LOCK_NAME).is_file()
    assert list(tmp_path.iterdir()) == []
    with hold_output_dir(tmp_path / "a" / "b") as folder:
        (folder / "x.md").write_text("x")
    assert [p.name for p in (tmp_path / "a" / "b").iterdir()] == ["x.md"]
    (tmp_path / "c").mkdir()
    with hold_output_dir(tmp_path / "c"):
        pass
    assert (tmp_path / "c").is_dir()


def test_a_second_hold_of_a_folder_this_process_holds_is_granted(tmp_path):
    """A hold of a folder the same process already holds (``train.py --report-dir`` equal to its
    ``--out``: the report's hold inside the run's claim; or another thread) is granted, not
    refused as "another run"; the lock stays until the last hold ends, and another process is
    refused meanwhile."""
    import os
    import subprocess
    import sys
    import threading

    from modquad_gym.core.outputs import hold_output_dir

    folder = tmp_path / "n1"
    probe = ("import sys; from modquad_gym.core.outputs import hold_output_dir\n"
             "try:\n    with hold_output_dir(sys.argv[1]): print('held')\n"
             "except ValueError as e: print(e)")  # fmt: skip

    def other_process() -> str:
        return subprocess.run([sys.executable, "-c", probe, str(folder)], capture_output=True,
                              text=True, check=True).stdout  # fmt: skip

    granted = []

    def in_a_thread() -> None:
        with hold_output_dir(os.path.relpath(folder)) as held:  # another spelling of it
            granted.append(held)

    with claim_output_dir(folder, ("a.csv",)) as claim:
        with hold_output_dir(folder, ("b.csv",)) as inner:
            granted.append(inner)
            thread = threading.Thread(target=in_a_thread)
            thread.start()
            thread.join()
        assert len(granted) == 2 and (folder / LOCK_NAME).is_file()  # the outer hold goes on
        assert "being written by another run" in other_process()
        claim.path("a.csv").write_text("a")
    assert not (folder / LOCK_NAME).exists() and other_process().strip() == "held"


def test_a_nested_claim_keeps_the_records_of_the_claim_around_it(tmp_path):
    """A claim inside a claim of the same folder (one process) adds to the same manifest and
    removes nothing of the outer run's, even with force."""
    from modquad_gym.core.outputs import MANIFEST_NAME

    with claim_output_dir(tmp_path, force=True) as outer:
        outer.path("a.csv").write_text("a")
        with claim_output_dir(tmp_path, ("b.csv",), force=True) as inner:
            inner.path("b.csv").write_text("b")
        outer.path("c.csv").write_text("c")
    assert (tmp_path / "a.csv").is_file()
    assert json.loads((tmp_path / MANIFEST_NAME).read_text()) == ["a.csv", "b.csv", "c.csv"]


def test_holding_a_path_through_dot_dot_leaves_no_folder_behind(tmp_path, monkeypatch):
    """``x/../y`` is the folder ``y``: ``x`` is neither created nor left behind."""
    from modquad_gym.core.outputs import hold_output_dir

    monkeypatch.chdir(tmp_path)
    with hold_output_dir("x/../y", ("a.csv",)):
        pass
    assert list(tmp_path.iterdir()) == []
    with hold_output_dir("x/../y", ("a.csv",)) as folder:
        (folder / "a.csv").write_text("a")
    assert [p.name for p in tmp_path.iterdir()] == ["y"] and (tmp_path / "y" / "a.csv").is_file()


# ------------------------------------------------------------------ train.py's TensorBoard events
def test_ppo_events_stay_in_the_claimed_log_folder_and_force_replaces_them(tmp_path):
    """PPO's TensorBoard events go to ``<log folder>/ppo``, recorded in its manifest: nothing
    lies beside the log folder (SB3's naming used to add ``<name>_1``, ``_2``, ... there, held by
    no run and removed by no ``--force``), and a ``--force`` rerun replaces them."""
    pytest.importorskip("sb3_contrib")
    pytest.importorskip("tensorboard")
    from test_agents import TINY_N_MAX, _tiny_tasks

    from agents.cli import main as train
    from modquad_gym.core.outputs import MANIFEST_NAME
    from modquad_gym.tasks import save_suite

    suite = save_suite(_tiny_tasks(), tmp_path / "tiny.json")
    tb, out = tmp_path / "tb", tmp_path / "runs" / "a"
    argv = ["--task-source", str(suite), "--n-max", str(TINY_N_MAX), "--out", str(out),
            "--tensorboard", str(tb), "--timesteps", "256", "--bc-epochs", "0", "--n-eval", "2",
            "--no-report", "--no-progress"]  # fmt: skip
    log = tb / "runs-a"

    def events() -> list[str]:
        assert [p.name for p in tb.iterdir()] == [log.name]  # no sibling folder
        return [p.name for p in (log / "ppo").glob("events.out.tfevents.*")]

    assert train(argv) == 0
    (first,) = events()
    assert f"ppo/{first}" in json.loads((log / MANIFEST_NAME).read_text())
    assert train([*argv, "--force"]) == 0
    (second,) = events()  # the earlier run's curves are gone, not shown beside the new ones
    assert second != first and f"ppo/{second}" in json.loads((log / MANIFEST_NAME).read_text())


def _tiny_train_argv(tmp_path) -> list[str]:
    from test_agents import TINY_N_MAX, _tiny_tasks

    from modquad_gym.tasks import save_suite

    suite = save_suite(_tiny_tasks(), tmp_path / "tiny.json")
    return ["--task-source", str(suite), "--n-max", str(TINY_N_MAX), "--out",
            str(tmp_path / "runs" / "a"), "--tensorboard", str(tmp_path / "tb"), "--timesteps",
            "256", "--bc-epochs", "0", "--n-eval", "2", "--no-progress"]  # fmt: skip


@pytest.mark.parametrize("where", ["out", "log"])
def test_a_report_into_the_runs_own_folder_is_written(tmp_path, monkeypatch, capsys, where):
    """``train.py --report-dir`` equal to its ``--out`` or its log folder: the report is written
    there after training (the report's hold of the folder the run holds was refused as "another
    run", exit 2 after the whole training); a second run without ``--force`` is refused before
    any work, naming ``--report-dir``."""
    pytest.importorskip("sb3_contrib")
    from agents import cli
    from modquad_gym.scoring import agents

    out, log = tmp_path / "runs" / "a", tmp_path / "tb" / "runs-a"
    report = out if where == "out" else log
    monkeypatch.setattr(cli, "train", lambda config: config.out / "model.zip")  # no training

    def greedy_only(args, tier):  # the report of a search: no model to load
        args.agents, args.setup = {}, {}
        return ["greedy"]

    monkeypatch.setattr(agents, "chosen_methods", greedy_only)
    argv = [*_tiny_train_argv(tmp_path), "--quick", "--report-dir", str(report)]
    assert cli.main(argv) == 0
    assert "greedy" in (report / "benchmark.csv").read_text()
    assert (report / "benchmark.md").is_file()
    assert not (report / LOCK_NAME).exists()
    monkeypatch.setattr(cli, "train", _no_work)
    capsys.readouterr()
    code = run_command(cli.main, "python train.py", argv)
    err = capsys.readouterr().err
    assert code == 2 and "--report-dir" in err and "already holds" in err, err


def test_force_clears_the_log_folders_of_a_killed_run(tmp_path, monkeypatch):
    """A run killed by SIGKILL never recorded its PPO events (the manifest is completed when the
    run ends): ``--force`` still replaces the log folder's ``ppo/``, ``bc/`` and ``train/``, so
    TensorBoard shows one run, not two mixed in one curve; the user's other files stay."""
    from agents import cli

    log = tmp_path / "tb" / "runs-a"
    leftovers = [log / "ppo" / "events.out.tfevents.1.host.1.0", log / "bc" / "events.x",
                 log / "train" / "checkpoints" / "ppo_256_steps.zip"]  # fmt: skip
    for path in [*leftovers, log / "notes.txt"]:
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text("killed run")
    seen = []

    def run(args):
        seen.append(sorted(p.relative_to(log).as_posix() for p in log.rglob("*")))
        return 0

    monkeypatch.setattr(cli, "run", run)
    assert cli.main([*_tiny_train_argv(tmp_path), "--force", "--no-report"]) == 0
    assert seen == [[".modquad.lock", "notes.txt"]], seen
    assert (log / "notes.txt").read_text() == "killed run"


# ------------------------------------------------------------------ SB3 without TensorBoard
def test_the_ppo_update_benchmark_leaves_no_sb3_folder(tmp_path, monkeypatch):
    """``learn`` without a logger of ours made an empty ``SB3-<date>`` folder in the temporary
    folder at every call (``python -m benchmarks.env``; 352 of them in /tmp): now none."""
    pytest.importorskip("sb3_contrib")
    import tempfile

    from benchmarks.env_measure import ppo_update_seconds

    monkeypatch.delenv("SB3_LOGDIR", raising=False)  # as outside the tests
    monkeypatch.setattr(tempfile, "tempdir", str(tmp_path / "tmp"))
    (tmp_path / "tmp").mkdir()
    update, rollout = ppo_update_seconds(0)
    assert update > 0 and rollout > 0
    assert list((tmp_path / "tmp").glob("SB3-*")) == []  # (torch puts its own cache there)


# ------------------------------------------------------------------ a file that appears meanwhile
@pytest.mark.parametrize(
    "command, option, step",
    [("solve", "--export", "modquad_gym.cli.solve.print_result"),
     ("export", "--out", "modquad_gym.cli.export.found_structure")],
)  # fmt: skip
def test_an_export_file_that_appears_during_the_search_is_refused_in_the_commands_words(
    tmp_path, capsys, monkeypatch, command, option, step
):
    """Another program writes the file while the search runs: it is kept, and the refusal names
    the option and ``--force`` (it said ``path: ... (use force=True ...)``, the Python
    function's words)."""
    module, name = step.rsplit(".", 1)
    real = getattr(importlib.import_module(module), name)
    out = tmp_path / "s.json"

    def meanwhile(*args, **kwargs):
        found = real(*args, **kwargs)
        out.write_text('{"mine": 1}')
        return found

    monkeypatch.setattr(step, meanwhile)
    argv = [command, "--task", "example:screwdriver", option, str(out), "--quiet"]
    code, _, err = run_main(capsys, *argv)
    assert code == 2 and err.strip().splitlines() == [
        f"modquad: error: {option}: {out} exists (use --force to replace it)"
    ], err
    assert out.read_text() == '{"mine": 1}'


# ------------------------------------------------------------------ an embedded Ray's session
def test_an_embedded_ray_leaves_no_session_folder(monkeypatch):
    """``--workers N`` starts a Ray of its own: its ``session_<date>_<pid>`` folder (logs,
    sockets; ~200 KB) is removed once Ray has shut down (180 of them had piled up in /tmp/ray)."""
    pytest.importorskip("ray")
    from modquad_gym.core.distributed import Engine

    sessions = _session_of_each_init(monkeypatch)
    with Engine(2) as engine:
        assert engine.map(abs, [-1, -2, -3]) == [1, 2, 3]
        (session,) = sessions
        assert session.is_dir()
    assert not session.exists()
    latest = session.parent / "session_latest"
    assert not (latest.is_symlink() and Path(latest.readlink()) == session)


def test_a_ray_that_cannot_wait_for_its_processes_keeps_its_folder(tmp_path):
    """Where ``ray.shutdown`` cannot wait for Ray's processes (older Ray), one of them could
    still write into the folder: it is left as Ray leaves it; so is a folder Ray did not name."""
    from modquad_gym.core.ray_session import shutdown

    calls = []

    class OldRay:
        @staticmethod
        def shutdown(_exiting_interpreter: bool = False):
            calls.append("shutdown")

    class NewRay:
        @staticmethod
        def shutdown(*, wait_for_processes: bool = False, _exiting_interpreter: bool = False):
            calls.append(wait_for_processes)

    session = tmp_path / "session_2026-01-01_00-00-00_000000_1"
    (session / "logs").mkdir(parents=True)
    shutdown(OldRay, session)
    shutdown(NewRay, tmp_path)  # not a session folder
    shutdown(NewRay, None)  # a cluster the user connected to
    assert calls == ["shutdown", False, False] and session.is_dir() and tmp_path.is_dir()
    shutdown(NewRay, session)
    assert calls[-1] is True and not session.exists()


def _session_of_each_init(monkeypatch) -> list[Path]:
    """The session folder of every ``ray.init`` from now on."""
    import ray

    sessions, real = [], ray.init

    def init(*args, **kwargs):
        context = real(*args, **kwargs)
        sessions.append(Path(context.address_info["session_dir"]))
        return context

    monkeypatch.setattr(ray, "init", init)
    return sessions


def test_an_embedded_ray_keeps_its_session_folder_when_a_worker_died(monkeypatch, capsys):
    """A worker that died: Ray's error says to read its logs, so the session folder (which holds
    them) stays, and a note names where; a clean run's goes (above)."""
    import os
    import shutil

    pytest.importorskip("ray")
    from modquad_gym.core.distributed import Failed, map_tasks

    def die_on_one(x: int) -> int:  # a closure: shipped to the workers by value
        if x == 1:
            os._exit(3)
        return x

    sessions = _session_of_each_init(monkeypatch)
    results = map_tasks(die_on_one, [0, 1], workers=2, catch=True, max_retries=0)
    (session,) = sessions
    try:
        assert results[0] == 0 and isinstance(results[1], Failed), results
        assert (session / "logs").is_dir() and list((session / "logs").glob("*worker*"))
        err = capsys.readouterr().err
        assert str(session / "logs") in err, err
    finally:
        shutil.rmtree(session, ignore_errors=True)


def test_the_distributed_benchmark_removes_its_ray_sessions_outside_its_timing(monkeypatch):
    """``benchmarks.distributed`` starts its Rays itself: each one's session folder goes too, and
    the wait for Ray's processes to exit (which that needs) is not counted in ``wall_s``."""
    ray = pytest.importorskip("ray")
    import functools
    import time

    from benchmarks.distributed import _timed

    sessions = _session_of_each_init(monkeypatch)
    stops, real = [], ray.shutdown

    @functools.wraps(real)
    def shutdown(*args, **kwargs):
        stops.append(time.perf_counter())
        return real(*args, **kwargs)

    monkeypatch.setattr(ray, "shutdown", shutdown)
    t0 = time.perf_counter()
    wall, startup, result = _timed(1, lambda workers: workers)
    assert result == 2 and 0 < startup <= wall
    (session,) = sessions
    assert not session.exists()
    assert stops and t0 + wall <= stops[0]  # the timing ended before the shutdown began


@pytest.mark.parametrize(
    "argv, option, step, name",
    [(["task", "generate", "--kind", "paper", "--seed", "4"], "--out",
      "modquad_gym.tasks.generated_task", "t.json"),
     (["task", "motion", "--kind", "hover"], "--out", "modquad_gym.cli.task_motion.motion_task",
      "m.json"),
     (["solve", "--task", "example:screwdriver", "--quiet"], "--certificate",
      "modquad_gym.cli.solve.print_result", "c.json"),
     (["solve", "--task", "example:screwdriver", "--quiet"], "--certificate",
      "modquad_gym.search.certificates.make", "c.json"),  # while the proof is made
     (["show", "--task", "example:screwdriver", "--quiet"], "--out", "modquad_gym.cli.show.shown",
      "p.png"),
     (["show", "--task", "example:screwdriver", "--quiet"], "--out",
      "modquad_gym.viz.drawing.draw_structure", "p.png"),  # while the picture is drawn
     (["show", "--task", "example:screwdriver", "--quiet"], "--html",
      "modquad_gym.cli.show.shown", "p.html")],
)  # fmt: skip
def test_an_output_file_that_appears_during_the_work_is_refused_in_the_commands_words(
    tmp_path, capsys, monkeypatch, argv, option, step, name
):
    """``task --out``, ``solve --certificate``, ``show --out/--html``: a file another program
    writes while the command works (its search, the proof, the drawing) is kept, and the
    refusal names the option and ``--force`` (it said ``path: ... (use force=True ...)``; a
    certificate or a picture made meanwhile replaced it)."""
    pytest.importorskip({"--out": "matplotlib", "--html": "plotly"}[option] if "show" in argv
                        else "json")  # fmt: skip
    module, attr = step.rsplit(".", 1)
    real = getattr(importlib.import_module(module), attr)
    out = tmp_path / name

    def meanwhile(*args, **kwargs):
        found = real(*args, **kwargs)
        out.write_text('{"mine": 1}')
        return found

    monkeypatch.setattr(step, meanwhile)
    code, _, err = run_main(capsys, *argv, option, str(out))
    assert code == 2 and err.strip().splitlines() == [
        f"modquad: error: {option}: {out} exists (use --force to replace it)"
    ], err
    assert out.read_text() == '{"mine": 1}'
