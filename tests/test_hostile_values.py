"""Hostile values at every door (review 21, fuzz): a benchmark report for any size list, no
benchmark read that waits on a pipe, f_max checked alike by every door, a model path that is not
a regular file said so, numbers strict everywhere (ASCII digits, no ``_``), an empty option value
refused as given, Python arguments named in their errors, and motion edge values refused naming
the option typed.

A command line case that the old code would have run (a benchmark, a training) ends with an
unknown option: argparse refuses that only after it has converted every value, so a value refused
by its type stops first, naming its option, and otherwise the run stops there, before any work."""

from __future__ import annotations

import argparse
import os
import threading
from contextlib import contextmanager
from pathlib import Path

import numpy as np
import pytest

import modquad_gym as mq
from benchmarks.common import run_script
from modquad_gym import cli
from modquad_gym.policy.models import DEFAULT_MODEL

POISON = "--no-such-option-here"
"""Ends a command line the old code would have run: refused after every value is converted."""


def run_modquad(capsys, *argv: str) -> tuple[int, str]:
    """(exit code, stderr) of ``modquad argv`` in this process."""
    try:
        code = cli.main(list(argv))
    except SystemExit as exc:  # argparse: usage and one error line
        code = exc.code
    return code, capsys.readouterr().err


def error_line(code: int, err: str, prefix: str) -> str:
    """The one error line of a refused command (exit 2, no traceback; argparse's usage aside)."""
    assert code == 2 and "Traceback" not in err, err
    *before, line = err.strip().splitlines()
    assert all(b.startswith(("usage:", " ")) for b in before), err
    assert line.startswith(prefix), err
    return line


# --- 1. benchmarks.oracle reports any size list -------------------------------------------------
def oracle_row(modules: int) -> dict:
    return {"workload": "boundary", "modules": modules, "rotors_m": 4 * modules, "method": "auto",
            "structures": 1, "decisions_per_s": 1e5, "decisions_per_cpu_s": 1e5,
            "margins_per_s": 1e4, "decisions_vs_scipy": 60.0, "decisions_vs_cvxpy": np.nan,
            "margins_vs_scipy": 5.0, "feasible_share": 0.5, "hrep_build_ms": np.nan,
            "hrep_facets": 0}  # fmt: skip


@pytest.mark.parametrize("sizes, lacking", [((12,), (7, 64)), ((20, 32), (7, 64)), ((64,), (7,))])
def test_the_oracle_report_says_which_goals_a_size_list_leaves_unmeasured(tmp_path, sizes, lacking):
    """No goal of issue 3 (7 modules) or 26 (64) measured: the report is written all the same,
    naming the size each missing goal needs (it crashed in markdown_table([]), after the run)."""
    from benchmarks import oracle

    rows = [oracle_row(n) for n in sizes]
    goals = oracle.evaluate_goals(rows, {}, 1.0, 10)
    oracle.write_report(rows, goals, 1, 4, 0, 1, "0.00", tmp_path, sizes)
    text = (tmp_path / "oracle_benchmark.md").read_text()
    goals_part = text.split("## Goals")[1].split("## Measurements")[0]
    for n in lacking:
        assert f"give {n} in --modules" in goals_part, goals_part
    assert ("issue 26" in goals_part.split("Not measured")[0]) == (64 in sizes), goals_part
    assert (tmp_path / "oracle_benchmark.csv").is_file()


# --- 2. benchmark inputs read as regular files -----------------------------------------------
@contextmanager
def unblocked(fifo: Path, after: float = 15.0):
    """Yields a list that is non-empty when a reader of ``fifo`` had to be set free (after
    ``after`` seconds, a writer opens and closes it: the reader sees an empty file)."""
    freed: list[bool] = []
    done = threading.Event()

    def guard() -> None:
        if done.wait(after):
            return
        freed.append(True)
        while not done.wait(0.05):
            try:
                os.close(os.open(fifo, os.O_WRONLY | os.O_NONBLOCK))
            except OSError:  # no reader waiting yet
                pass

    thread = threading.Thread(target=guard, daemon=True)
    thread.start()
    try:
        yield freed
    finally:
        done.set()
        thread.join()


def _fifo_inputs(tmp: Path, fifo: Path) -> dict[str, list[str]]:
    """Each benchmark's command line reading ``fifo`` through a file option (or inside the
    folder it names)."""
    (tmp / "seeds").mkdir()
    os.mkfifo(tmp / "seeds" / "seeds.csv")
    (tmp / "res" / "agent").mkdir(parents=True)
    (tmp / "res" / "agent" / "benchmark.csv").write_text("suite,task\n")
    (tmp / "res" / "agent" / "benchmark_bars.png").write_bytes(b"")
    os.mkfifo(tmp / "res" / "agent" / "benchmark.md")
    out = ["--out", str(tmp / "out")]
    return {
        "fault_detector --faults": ["--faults", str(fifo), *out],
        "fallback --rows": ["--rows", str(fifo), *out],
        "prune --rows": ["--rows", str(fifo), *out],
        "scale --rows": ["--rows", str(fifo), *out],
        "scale_seeds --rows": ["--rows", str(fifo), *out],
        "scale_models --reuse": ["--reuse", str(fifo), "--models", f"m={DEFAULT_MODEL}", *out],
        "seeds_rerender FOLDER": [str(tmp / "seeds")],
        "figures --results": ["--results", str(tmp / "res"), "--force"],
    }


READERS = ["fault_detector --faults", "fallback --rows", "prune --rows", "scale --rows",
           "scale_seeds --rows", "scale_models --reuse", "seeds_rerender FOLDER",
           "figures --results"]  # fmt: skip


@pytest.mark.parametrize("case", READERS)
def test_a_benchmark_refuses_a_pipe_at_once(tmp_path, capsys, case):
    """A FIFO where a benchmark reads an earlier run's file: refused in one line naming the
    option and the file (exit 2), never waited on (the old code blocked until a writer came)."""
    if case == "scale_models --reuse":
        pytest.importorskip("torch")
    fifo = tmp_path / "pipe.csv"
    os.mkfifo(fifo)
    argv = _fifo_inputs(tmp_path, fifo)[case]
    name, option = case.split()
    with unblocked(fifo) as freed, unblocked(tmp_path / "seeds" / "seeds.csv"):
        with unblocked(tmp_path / "res" / "agent" / "benchmark.md"):
            code = run_script(name, argv)
    err = capsys.readouterr().err
    assert not freed, "the benchmark waited on the pipe"
    line = error_line(code, err, f"python -m benchmarks.{name}: error: ")
    assert "not a regular file" in line and (option == "--results" or option in line), line


# --- 3. f_max: the same range and scale at every door ----------------------------------------
S3 = [(0, 0), (1, 0), (0, 1)]
W1 = [[0.0, 0.0, 1.0, 0.0, 0.0, 0.0]]


def _sim(name: str):
    pytest.importorskip("mujoco")
    import importlib

    return importlib.import_module(f"modquad_gym.sim.{name}")


F_MAX_DOORS = {
    "TaskRequirement": lambda v: mq.TaskRequirement(W1, f_max=v),
    "with_f_max": lambda v: mq.TaskRequirement(W1).with_f_max(v),
    "validate": lambda v: _sim("validate").validate(mq.Structure(S3), mq.TaskRequirement(W1),
                                                    f_max=v, render=False),  # fmt: skip
    "validate(array)": lambda v: _sim("validate").validate(mq.Structure(S3), np.array(W1),
                                                           f_max=v, render=False),  # fmt: skip
    "build_model": lambda v: _sim("model").build_model(mq.Structure(S3), v),
    "run_bench": lambda v: _sim("wrench_stand").run_bench(mq.Structure(S3), np.array(W1), v),
    "HoverConfig": lambda v: _sim("hover").HoverConfig(f_max=v),
    "worst_failure": lambda v: _sim("fault_flight").worst_failure(
        mq.Structure(S3), np.array(W1), v, "rotor"),
    "fly_with_failure": lambda v: _sim("fault_flight").fly_with_failure(
        mq.Structure(S3), np.array(W1), "rotor", f_max=v),
    "projection_vertices": lambda v: __import__(
        "modquad_gym.viz.zonotope", fromlist=["x"]).projection_vertices(
        mq.Structure(S3).configuration_matrix(), "force", v),
}  # fmt: skip


@pytest.mark.parametrize("f_max", [1e-320, 1e30])
@pytest.mark.parametrize("door", list(F_MAX_DOORS))
def test_every_door_taking_f_max_refuses_one_outside_the_range(door, f_max):
    """f_max = 1e-320 (MuJoCo simulated nonsense through validate) and 1e30 are outside
    1e-300..1e12, in the words of export, the searches, the task files and the environment."""
    with pytest.raises(ValueError, match=r"^f_max = .* is outside 1e-300\.\.1e12 "):
        F_MAX_DOORS[door](f_max)


@pytest.mark.parametrize("door", ["validate", "validate(array)", "fly_with_failure"])
def test_a_flight_refuses_wrenches_beyond_the_scale_of_its_f_max(door):
    """f_max = 1e-300 and a 1 N wrench: the searches' scale check, naming f_max (validate
    failed in HiGHS, blaming the matrix A)."""
    with pytest.raises(ValueError, match=r"^wrench row 1 .* with f_max = 1e-300 is beyond"):
        F_MAX_DOORS[door](1e-300)


# --- 4. a model path that is not a regular file -------------------------------------------------
@pytest.fixture()
def special(tmp_path):
    """A device and a pipe: paths that exist but are no regular file."""
    fifo = tmp_path / "model.zip"
    os.mkfifo(fifo)
    return {"device": Path("/dev/null"), "pipe": fifo}


@pytest.mark.parametrize("kind", ["device", "pipe"])
def test_a_model_that_is_not_a_regular_file_is_said_so(special, capsys, kind):
    from modquad_gym.policy.models import model_file

    path = special[kind]
    with pytest.raises(ValueError, match=f"^--model {path}: not a regular file"):
        model_file(path)
    code, err = run_modquad(capsys, "solve", "--task", "example:screwdriver", "--method", "ppo",
                            "--model", str(path))  # fmt: skip
    line = error_line(code, err, "modquad: error: ")
    assert f"--model {path}: not a regular file" in line, line


@pytest.mark.parametrize("option", ["--resume", "--init-from"])
def test_train_says_a_start_model_is_not_a_regular_file(special, tmp_path, capsys, option):
    pytest.importorskip("sb3_contrib")
    from agents.cli import parse_args

    argv = ["--out", str(tmp_path / "run"), "--no-report", "--tensorboard", str(tmp_path / "tb"),
            option, str(special["pipe"])]  # fmt: skip
    with pytest.raises(SystemExit) as exc:
        parse_args(argv)
    line = error_line(exc.value.code, capsys.readouterr().err, "python train.py: error: ")
    assert f"{option} {special['pipe']}: not a regular file" in line, line


# --- 5. numbers: ASCII digits, no separators, at every text door ------------------------------
NUMBERS = [
    (["solve", "--task", "example:screwdriver", "--n-max", "١٢"], "--n-max"),
    (["solve", "--task", "example:screwdriver", "--time-limit", "١٢"], "--time-limit"),
    (["task", "generate", "--kind", "paper", "--seed", "١٢", "--out", "{tmp}/g.json"], "--seed"),
    (["score", "--methods", "greedy", "--limit", "١٢", "--out", "{tmp}/s", POISON], "--limit"),
    (["solve", "--task", "example:screwdriver", "--method", "beam", "--option",
      "beam_width=1_000"], "--option beam_width=1_000"),
    (["solve", "--task", "example:screwdriver", "--method", "genetic", "--option",
      "generations=١٢"], "--option generations"),
    (["solve", "--task", "example:screwdriver", "--method", "genetic", "--option",
      "penalty=1_0"], "--option penalty"),
    (["solve", "--task", "example:screwdriver", "--method", "ppo-k²"], "--method"),
    (["solve", "--task", "example:screwdriver", "--method", "ppo-k١٢"], "--method"),
    (["solve", "--task", "example:screwdriver", "--method", "ppo-guided-b²"], "--method"),
    (["task", "motion", "--kind", "hover", "--payload-mass", "1", "--payload-offset", "0,١,0",
      "--out", "{tmp}/m.json"], "--payload-offset"),
]  # fmt: skip


@pytest.mark.parametrize("argv, option", NUMBERS, ids=[f"{o} {a[a.index(o.split()[0]) + 1]}"
                                                         for a, o in NUMBERS])  # fmt: skip
def test_numbers_in_other_scripts_or_with_separators_are_refused(tmp_path, capsys, argv, option):
    """``١٢`` (Arabic-Indic digits), ``²`` and ``1_000`` are no numbers on the command line, as
    in task files: one line naming the option (they were read as 12 and 1000)."""
    argv = [a.replace("{tmp}", str(tmp_path)) for a in argv]
    code, err = run_modquad(capsys, *argv)
    line = error_line(code, err, ("modquad: error: ", "modquad "))
    assert option in line, line
    assert POISON not in line, line  # refused by the value's own rule
    if option == "--method":  # not int()'s "invalid literal for int() with base 10: '²'"
        assert "bad method" in line and "int()" not in line, line


def test_the_python_doors_read_numbers_by_the_same_rule():
    from benchmarks.oracle import sizes_option
    from modquad_gym.core.options import parse_integer, parse_real

    for text in ("١٢", "1_0", "²", "0x10", "nan", ""):
        with pytest.raises(ValueError, match="expected an integer"):
            parse_integer(text)
    for text in ("١.5", "1_0.5", "inf", "1e999", ""):
        with pytest.raises(ValueError, match="expected a finite number"):
            parse_real(text)
    assert parse_integer(" -12 ") == -12 and parse_real("+.5e1") == 5.0
    with pytest.raises(ValueError, match="bad method 'ppo-k²'"):
        mq.make_solver("ppo-k²")
    with pytest.raises(argparse.ArgumentTypeError, match="sizes from 7 to 64"):
        sizes_option("١٢")


def test_derivative_agreement_counts_are_strict(capsys):
    code = run_script("derivative_agreement", ["--draws", "1_000", POISON])
    line = error_line(code, capsys.readouterr().err, "python -m benchmarks.derivative_agreement")
    assert "argument --draws: expected an integer, got '1_000'" in line, line


# --- 6. an empty value is not the option left out ---------------------------------------------
EMPTY_MODQUAD = [
    ["show", "--cells", "", "--task", "example:screwdriver", "--out", "{tmp}/s.png"],
    ["export", "--cells", "", "--format", "json", "--out", "{tmp}/e.json"],
    ["score", "--tier", "", "--methods", "greedy", "--limit", "1", "--out", "{tmp}/s"],
    ["solve", "--task", "example:screwdriver", "--method", "anytime", "--workers", "2",
     "--ray-address", ""],
    ["task", "motion", "--kind", "hover", "--payload-mass", "1", "--payload-offset", "",
     "--out", "{tmp}/m.json"],
]  # fmt: skip

EMPTY_BENCHMARKS = [
    ("figures", ["--results", ""]),
    ("fallback", ["--rows", ""]),
    ("fault_detector", ["--faults", ""]),
    ("prune", ["--rows", ""]),
    ("scale", ["--model", ""]),
    ("scale_models", ["--reuse", "", "--models", "m=x.zip"]),
    ("leaderboard", ["--solver", "", "--out", "{tmp}/l"]),
    ("oracle", ["--out", ""]),
]


def _flag(argv: list[str]) -> str:
    return argv[argv.index("") - 1]


@pytest.mark.parametrize("argv", EMPTY_MODQUAD, ids=[_flag(a) for a in EMPTY_MODQUAD])
def test_modquad_refuses_an_empty_value(tmp_path, capsys, argv):
    argv = [a.replace("{tmp}", str(tmp_path)) for a in argv]
    code, err = run_modquad(capsys, *argv, POISON)
    line = error_line(code, err, "modquad ")
    assert f"argument {_flag(argv)}: an empty value" in line, line


@pytest.mark.parametrize("name, argv", EMPTY_BENCHMARKS, ids=[n for n, _ in EMPTY_BENCHMARKS])
def test_a_benchmark_refuses_an_empty_path_or_value(tmp_path, capsys, monkeypatch, name, argv):
    monkeypatch.chdir(tmp_path)  # what an empty path would have named
    argv = [a.replace("{tmp}", str(tmp_path)) for a in argv]
    code = run_script(name, [*argv, POISON])
    line = error_line(code, capsys.readouterr().err, f"python -m benchmarks.{name}: error: ")
    assert f"argument {_flag(argv)}: an empty" in line, line


def test_train_refuses_an_empty_task_source(tmp_path, capsys):
    from agents.cli import parse_args

    argv = ["--out", str(tmp_path / "run"), "--no-report", "--tensorboard", str(tmp_path / "tb"),
            "--task-source", ""]  # fmt: skip
    with pytest.raises(SystemExit) as exc:
        parse_args(argv)
    line = error_line(exc.value.code, capsys.readouterr().err, "python train.py")
    assert "argument --task-source: an empty value" in line, line


def test_score_options_refuse_an_empty_tier_from_python():
    from modquad_gym.scoring.options import score_options

    with pytest.raises(ValueError, match="^--tier: an empty value"):
        score_options(tier="")


# --- 7. Python arguments named in their errors --------------------------------------------------
def _gym(**kwargs):
    import gymnasium as gym

    return gym.make("ModQuadAssembly-v0", **kwargs)


def _validate(**kwargs):
    return _sim("validate").validate(mq.Structure(S3), mq.TaskRequirement(W1), **kwargs)


def _generated(**kwargs):
    from modquad_gym.tasks.specs import generated_task

    return generated_task(**{"kind": "planted", **kwargs})


def _export(fmt):
    from modquad_gym.sim.export import export_text

    return export_text(mq.Structure(S3), fmt)


ARRAY = np.array([1, 2])
PYTHON = {
    "make_solver fault": (lambda: mq.make_solver("greedy", fault=ARRAY), "fault"),
    "SearchProblem fault": (lambda: mq.SearchProblem(mq.TaskRequirement(W1), fault=ARRAY),
                            "fault"),
    "env fault": (lambda: _gym(fault=ARRAY), "fault"),
    "env invalid_action": (lambda: _gym(invalid_action=ARRAY), "invalid_action"),
    "env lookahead": (lambda: _gym(lookahead=ARRAY), "lookahead"),
    "env oracle_method": (lambda: _gym(oracle_method=ARRAY), "oracle_method"),
    "env tasks 10 kB": (lambda: _gym(tasks="x" * 10240), "tasks"),
    "env task 10 kB": (lambda: _gym(task="x" * 10240), "task"),
    "validate out_dir 3.5": (lambda: _validate(out_dir=3.5), "out_dir"),
    "validate out_dir True": (lambda: _validate(out_dir=True), "out_dir"),
    "generated_task seed []": (lambda: _generated(seed=[]), "seed"),
    "generated_task seed True": (lambda: _generated(seed=True), "seed"),
    "generated_task seed array": (lambda: _generated(seed=ARRAY), "seed"),
    "generated_task seed 10**30": (lambda: _generated(seed=10**30), "seed"),
    "generated_task kind": (lambda: _generated(kind=ARRAY), "kind"),
    "generated_task task_kind": (lambda: _generated(task_kind=ARRAY), "task_kind"),
    "export_text fmt": (lambda: _export(ARRAY), "format"),
}  # fmt: skip


@pytest.mark.parametrize("case", list(PYTHON))
def test_a_python_argument_is_named_in_its_error(case):
    call, name = PYTHON[case]
    with pytest.raises(ValueError) as exc:
        call()
    message = str(exc.value)
    assert message.startswith(name) and len(message) < 400, message
    assert "truth value" not in message, message


def test_generated_task_keeps_a_plain_seed():
    from modquad_gym.tasks.specs import generated_task

    assert generated_task("planted", seed=np.int64(3)).name == "planted-seed3"


# --- 8. edge values of the motions and the checker -------------------------------------------
def test_a_hover_spans_at_least_one_sample_interval(tmp_path, capsys):
    from modquad_gym import dynamics as dy

    with pytest.raises(ValueError, match="^duration: .* shorter than one sample interval"):
        dy.hover(duration=1e-320)
    assert dy.hover(duration=0.01, rate=100.0).n_wrenches == 2  # exactly one interval
    code, err = run_modquad(capsys, "task", "motion", "--kind", "hover", "--duration", "1e-320",
                            "--out", str(tmp_path / "m.json"))  # fmt: skip
    line = error_line(code, err, "modquad: error: --duration: ")
    assert "one sample interval at --rate 100" in line, line
    assert not (tmp_path / "m.json").exists()


SHORT_PATHS = [
    (["--kind", "circle", "--radius", "1e-320"], "--radius 9.99989e-321: too fast"),
    (["--kind", "circle", "--laps", "1e-320"], "--laps 9.99989e-321: too fast"),
    (["--kind", "push", "--distance", "1e-320"], "--distance 9.99989e-321: too fast"),
    (["--kind", "circle", "--speed", "100"], "--speed 100: too fast"),
]


@pytest.mark.parametrize("argv, start", SHORT_PATHS, ids=[a[2] for a, _ in SHORT_PATHS])
def test_a_path_too_short_for_its_ramps_blames_the_option_typed(tmp_path, capsys, argv, start):
    """The ramps need a path as long as 1 s at cruise speed each way: the error names what was
    typed (it named --speed, which the user had not given)."""
    code, err = run_modquad(capsys, "task", "motion", *argv, "--out", str(tmp_path / "m.json"))
    line = error_line(code, err, "modquad: error: ")
    assert line.startswith(f"modquad: error: {start}"), line


def test_check_refuses_an_empty_path(capsys):
    code, err = run_modquad(capsys, "check", "")
    line = error_line(code, err, "modquad check: error: ")
    assert "argument FILE: an empty path" in line, line
    from modquad_gym import proofcheck

    with pytest.raises(proofcheck.CertificateFormatError, match="^an empty path"):
        proofcheck.check_file("")
