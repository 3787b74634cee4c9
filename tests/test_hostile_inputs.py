"""The tools around the product (training, expert iteration, the benchmarks, validate) under
hostile input, as ``modquad`` is: bad options refused in one line before any work, a second run
into the same output refused, ``--force`` that removes only what the command wrote, Ctrl-C and
SIGTERM ending in one line with the finished work kept and no process left behind."""

from __future__ import annotations

import json
import math
import os
import runpy
import signal
import subprocess
import sys
import time
from pathlib import Path
from types import SimpleNamespace

import pytest
from test_hardening import another_run_holds

import modquad_gym as mq
from benchmarks.common import run_command, run_main
from modquad_gym.core.interrupts import (
    Terminated,
    deferred_signals,
    exit_status,
    keep_sigterm,
    sigterm_as_interrupt,
    stop_line,
)
from modquad_gym.core.outputs import (
    LOCK_NAME,
    MANIFEST_NAME,
    OutputError,
    check_output_file,
    claim_output_dir,
    json_ready,
    write_text,
)

ROOT = Path(__file__).resolve().parents[1]
ENV = {**os.environ, "PYTHONPATH": str(ROOT), "OMP_NUM_THREADS": "1"}


def _exits_2(capsys, main, argv, match: str) -> str:
    """``main(argv)`` stops with exit status 2 and one error line holding ``match``."""
    with pytest.raises(SystemExit) as stop:
        main(argv)
    assert stop.value.code == 2
    err = capsys.readouterr().err
    last = err.strip().splitlines()[-1]
    assert match in last and "Traceback" not in err, err
    return last


# --- outputs: names, locks, --force -----------------------------------------------------------


def test_a_legal_long_name_is_written_and_an_illegal_one_refused_before_work(tmp_path):
    long = tmp_path / ("a" * 250 + ".md")  # 253 bytes: legal; the old temporary name was not
    write_text(long, "x")
    assert long.read_text() == "x" and os.listdir(tmp_path) == [long.name]
    with pytest.raises(OutputError, match="bytes long"):
        check_output_file(tmp_path / ("b" * 300 + ".md"))


def test_a_claimed_folder_refuses_a_second_run_and_force_removes_only_recorded_files(tmp_path):
    out = tmp_path / "out"
    with claim_output_dir(out, ("report.md",)) as claim:
        write_text(claim.path("report.md"), "first")
        write_text(claim.path("round-3/model.zip"), "old round")
    assert not (out / LOCK_NAME).exists()  # the lock goes with the run
    with another_run_holds(out), pytest.raises(OutputError, match="another run"):
        with claim_output_dir(out, ("report.md",), force=True):
            pass
    assert (out / "round-3" / "model.zip").read_text() == "old round"  # nothing removed
    (out / "notes.txt").write_text("the user's")
    with pytest.raises(OutputError, match="already holds report.md"):
        with claim_output_dir(out, ("report.md",)):
            pass
    with claim_output_dir(out, ("report.md",), force=True):
        assert sorted(p.name for p in out.iterdir()) == [LOCK_NAME, "notes.txt"]
    assert (out / "notes.txt").read_text() == "the user's" and not (out / MANIFEST_NAME).exists()


def test_json_ready_turns_non_finite_numbers_into_null():
    record = {"a": math.inf, "b": [1.0, -math.inf, {"c": math.nan}], "d": (2, "x")}
    assert json_ready(record) == {"a": None, "b": [1.0, None, {"c": None}], "d": [2, "x"]}


def test_validate_json_of_a_dynamic_task_is_strict_json(tmp_path, capsys, monkeypatch):
    """A flight record with an unlimited step headroom prints null, never bare Infinity."""
    from modquad_gym import dynamics as dy
    from modquad_gym.cli import main
    from modquad_gym.sim import validate_track

    def fake(structure, task, **kw):
        return {"track_max_position_error_m": 0.001, "hover_unknown_load_segments": [
            {"segment": 0, "step_headroom": math.inf}]}  # fmt: skip

    monkeypatch.setattr(validate_track, "validate_trajectory", fake)
    path = dy.line(0.5, 1.0, rate=20).save(tmp_path / "line.json")
    argv = ["validate", "--task", str(path), "--method", "exhaustive", "--json"]
    assert main([*argv, "--max-hover-wrenches", "3", "--out", str(tmp_path / "v")]) == 0
    line = capsys.readouterr().out.strip().splitlines()[-1]

    def refuse(name):
        raise ValueError(f"not JSON: {name}")

    record = json.loads(line, parse_constant=refuse)
    assert record["hover_unknown_load_segments"][0]["step_headroom"] is None


def test_validate_refuses_an_out_folder_another_run_holds(tmp_path, capsys):
    from modquad_gym.cli import main

    with another_run_holds(tmp_path / "v"):
        argv = ["validate", "--task", "example:screwdriver", "--out", str(tmp_path / "v")]
        assert main(argv) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert "another run" in err[-1] and len([e for e in err if "error" in e]) == 1


# --- small library fixes ------------------------------------------------------------------


def test_a_value_just_past_a_bound_is_shown_as_given(capsys):
    from modquad_gym.core.validation import check_real

    with pytest.raises(ValueError, match=r"must be <= 1, got 1\.0000001$"):
        check_real(1.0000001, "--detection-delay", 0.0, 1.0)
    with pytest.raises(ValueError, match=r"must be >= 0, got -1$"):
        check_real(-1, "x", 0.0)


def test_greedy_start_may_be_a_generator():
    from modquad_gym.tasks import load_task

    task = load_task("example:screwdriver")
    cells = [(0, 0), (1, 0)]
    from_list = mq.greedy_search(task, n_max=8, start=cells)
    from_generator = mq.greedy_search(task, n_max=8, start=(c for c in cells))
    assert from_generator.structure.cells == from_list.structure.cells
    with pytest.raises(ValueError, match="start"):
        mq.greedy_search(task, n_max=8, start=[5])


# --- Ctrl-C and SIGTERM -------------------------------------------------------------------


def test_sigterm_becomes_one_line_and_exit_143_and_survives_a_library_handler(capsys):
    with sigterm_as_interrupt():
        with pytest.raises(Terminated):
            os.kill(os.getpid(), signal.SIGTERM)
            time.sleep(5)
        with pytest.raises(Terminated):  # held back while a library replaces the handler
            with keep_sigterm():
                signal.signal(signal.SIGTERM, lambda signum, frame: sys.exit(signum))  # as Ray
                os.kill(os.getpid(), signal.SIGTERM)
            time.sleep(5)
        started = []
        with pytest.raises(Terminated):  # deferred: the step in the block finishes first
            with deferred_signals():
                os.kill(os.getpid(), signal.SIGTERM)
                time.sleep(0.2)
                started.append(True)
            time.sleep(5)
        assert started == [True]

    def stopped(argv):
        raise KeyboardInterrupt

    assert run_command(stopped, "python train.py", []) == 130
    assert capsys.readouterr().err == "python train.py: interrupted\n"
    assert exit_status(Terminated()) == 143 and stop_line("x", Terminated()) == "x: terminated"


class _FakeRay:
    """What Ray does to SIGTERM: ``init`` installs a handler that calls ``sys.exit(15)``
    (``kill`` sends SIGTERM meanwhile), ``shutdown`` resets it to the default."""

    def __init__(self, kill: bool = False):
        self.kill, self.up = kill, False

    def is_initialized(self):
        return self.up

    def init(self, **kwargs):
        signal.signal(signal.SIGTERM, lambda signum, frame: sys.exit(signum))
        self.up = True
        if self.kill:
            os.kill(os.getpid(), signal.SIGTERM)
            time.sleep(0.5)

    def shutdown(self):
        signal.signal(signal.SIGTERM, signal.SIG_DFL)
        self.up = False


@pytest.mark.parametrize("kill", [False, True])
def test_ray_starting_and_stopping_keeps_the_sigterm_handler(monkeypatch, kill):
    from modquad_gym.core import distributed, interrupts

    monkeypatch.setattr(distributed, "import_optional", lambda name: _FakeRay(kill))
    monkeypatch.setattr(distributed, "ray_installed", lambda: True)
    monkeypatch.delenv("RAY_ADDRESS", raising=False)
    with sigterm_as_interrupt():
        engine = distributed.Engine(2)
        with engine:
            if kill:  # Ray's handler ran during init: still one Terminated, not sys.exit(15)
                with pytest.raises(Terminated):
                    engine.start()
            else:
                engine.start()
            assert signal.getsignal(signal.SIGTERM) is interrupts._raise_terminated
        assert signal.getsignal(signal.SIGTERM) is interrupts._raise_terminated


def _default_sigint() -> None:
    """A job started in the background by a shell without job control inherits SIGINT ignored,
    and Python keeps it ignored: give the child the default disposition."""
    signal.signal(signal.SIGINT, signal.SIG_DFL)


_JOBS = """
import sys, time
from benchmarks.common import run_command
from benchmarks.measure import fresh_map

def main(argv):
    fresh_map(time.sleep, [(0.01,), (120,), (120,)], 2,
              on_result=lambda i, r: print("finished", i, flush=True))

sys.exit(run_command(main, "jobs"))
"""


def _children(pid: int) -> list[int]:
    out = subprocess.run(["pgrep", "-P", str(pid)], capture_output=True, text=True).stdout
    return [int(p) for p in out.split()]


def _gone(pids: list[int], seconds: float = 10.0) -> bool:
    end = time.monotonic() + seconds
    while time.monotonic() < end:
        if not any(Path(f"/proc/{p}").exists() and "Z" not in _state(p) for p in pids):
            return True
        time.sleep(0.1)
    return False


def _state(pid: int) -> str:
    try:
        return Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
    except (OSError, IndexError):
        return "Z"


@pytest.mark.skipif(not Path("/proc").is_dir(), reason="reads /proc")
@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM, signal.SIGKILL])
def test_stopping_fresh_processes_keeps_finished_work_and_leaves_no_process(sig):
    """The benchmarks' fresh processes (benchmarks.scale's jobs): a finished job was reported
    at once; Ctrl-C or SIGTERM ends with one line and no traceback; even SIGKILL of the main
    process leaves no job running."""
    proc = subprocess.Popen([sys.executable, "-c", _JOBS], env=ENV, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, start_new_session=True,
                            preexec_fn=_default_sigint)  # fmt: skip
    try:
        assert proc.stdout.readline().strip() == "finished 0"
        end = time.monotonic() + 30
        while len(_children(proc.pid)) < 2 and time.monotonic() < end:  # the two sleepers
            time.sleep(0.1)
        jobs = _children(proc.pid)
        assert jobs
        os.kill(proc.pid, sig)
        _, err = proc.communicate(timeout=30)
    finally:
        proc.kill()
    assert _gone(jobs), "a job process outlived the main one"
    if sig == signal.SIGKILL:
        return
    assert proc.returncode == (130 if sig == signal.SIGINT else 143)
    assert err.strip() == ("jobs: interrupted" if sig == signal.SIGINT else "jobs: terminated")


# --- benchmarks ---------------------------------------------------------------------------


def test_helper_modules_run_as_scripts_say_so(capsys):
    from benchmarks.common import scripts

    commands = scripts()
    helpers = [p for p in (ROOT / "benchmarks").glob("*.py")
               if p.stem not in commands and not p.stem.startswith("_")]  # fmt: skip
    assert {"common", "leaderboard_page"} <= {p.stem for p in helpers}
    for path in helpers:
        capsys.readouterr()
        with pytest.raises(SystemExit) as done:
            runpy.run_path(str(path), run_name="__main__")
        out = capsys.readouterr()
        assert done.value.code == 2 and not out.out, path.stem
        assert "helper module" in out.err and len(out.err.splitlines()) == 1, out.err


@pytest.mark.parametrize(
    "argv, match",
    [
        (["--per-suite", "0"], "--per-suite"),
        (["--time-limit", "-1"], "--time-limit"),
        (["--time-limit", "nan"], "--time-limit"),
    ],
)
def test_milp_refuses_bad_options_before_work(tmp_path, capsys, argv, match):
    from benchmarks import milp

    _exits_2(capsys, milp.main, [*argv, "--out", str(tmp_path / "m")], match)
    assert not (tmp_path / "m").exists()


@pytest.mark.parametrize(
    "script, argv, match",
    [
        ("faults", ["--n-max", "0"], "argument --n-max: must be in 1.."),
        ("faults", ["--time-limit", "nan"], "argument --time-limit: expected a finite number"),
        ("faults", ["--rotor2-time-limit", "-1"], "argument --rotor2-time-limit: must lie in"),
        ("faults", ["--intact-seconds", "0"], "--intact-seconds must lie in (0, 3600], got 0"),
        ("faults", ["--skip", "3", "--per-suite", "3"], "--skip must be below --per-suite (3)"),
        ("fault_rotor2", ["--n-max", "0"], "argument --n-max: must be in 1.."),
        ("fault_rotor2", ["--time-limit", "nan"], "argument --time-limit: expected a finite"),
        ("dynamics", ["--n-max", "0"], "argument --n-max: must be in 1.."),
        ("dynamics", ["--push-forces", "nan"], "argument --push-forces: expected a finite"),
    ],
)
def test_fault_and_dynamics_benchmarks_name_the_bad_option(tmp_path, capsys, script, argv, match):
    import importlib

    main = importlib.import_module(f"benchmarks.{script}").main
    _exits_2(capsys, main, [*argv, "--out", str(tmp_path / "o")], match)
    assert not (tmp_path / "o").exists()


def test_reports_are_replaced_only_with_force(tmp_path, capsys):
    from benchmarks import faults, leaderboard, milp, scale_suites, startup

    (tmp_path / "report.md").write_text("mine")
    for main in (milp.main, startup.main):
        _exits_2(capsys, main, ["--out", str(tmp_path)], "use --force")
    _exits_2(capsys, faults.main, ["--out", str(tmp_path)], "use --force")
    _exits_2(capsys, leaderboard.main, [], "use --force")  # the committed pages
    shipped = scale_suites.suite_path(16)
    before = shipped.stat().st_mtime_ns
    _exits_2(capsys, scale_suites.main, ["--bands", "16", "--out", str(shipped.parent)], "--force")
    assert shipped.stat().st_mtime_ns == before and (tmp_path / "report.md").read_text() == "mine"
    with pytest.raises(SystemExit):  # the default --out is not the shipped folder
        scale_suites.main(["--help"])
    assert "default results/scale_suites" in " ".join(capsys.readouterr().out.split())


def test_faults_oracle_only_needs_earlier_rows_and_no_fly(tmp_path, capsys):
    from benchmarks import faults

    out = tmp_path / "new"
    _exits_2(capsys, faults.main, ["--fly", "--oracle-only", "--out", str(out)], "--fly")
    _exits_2(capsys, faults.main, ["--oracle-only", "--out", str(out)], "no faults.csv")
    _exits_2(capsys, faults.main, ["--update", "--out", str(out)], "no faults.csv")
    _exits_2(capsys, faults.main, ["--skip", "3", "--per-suite", "3", "--out", str(out)], "--skip")
    assert not out.exists()


def test_faults_update_replaces_only_the_rows_it_makes():
    from benchmarks.faults_measure import merged

    def row(suite, task, design, modules):
        return {"suite": suite, "task": task, "design": design, "modules": modules}

    old = [row("heldout_paper", "p0", "intact", 5), row("heldout_paper", "p0", "rotor2", 7),
           row("fault_rotor", "f0", "rotor2", 9)]  # fmt: skip
    new = [row("heldout_paper", "p0", "rotor2", 6), row("fault_rotor", "f0", "intact", 6)]
    assert [(r["suite"], r["design"], r["modules"]) for r in merged(old, new)] == [
        ("fault_rotor", "intact", 6), ("fault_rotor", "rotor2", 9),
        ("heldout_paper", "intact", 5), ("heldout_paper", "rotor2", 6),
    ]  # fmt: skip


def test_scale_refuses_a_missing_model_and_a_held_out_folder(tmp_path, capsys):
    from benchmarks import scale

    base = ["--bands", "16", "--per-family", "1", "--time-limit", "1"]
    argv = [*base, "--methods", "ppo", "--model", str(tmp_path / "missing.zip")]
    assert run_main(scale.main, "scale", [*argv, "--out", str(tmp_path / "a")]) == 2
    assert "--model" in capsys.readouterr().err
    argv = [*base, "--methods", "greedy", "--model", str(tmp_path / "missing.zip")]
    assert run_main(scale.main, "scale", [*argv, "--out", str(tmp_path / "a")]) == 2
    assert "no learned method" in capsys.readouterr().err
    with another_run_holds(tmp_path / "b"):
        argv = [*base, "--methods", "greedy", "--out", str(tmp_path / "b")]
        assert run_main(scale.main, "scale", argv) == 2
    assert "another run" in capsys.readouterr().err


def test_scale_refuses_foreign_rows_in_one_line(tmp_path, capsys):
    """--rows of another benchmark (missing columns), a row cut short, with a word for a
    number, NaN seconds or zero modules, or a binary file: exit 2, one line naming the file
    and the 1-based row; nothing written."""
    from benchmarks import scale

    header = ",".join(scale.ROW_COLUMNS) + "\n"
    good = "16,planted,t,greedy,16,15,16,True,0.0,1,0.24,197,\n"
    cases = {"other.csv": ("band,method\n16,greedy\n", "its header"),
             "short.csv": (header + good + "16,planted,t,greedy\n", "row 2"),
             "word.csv": (header + good.replace(",16,True", ",x,True"), "row 1"),
             "nan.csv": (header + good.replace("0.24", "nan"), "row 1"),
             "zero.csv": (header + good.replace(",16,True", ",0,True"), "row 1"),
             "binary.csv": (None, "not a CSV file")}  # fmt: skip
    for name, (text, message) in cases.items():
        path = tmp_path / name
        path.write_text(text) if text else path.write_bytes(bytes(range(128, 256)))
        out = tmp_path / f"out-{name}"
        assert run_main(scale.main, "scale", ["--rows", str(path), "--out", str(out)]) == 2
        err = capsys.readouterr().err.strip()
        assert len(err.splitlines()) == 1 and f"{name}: {message}" in err, err
        assert not out.exists()
    (tmp_path / "good.csv").write_text(header + good)
    assert scale.read_rows(tmp_path / "good.csv")[0]["found"] == 16


def test_scale_keeps_the_rows_of_finished_runs_when_interrupted(monkeypatch):
    from benchmarks import scale

    tasks = [SimpleNamespace(name=f"t{i}", meta={"band": 16, "family": "planted",
                                                "planted": 16, "lower_bound": 14})
             for i in range(2)]  # fmt: skip
    answer = {"found": 15, "proved": 15, "verified": True, "seconds": 1.0, "peak_MB": 1.0,
              "note": ""}  # fmt: skip

    def stopped_midway(fn, jobs, workers, on_result, on_part):
        on_part(0, answer)  # greedy's first task
        on_result(0, [answer, answer])  # greedy done
        on_part(1, answer)  # beam's first task, then Ctrl-C
        raise KeyboardInterrupt

    monkeypatch.setattr(scale, "fresh_map", stopped_midway)
    monkeypatch.setattr(scale, "band_tasks", lambda *a: tasks)
    kept = []
    args = SimpleNamespace(bands=[16], families=["planted"], per_family=2, validation=False,
                           time_limit=1.0, seed=0, model=None, methods=["greedy", "beam"],
                           workers=1)  # fmt: skip
    with pytest.raises(KeyboardInterrupt):
        scale.measure(args, kept.append)
    assert [(r["task"], r["method"]) for r in kept[0]] == [("t0", "greedy")]
    assert [(r["task"], r["method"], r["lower_bound"]) for r in kept[-1]] == [
        ("t0", "greedy", 15),
        ("t0", "beam", 15),
        ("t1", "greedy", 15),
    ]


def _answer_in_parts(n: int) -> str:
    """A job of :func:`benchmarks.measure.fresh_map` that hands back ``n`` parts first."""
    from benchmarks.measure import report_part

    for k in range(n):
        report_part(k)
    return "done"


def test_a_fresh_job_hands_back_parts_as_they_come():
    from benchmarks.measure import fresh_map

    parts, results = [], []
    out = fresh_map(_answer_in_parts, [(3,)], 1, lambda i, r: results.append((i, r)),
                    on_part=lambda i, v: parts.append((i, v)))  # fmt: skip
    assert out == ["done"] and results == [(0, "done")] and parts == [(0, 0), (0, 1), (0, 2)]


# --- expert iteration and train.py ----------------------------------------------------------


@pytest.mark.parametrize(
    "argv, match",
    [
        (["--rounds", "-1"], "--rounds"),
        (["--rounds", "0"], "--rounds"),
        (["--epochs", "-1"], "--epochs"),
        (["--tasks", "0"], "--tasks"),
        (["--workers", "0"], "--workers"),
        (["--n-max", "0"], "--n-max"),
        (["--search-seconds", "nan"], "--search-seconds"),
        (["--budget", "0"], "--budget"),
        (["--seed", "-1"], "--seed"),
        (["--per-family", "0"], "--per-family"),
        (["--model", "missing.zip"], "--model missing.zip"),
        (["--draws", "mixed:8-32"], "--draws"),
        (["--draws", "torque:40-20"], "--draws"),
        (["--draws", "planted:\u00b2-5"], "sizes LOW-HIGH"),
        (["--bands", "16", "24", "16"], "argument --bands: 16 is given twice"),
        (["--model", "."], "error: --model .: a folder"),
    ],
)
def test_expert_iteration_refuses_bad_options_before_work(tmp_path, capsys, argv, match):
    pytest.importorskip("sb3_contrib")
    from agents.expert_iteration import main

    out = tmp_path / "exit"
    _exits_2(capsys, main, [*argv, "--out", str(out)], match)
    assert not out.exists()


def test_expert_iteration_force_replaces_only_its_own_files(tmp_path, monkeypatch, capsys):
    pytest.importorskip("sb3_contrib")
    from agents import expert_iteration as exit_

    def fake_run(args):  # one round's files, as run() writes them
        for name in ("model.zip", "model_actor.npz", "config.json"):
            write_text(args.claim.path(f"round-1/{name}"), name)
        write_text(args.claim.path("labels.csv"), "round\n1\n")
        args.labels = [{"round": 1, "search": 9, "guided": 9, "ppo": 9, "target": 9}]
        return [{"round": 1, "model": "m", "states": 1}]

    monkeypatch.setattr(exit_, "run", fake_run)
    out = tmp_path / "exit"
    assert exit_.main(["--rounds", "1", "--replay", "0", "--out", str(out)]) == 0
    (out / "my_notes.txt").write_text("keep me")
    _exits_2(capsys, exit_.main, ["--rounds", "1", "--out", str(out)], "--force")
    assert exit_.main(["--rounds", "1", "--out", str(out), "--force"]) == 0
    assert (out / "my_notes.txt").read_text() == "keep me"
    assert {"report.md", "rows.csv", "model.zip", "round-1"} <= {p.name for p in out.iterdir()}


def test_train_refuses_a_run_folder_another_run_holds(tmp_path):
    pytest.importorskip("sb3_contrib")
    from agents.cli import main

    run = tmp_path / "run"
    argv = ["--quick", "--no-report", "--no-progress", "--out", str(run), "--tensorboard",
            str(tmp_path / "tb")]  # fmt: skip
    with another_run_holds(run):
        with pytest.raises(OutputError, match="another run"):
            main(argv)
    assert not (run / "model.zip").exists()


def test_scale_models_refuses_foreign_reuse_rows_and_bad_options(tmp_path, capsys):
    """--reuse of another benchmark's rows (a superset of the columns), an empty, binary or
    NUL-holding file, or rows with values it never writes (no module count, NaN seconds, another
    family, an extra field) is refused naming the file and row; --time-limit outside
    (0, 86400] and a band or family given twice are refused before any work: exit 2, one line."""
    from benchmarks.common import run_script
    from benchmarks.scale_models import read_rows

    header = "band,family,task,method,found,seconds\n"
    cases = {"scale.csv": ("band,family,task,method,planted,found,seconds\n", "its header"),
             "empty.csv": ("", "its header"), "nul.csv": ("band,family\0,task\n", "its header"),
             "zero.csv": (header + "16,torque,a,greedy,0,1.0\n", "row 1"),
             "nan.csv": (header + "16,torque,a,greedy,3,1.0\n16,torque,b,greedy,,nan\n", "row 2"),
             "family.csv": (header + "16,mixed,a,greedy,3,1.0\n", "row 1"),
             "extra.csv": (header + "16,torque,a,greedy,3,1.0,x\n", "row 1")}  # fmt: skip
    for name, (text, message) in cases.items():
        (tmp_path / name).write_text(text)
        with pytest.raises(ValueError, match=f"--reuse .*{name}: {message}"):
            read_rows(tmp_path / name)
    (tmp_path / "binary.csv").write_bytes(bytes(range(128, 256)))
    with pytest.raises(ValueError, match="binary.csv: not a CSV file"):
        read_rows(tmp_path / "binary.csv")
    (tmp_path / "good.csv").write_text(header + "16,torque,a,greedy,,0.5\n")
    assert read_rows(tmp_path / "good.csv")[0]["found"] is None
    out = tmp_path / "out"
    twice = [(["--bands", "16", "16"], "argument --bands: 16 is given twice"),
             (["--families", "torque", "torque"], "--families: torque is given twice")]  # fmt: skip
    for argv, message in ((["--time-limit", "nan"], "--time-limit"),
                          (["--time-limit", "-1"], "--time-limit"), *twice):  # fmt: skip
        assert run_script("scale_models", ["--models", "m=x.zip", *argv, "--out", str(out)]) == 2
        err = capsys.readouterr().err.strip()
        assert message in err.splitlines()[-1] and "Traceback" not in err, err
    assert not out.exists()
