"""Issue 12, one regression test per reproduction: every hostile input gives one line and exit 2
(or the right answer), within seconds, and checks that are meant to come before long work do."""

from __future__ import annotations

import json
import math
import os
import signal
import subprocess
import sys
import time
import zipfile
from contextlib import contextmanager
from pathlib import Path

import numpy as np
import pytest

import modquad_gym as mq
from modquad_gym import cli
from modquad_gym.tasks import TaskRequirement, load_task

ROOT = Path(__file__).resolve().parents[1]
SCREWDRIVER = ROOT / "examples" / "screwdriver.json"
ENV = {**os.environ, "OMP_NUM_THREADS": "1", "MPLBACKEND": "Agg", "PYTHONPATH": str(ROOT)}


def run_main(capsys, *argv: str) -> tuple[int, str, str]:
    """(exit code, stdout, stderr) of ``modquad argv`` in this process."""
    try:
        code = cli.main(list(argv))
    except SystemExit as exc:  # argparse errors
        code = exc.code
    out, err = capsys.readouterr()
    return code, out, err


@contextmanager
def another_run_holds(folder: Path):
    """``folder`` held as another process's run holds it: its lock file taken on a descriptor of
    its own (``flock`` refuses a second descriptor, even in one process), which this process's
    holds of the folder do not share (a second hold of one process is granted)."""
    from filelock import FileLock

    from modquad_gym.core.outputs import LOCK_NAME

    folder.mkdir(parents=True, exist_ok=True)
    with FileLock(folder / LOCK_NAME, timeout=0):
        yield folder


def run_bench(capsys, name: str, *argv: str) -> tuple[int, str, str]:
    """(exit code, stdout, stderr) of ``python -m benchmarks.NAME argv`` in this process."""
    from benchmarks.common import run_script

    code = run_script(name, list(argv))
    out, err = capsys.readouterr()
    return code, out, err


def assert_one_line_error(code: int, err: str, *names: str) -> None:
    assert code == 2, err
    assert "Traceback" not in err
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("modquad: error: "), err
    for name in names:
        assert name in lines[0], (name, err)


def assert_rejected(code: int, err: str, *names: str) -> None:
    """Exit 2 without a traceback, the last line an error naming ``names`` (one line from the
    command, or argparse's usage and error line for a malformed option)."""
    assert code == 2, err
    assert "Traceback" not in err
    last = err.strip().splitlines()[-1]
    assert "error: " in last, err
    for name in names:
        assert name in last, (name, err)


def run_cli(*argv: str, **kw) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-m", "modquad_gym.cli", *argv],
        capture_output=True,
        text=True,
        env=ENV,
        timeout=120,
        **kw,
    )


def write(path: Path, content: str | bytes) -> Path:
    if isinstance(content, bytes):
        path.write_bytes(content)
    else:
        path.write_text(content, encoding="utf-8")
    return path


# ------------------------------------------------------------------ 1. memory and time bounds
@pytest.mark.parametrize("method", ["exhaustive", "centrosymmetric", "greedy", "random"])
def test_force_impossible_task_with_huge_n_max_answers_at_once(tmp_path, capsys, method):
    """A search of n_max 10**9 on a downward force: the force bound proves it impossible at
    every size, so every search answers at once (it used to grow to 23.8 GB). A solver (the
    command line's, make_solver's) refuses an n_max beyond its method's reach when it is made."""
    from modquad_gym.search import SEARCHES

    task = write(tmp_path / "down.json", '{"wrenches": [[0, 0, -3, 0, 0, 0]]}')
    t0 = time.perf_counter()
    result = SEARCHES[method](load_task(task), n_max=10**9)
    assert result.structure is None and result.evaluated == 0
    code, _, err = run_main(
        capsys, "solve", "--task", str(task), "--n-max", "1000000000", "--method", method, "--json"
    )
    assert_one_line_error(code, err, f"--n-max 1000000000: method '{method}'")
    assert time.perf_counter() - t0 < 5


@pytest.mark.parametrize(("method", "limit"), [("exhaustive", 16)])
def test_n_max_beyond_the_search_budget_is_refused_before_work(tmp_path, capsys, method, limit):
    """A torque task with `--n-max 30` kept growing past 2.4 GB; now the levels that cannot be
    finished are refused up front, naming the limit. (The centrosymmetric search now goes to
    64 modules bounded by its time limit and a memory check: tests/test_baselines_scale.py.)"""
    task = write(tmp_path / "torque.json", '{"wrenches": [[0, 0, 3, 50, 0, 0]]}')
    t0 = time.perf_counter()
    code, _, err = run_main(
        capsys, "solve", "--task", str(task), "--n-max", "30", "--method", method, "--quiet"
    )
    assert_one_line_error(code, err, "--n-max 30", f"at most {limit}")
    assert time.perf_counter() - t0 < 5


def test_solve_memory_stays_bounded(tmp_path):
    """The reproductions of item 1 in a child process add a few hundred MB at most to the peak
    of an ordinary solve (which compiles the numba kernels when their cache is cold)."""
    if not Path("/proc/self/status").is_file():  # pragma: no cover - Linux only
        pytest.skip("needs /proc")
    down = write(tmp_path / "down.json", '{"wrenches": [[0, 0, -3, 0, 0, 0]]}')
    torque = write(tmp_path / "torque.json", '{"wrenches": [[0, 0, 3, 50, 0, 0]]}')
    plain = write(tmp_path / "plain.json", '{"wrenches": [[0, 0, 3, 0.1, 0, 0]]}')
    code = (
        "from benchmarks.measure import own_peak_mb\n"
        "from modquad_gym.cli import main\n"
        "peak = lambda: round(own_peak_mb() * 1024)  # own peak, kB: not the forking parent's\n"
        f"assert main(['solve', '--task', {str(plain)!r}, '--quiet']) == 0\n"
        f"assert main(['solve', '--task', {str(plain)!r}, '--method', 'greedy']) == 0\n"
        "base = peak()\n"
        f"assert main(['solve', '--task', {str(down)!r}, '--n-max', '128', '--quiet']) == 0\n"
        f"assert main(['solve', '--task', {str(torque)!r}, '--n-max', '30', '--method', "
        "'greedy', '--quiet']) == 0\n"
        "print(base, peak())\n"
    )
    proc = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, env=ENV, timeout=300
    )
    assert proc.returncode == 0, proc.stderr
    base_kb, peak_kb = map(int, proc.stdout.strip().splitlines()[-1].split())
    assert peak_kb - base_kb < 300 * 1024, f"peak RSS grew {(peak_kb - base_kb) / 1024:.0f} MB"
    assert peak_kb < 2048 * 1024, f"peak RSS {peak_kb / 1024:.0f} MB"


def test_n_max_16_checks_the_budget_before_work(tmp_path, capsys):
    """n_max 16 is allowed (the search stops at the first feasible level); 17 is refused before
    any level is enumerated (the default anytime search: 129)."""
    exhaustive = ("solve", "--task", str(SCREWDRIVER), "--method", "exhaustive")
    code, out, err = run_main(capsys, *exhaustive, "--n-max", "16", "--json", "--quiet")
    assert code == 0, err
    assert json.loads(out)["n_modules"] == 3
    t0 = time.perf_counter()
    code, _, err = run_main(capsys, *exhaustive, "--n-max", "17")
    assert_one_line_error(code, err, "--n-max 17: method 'exhaustive'")
    code, _, err = run_main(capsys, "solve", "--task", str(SCREWDRIVER), "--n-max", "129")
    assert_one_line_error(code, err, "--n-max 129: method 'anytime'")
    assert time.perf_counter() - t0 < 2


def test_env_with_huge_n_max_is_rejected_at_make_time():
    import gymnasium as gym

    for n_max in (129, 10**9):  # the env goes to 128 modules (the searches' limit)
        with pytest.raises(ValueError, match="n_max"):
            gym.make("ModQuadAssembly-v0", n_max=n_max)
    with pytest.raises(ValueError, match="n_directions"):
        gym.make("ModQuadAssembly-v0", n_directions=10**9)


# ------------------------------------------------------------------ 2. CSV misreads
def test_numeric_csv_header_is_refused_with_a_hint(tmp_path, capsys):
    task = write(tmp_path / "pandas.csv", "0,1,2,3,4,5\n0.8,0,3,0,0.1,0\n0,0,3.5,0,0,0.5\n")
    code, _, err = run_main(capsys, "solve", "--task", str(task), "--quiet")
    assert_one_line_error(code, err, "pandas.csv", "--csv-header")
    code, out, err = run_main(
        capsys, "solve", "--task", str(task), "--csv-header", "yes", "--json", "--quiet"
    )
    assert code == 0, err
    assert json.loads(out)["n_modules"] == 3  # the screwdriver's answer


def test_digit_separators_are_not_numbers(tmp_path, capsys):
    task = write(tmp_path / "sep.csv", "1_0,0,5,0,0,0\n")
    code, _, err = run_main(capsys, "solve", "--task", str(task))
    assert_one_line_error(code, err, "sep.csv", "1_0")


def test_utf8_bom_is_accepted(tmp_path, capsys):
    task = write(
        tmp_path / "bom.csv", "\ufefffx,fy,fz,tx,ty,tz\n0.8,0,3,0,0.1,0\n0,0,3.5,0,0,0.5\n"
    )
    code, out, err = run_main(capsys, "solve", "--task", str(task), "--json", "--quiet")
    assert code == 0, err
    assert json.loads(out)["n_modules"] == 3
    bom_json = write(tmp_path / "bom.json", "\ufeff" + SCREWDRIVER.read_text())
    assert TaskRequirement.load(bom_json).n_wrenches == 2


# ------------------------------------------------------------------ 3. outputs
def test_concurrent_saves_never_leave_a_mixed_file(tmp_path):
    """Two `task generate` runs to one --out left corrupt JSON in 3 of 40 tries: writers racing
    on one path now always leave one complete task, and a reader never sees half a file."""
    import threading

    path = tmp_path / "t.json"
    tasks = [
        TaskRequirement(np.full((200, 6), float(k)), f"writer{k}") for k in range(4)
    ]  # large enough that a plain write would be seen half done
    tasks[0].save(path)
    seen, stop = [], threading.Event()

    def write(task):
        for _ in range(15):
            task.save(path, force=True)

    def read():
        while not stop.is_set():
            seen.append(TaskRequirement.load(path).name)

    reader = threading.Thread(target=read)
    reader.start()
    writers = [threading.Thread(target=write, args=(t,)) for t in tasks]
    for w in writers:
        w.start()
    for w in writers:
        w.join()
    stop.set()
    reader.join()
    assert seen and set(seen) <= {t.name for t in tasks}
    final = TaskRequirement.load(path)
    assert final.name in {t.name for t in tasks} and final.n_wrenches == 200
    assert [p.name for p in tmp_path.iterdir()] == ["t.json"]  # no temporary files left


def test_generate_refuses_an_existing_output_unless_forced(tmp_path, capsys):
    out = tmp_path / "t.json"
    argv = ("task", "generate", "--kind", "paper", "--seed", "1", "--out", str(out))
    assert run_main(capsys, *argv)[0] == 0
    before = out.read_bytes()
    code, _, err = run_main(capsys, *argv)
    assert_one_line_error(code, err, "t.json", "--force")
    assert out.read_bytes() == before
    assert run_main(capsys, *argv, "--force")[0] == 0
    assert not [p for p in tmp_path.iterdir() if p.name.endswith(".tmp")]  # atomic: no debris


def test_show_names_the_file_it_wrote(tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    code, out, err = run_main(capsys, "show", "--cells", "[[0,0],[1,0]]", "--out", "pic")
    assert code == 0, err
    assert (tmp_path / "pic.png").is_file()
    assert "wrote pic.png" in out


# ------------------------------------------------------------------ 4. work lost at the end
def _no_simulation(monkeypatch):
    """Make any simulation or search fail loudly: the checks must come first."""
    import importlib

    sim_validate = importlib.import_module("modquad_gym.sim.validate")  # the module, not the
    # function of the same name that modquad_gym.sim re-exports

    def boom(*args, **kwargs):
        raise AssertionError("work started before the output was checked")

    monkeypatch.setattr(sim_validate, "validate", boom)
    monkeypatch.setattr("modquad_gym.cli.solve.solver", boom)


def test_validate_existing_out_is_refused_before_simulating(tmp_path, capsys, monkeypatch):
    _no_simulation(monkeypatch)
    out = tmp_path / "out"
    out.mkdir()
    (out / "report.md").write_text("an earlier report")
    t0 = time.perf_counter()
    code, _, err = run_main(capsys, "validate", "--task", str(SCREWDRIVER), "--out", str(out))
    assert_one_line_error(code, err, "report.md", "--force")
    assert time.perf_counter() - t0 < 2
    assert (out / "report.md").read_text() == "an earlier report"


def test_validate_out_under_a_file_is_refused_before_simulating(tmp_path, capsys, monkeypatch):
    _no_simulation(monkeypatch)
    blocker = write(tmp_path / "file.txt", "x")
    code, _, err = run_main(
        capsys, "validate", "--task", str(SCREWDRIVER), "--out", str(blocker / "sub")
    )
    assert_one_line_error(code, err, "--out")
    code, _, err = run_main(capsys, "validate", "--task", str(SCREWDRIVER), "--out", str(blocker))
    assert_one_line_error(code, err, "not a folder")


@pytest.mark.skipif(hasattr(os, "geteuid") and os.geteuid() == 0, reason="root ignores modes")
def test_read_only_output_folder_is_refused_before_work(tmp_path, capsys, monkeypatch):
    _no_simulation(monkeypatch)
    folder = tmp_path / "ro"
    folder.mkdir()
    folder.chmod(0o555)
    try:
        code, _, err = run_main(
            capsys, "validate", "--task", str(SCREWDRIVER), "--out", str(folder)
        )
        assert_one_line_error(code, err, "not writable")
        code, _, err = run_main(
            capsys, "task", "generate", "--kind", "paper", "--out", str(folder / "t.json")
        )
        assert_one_line_error(code, err, "ro")
    finally:
        folder.chmod(0o755)


def piped_stderr(pipeline: str) -> str:
    """The stderr of the bash ``pipeline``, ending in ``rc=N``: its first command's exit code."""
    proc = subprocess.run(
        f"{pipeline}; echo rc=${{PIPESTATUS[0]}} >&2",
        shell=True,
        executable="/bin/bash",
        capture_output=True,
        text=True,
        env=ENV,
        timeout=120,
    )
    return proc.stderr


def test_broken_pipe_is_one_line_exit_2():
    """`solve --json | head -0`: the reader is gone before the first line."""
    err = piped_stderr(
        f"{sys.executable} -m modquad_gym.cli solve --task {SCREWDRIVER} --task {SCREWDRIVER} "
        "--json --quiet | head -c 0"
    )
    assert "rc=2" in err, err
    assert "Traceback" not in err
    assert "broken pipe" in err


@pytest.mark.parametrize("lines", [1, 5000])
def test_the_scripts_stop_on_a_broken_pipe_in_one_line(lines):
    """The scripts' door (:func:`~modquad_gym.core.interrupts.run_command`, as ``python -m
    modquad_gym.scoring.seeds`` printing its report runs it) as the CLI's: a reader gone
    before the output ends (`| true`) is one line and exit 2, whether the output breaks the
    pipe while it is written or waits in the buffer until exit."""
    script = (
        "import sys; from modquad_gym.core.interrupts import run_command; "
        f"sys.exit(run_command(lambda argv: print('row\\n' * {lines}), 'prog'))"
    )
    err = piped_stderr(f'{sys.executable} -c "{script}" | true')
    assert "rc=2" in err, err
    assert "Traceback" not in err and "Exception ignored" not in err
    assert err.count("prog: error: output closed before the end (broken pipe)") == 1


def test_interrupt_exits_130_in_process(capsys, monkeypatch):
    def interrupted(*args, **kwargs):
        raise KeyboardInterrupt

    monkeypatch.setattr("modquad_gym.cli.common.load_task", interrupted)
    code, _, err = run_main(capsys, "solve", "--task", str(SCREWDRIVER))
    assert code == 130
    assert err.strip() == "modquad: interrupted"


def test_ctrl_c_exits_130(tmp_path):
    """A real SIGINT during a long search (centrosymmetric up to 21 modules on a torque task
    that no level satisfies): exit 130, one line, no traceback."""
    task = write(tmp_path / "torque.json", '{"wrenches": [[0, 0, 3, 50, 0, 0]]}')
    proc = subprocess.Popen(
        [sys.executable, "-m", "modquad_gym.cli", "solve", "--task", str(task)]
        + ["--method", "centrosymmetric", "--n-max", "21", "--quiet"],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env=ENV,
        # a job started in the background by a shell without job control inherits SIGINT
        # ignored, and Python keeps it ignored: give the child the default disposition
        preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL),
    )
    time.sleep(6)
    if proc.poll() is not None:  # pragma: no cover - finished before the signal
        pytest.skip("the search finished before the signal")
    proc.send_signal(signal.SIGINT)
    out, err = proc.communicate(timeout=60)
    assert proc.returncode == 130, err
    assert "Traceback" not in err and "interrupted" in err


# ------------------------------------------------------------------ 5. unbounded validation
@pytest.mark.parametrize(
    ("option", "value"),
    [
        ("--hover-seconds", "1e9"),
        ("--hover-seconds", "inf"),
        ("--hover-seconds", "nan"),
        ("--max-hover-wrenches", "0"),
        ("--load-ramp-seconds", "-1"),
    ],
)
def test_validate_bounds_are_checked_before_work(tmp_path, capsys, monkeypatch, option, value):
    _no_simulation(monkeypatch)
    code, _, err = run_main(
        capsys, "validate", "--task", str(SCREWDRIVER), "--out", str(tmp_path / "o"), option, value
    )
    assert_rejected(code, err, option)


# ------------------------------------------------------------------ 6. numeric range
@pytest.mark.parametrize("scale", [1e-9, 1e-6, 1e10, 1e12])
def test_scaled_task_gives_the_same_answer(tmp_path, capsys, scale):
    """Scaling a task and f_max together used to make HiGHS fail (1e-9, 1e10, 1e12) or trip the
    'exact LP rejects it' error (1e-6)."""
    task = TaskRequirement.load(SCREWDRIVER)
    path = tmp_path / "scaled.json"
    TaskRequirement(task.wrenches * scale, "scaled", f_max=task.f_max * scale).save(path)
    code, out, err = run_main(capsys, "solve", "--task", str(path), "--json", "--quiet")
    assert code == 0, err
    assert json.loads(out)["n_modules"] == 3


def test_huge_torques_and_f_max(tmp_path, capsys):
    """Torques of 1e50 are a plain infeasible answer; 1e200 and beyond a clear error (they used
    to be `RuntimeError: HiGHS failed`); f_max 1e12 (the largest) makes a small task trivially
    feasible, and 1e300 is refused by name."""
    big = write(tmp_path / "big.json", '{"wrenches": [[0, 0, 3, 1e50, 0, 0]]}')
    code, out, err = run_main(capsys, "solve", "--task", str(big), "--json", "--quiet")
    assert code == 0, err
    assert json.loads(out)["feasible"] is False
    absurd = write(tmp_path / "absurd.json", '{"wrenches": [[0, 0, 3, 1e200, 0, 0]]}')
    code, _, err = run_main(capsys, "solve", "--task", str(absurd), "--quiet")
    assert_one_line_error(code, err, "wrench row 1", "f_max")
    strong = write(tmp_path / "strong.json", '{"wrenches": [[0, 0, 3, 0, 0, 0]], "f_max": 1e12}')
    code, out, err = run_main(capsys, "solve", "--task", str(strong), "--json", "--quiet")
    assert code == 0, err
    assert json.loads(out)["n_modules"] == 1
    absurd = write(tmp_path / "strong.json", '{"wrenches": [[0, 0, 3, 0, 0, 0]], "f_max": 1e300}')
    code, _, err = run_main(capsys, "solve", "--task", str(absurd), "--quiet")
    assert_one_line_error(code, err, "f_max = 1e+300 is outside 1e-300..1e12")
    A = mq.Structure([(0, 0), (1, 0), (0, 1)]).configuration_matrix()
    with np.errstate(all="raise"):  # no overflow anywhere on the way
        assert not mq.feasible(A, [[0, 0, 3, 1e200, 0, 0]]).any()
        assert mq.margin(A, [[0, 0, 3, 1e200, 0, 0]])[0] < -1e199


# ------------------------------------------------------------------ 7. hostile files
def test_400_digit_integer(tmp_path, capsys):
    task = write(tmp_path / "digits.json", '{"wrenches": [[' + "9" * 400 + ", 0, 0, 0, 0, 0]]}")
    code, _, err = run_main(capsys, "solve", "--task", str(task))
    assert_one_line_error(code, err, "digits.json")


def test_deeply_nested_json(tmp_path, capsys):
    task = write(tmp_path / "deep.json", '{"wrenches": ' + "[" * 100_000 + "]" * 100_000 + "}")
    code, _, err = run_main(capsys, "solve", "--task", str(task))
    assert_one_line_error(code, err, "deep.json", "nested")


def test_npz_named_npy(tmp_path, capsys):
    path = tmp_path / "archive.npy"
    with path.open("wb") as fh:
        np.savez(fh, wrenches=np.zeros((2, 6)))
    code, _, err = run_main(capsys, "solve", "--task", str(path))
    assert_one_line_error(code, err, "archive.npy", ".npz")


def _zip(path: Path, members: dict[str, str]) -> Path:
    with zipfile.ZipFile(path, "w") as z:
        for name, text in members.items():
            z.writestr(name, text)
    return path


@pytest.mark.parametrize(
    "make",
    [
        lambda p: write(p, b"PK\x03\x04 not really a zip"),
        lambda p: _zip(p, {"readme.txt": "no model data"}),  # SB3: AssertionError
        lambda p: _zip(p, {"data": "{not json"}),
        lambda p: _zip(p, {"data": "{}"}),
    ],
    ids=["not-a-zip", "no-data", "bad-json", "empty-data"],
)
def test_bad_model_zip_is_one_line(tmp_path, capsys, make):
    pytest.importorskip("sb3_contrib")
    model = make(tmp_path / "model.zip")
    code, _, err = run_main(
        capsys, "solve", "--task", str(SCREWDRIVER), "--method", "ppo", "--model", str(model)
    )
    assert_one_line_error(code, err, "model.zip")


# ------------------------------------------------------------------ 8. small ones
def test_show_cells_not_a_list(capsys, tmp_path):
    code, _, err = run_main(capsys, "show", "--cells", "5", "--out", str(tmp_path / "c.png"))
    assert_one_line_error(code, err, "--cells")


@pytest.mark.parametrize(
    "argv",
    [
        ("paper", "--seeds", "0"),
        ("oracle", "--structures", "0"),
        ("search", "--tasks", "0"),
        ("oracle", "--repeats", "0"),
        ("env", "--sizes", "0"),
        ("scaling", "--n-max", "7"),
        ("level_bounds", "--n-max", "0"),
    ],
)
def test_bench_counts_are_rejected_before_work(capsys, tmp_path, monkeypatch, argv):
    """`python -m benchmarks.paper --seeds 0` and friends used to crash after working
    (IndexError); now the option is an argparse error, exit 2, before anything runs or is
    written."""
    monkeypatch.chdir(tmp_path)
    t0 = time.perf_counter()
    code, out, err = run_bench(capsys, *argv)
    assert_rejected(code, err, argv[1], f"got {argv[-1]}")
    assert time.perf_counter() - t0 < 5
    assert not list(tmp_path.iterdir())  # nothing written


def test_api_rejects_hostile_arguments():
    A = mq.Structure([(0, 0), (1, 0)]).configuration_matrix()
    W = [[0, 0, 3, 0, 0, 0]]
    for f_max in ("2", True):
        with pytest.raises(ValueError, match="f_max"):
            mq.feasible(A, W, f_max=f_max)
    with pytest.raises(ValueError, match="n_max"):
        mq.exhaustive_search(W, n_max=True)
    with pytest.raises(ValueError, match="eta"):
        mq.TModule(eta=100)
    with pytest.raises(ValueError, match="no wrenches"):
        mq.exhaustive_search(np.zeros((0, 6)), n_max=2)
    with pytest.raises(ValueError, match="cell #1 "):  # 1-based, as task-file rows
        mq.Structure([(math.inf, 0)])
