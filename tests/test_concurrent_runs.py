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
from test_hardening import assert_rejected, run_bench, run_main

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
    with monkeypatch.context() as m, claim_output_dir(out):  # as another run's score holds it
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
    with claim_output_dir(out):
        code = run_command(seeds.main, "seeds", [str(tmp_path), "--out", str(out)])
    _refused_once(code, capsys.readouterr().err.removeprefix("seeds: error: "), out)


def test_the_suites_script_refuses_a_folder_another_run_holds(tmp_path, capsys, monkeypatch):
    from modquad_gym.scoring import suites

    monkeypatch.setattr(suites, "build_suite", _no_work)
    with claim_output_dir(tmp_path):
        code = run_command(suites.main, "suites", ["--out", str(tmp_path)])
    _refused_once(code, capsys.readouterr().err, tmp_path)


def test_a_benchmark_holds_its_out_folder_until_it_ends(tmp_path, capsys, monkeypatch):
    """``python -m benchmarks.codebase --out D`` while another run holds D: refused at once
    (argparse's usage and error line, exit 2), nothing written; alone it runs, holding D while
    it writes and letting go at the end."""
    from benchmarks import codebase

    with claim_output_dir(tmp_path):
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
    with claim_output_dir(tmp_path):
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
    ray = pytest.importorskip("ray")
    from modquad_gym.core.distributed import Engine

    sessions, real = [], ray.init

    def init(*args, **kwargs):
        context = real(*args, **kwargs)
        sessions.append(Path(context.address_info["session_dir"]))
        return context

    monkeypatch.setattr(ray, "init", init)
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
