"""Issue 34, item 1: the reliability families, each fixed at its root and tried across every
command and API entry point that meets it (one table of hostile inputs per family):

1. bounded before work: a motion's sample count checked from its arguments, before any sample;
2. nothing the user saved is lost: a dangling symbolic link is an existing output;
3. no half a result: a command's outputs are checked together, before any work or write;
4. no silently ignored input: an option that would change nothing is refused;
5. no silently changed input: complex numbers are refused, not cut to their real parts;
6. no traceback from the environment: numba settings checked before numba is imported;
7. messages that name the file, field or option (dynamic task files at the edges of floating
   point, a full disk, the benchmarks' usage), and one spelling and one default per option.
"""

from __future__ import annotations

import errno
import json
import os
import subprocess
import sys
import time
import tracemalloc
import types
import warnings
from pathlib import Path

import numpy as np
import pytest
from test_fuzz_outputs import MOVED

import modquad_gym as mq
from benchmarks.common import run_script
from modquad_gym import cli
from modquad_gym import dynamics as dy
from modquad_gym.core import atomic_files, outputs

ROOT = Path(__file__).resolve().parents[1]
SCREWDRIVER = str(ROOT / "examples" / "screwdriver.json")
ENV = {**os.environ, "OMP_NUM_THREADS": "1", "MPLBACKEND": "Agg", "PYTHONPATH": str(ROOT)}


def run_main(capsys, *argv: str) -> tuple[int, str, str]:
    """(exit code, stdout, stderr) of ``modquad argv`` in this process."""
    try:
        code = cli.main(list(argv))
    except SystemExit as exc:  # argparse errors
        code = exc.code
    out, err = capsys.readouterr()
    return code, out, err


def assert_one_line_error(code: int, err: str, *names: str) -> str:
    assert code == 2, err
    assert "Traceback" not in err
    lines = [line for line in err.strip().splitlines() if not line.startswith("modquad: note")]
    assert len(lines) == 1 and lines[0].startswith("modquad: error: "), err
    for name in names:
        assert name in lines[0], (name, err)
    return lines[0]


def files_under(folder: Path) -> dict[str, bytes | str]:
    """Every entry below ``folder``: a file's bytes, a link's target."""
    out: dict[str, bytes | str] = {}
    for p in sorted(folder.rglob("*")):
        if p.is_symlink():
            out[str(p)] = "-> " + os.readlink(p)
        elif p.is_file():
            out[str(p)] = p.read_bytes()
    return out


@pytest.fixture()
def dynamic_task(tmp_path) -> Path:
    path = tmp_path / "hover.json"
    dy.hover(1.0, payload=0.1, rate=20.0).save(path)
    return path


# ------------------------------------------------------------- 1. bounded before any sample
MOTION_FLOODS = [
    ("hover", ["--rate", "1e6"]),
    ("hover", ["--rate", "1e12"]),
    ("hover", ["--duration", "1e300"]),
    ("line", ["--rate", "1e9"]),
    ("line", ["--distance", "1e12"]),
    ("circle", ["--laps", "1e9"]),
    ("circle", ["--radius", "1e300"]),
    ("figure-eight", ["--laps", "1e7"]),
    ("push", ["--distance", "1e12"]),
]


@pytest.mark.parametrize(("kind", "options"), MOTION_FLOODS)
def test_task_motion_counts_its_samples_before_building_them(tmp_path, capsys, kind, options):
    """`task motion` with a rate or a length past 100,000 samples: refused from the numbers,
    with next to no memory and time (it reached 2.95 GB and 13 s, or numpy's 'Unable to
    allocate 61.7 GiB', before)."""
    out = tmp_path / "m.json"
    tracemalloc.start()
    t0 = time.perf_counter()
    try:
        argv = ["task", "motion", "--kind", kind, *options, "--out", str(out)]
        code, _, err = run_main(capsys, *argv)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert_one_line_error(code, err, "--rate", "100,000")
    assert time.perf_counter() - t0 < 2 and peak < 20e6, peak
    assert not out.exists()


@pytest.mark.parametrize("name", sorted(dy.MOTIONS))
def test_motion_api_refuses_too_many_samples_before_building_them(name):
    tracemalloc.start()
    try:
        with pytest.raises(ValueError, match=r"^[a-z_, ]*\brate: .*more than the 100,000"):
            dy.MOTIONS[name](rate=1e9)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert peak < 20e6, peak


def test_sample_count_is_exact_at_the_limit():
    from modquad_gym.dynamics.motions import sample_count

    assert sample_count(1000.0, 99.999) == dy.MAX_SAMPLES
    assert sample_count(2.0, 100.0) == 201
    for duration, rate in [(1000.0, 100.0), (1e300, 1e300), (1e308, 10.0)]:
        with pytest.raises(ValueError, match="rate"):
            sample_count(duration, rate)


# ------------------------------------------------------------- 2. a dangling link is kept
FILE_WRITERS = {
    "task motion": ["task", "motion", "--kind", "hover", "--out", "{out}.json"],
    "task generate": ["task", "generate", "--kind", "screwdriver", "--out", "{out}.json"],
    "task example": ["task", "example", "screwdriver", "--out", "{out}.json"],
    "export": ["export", "--cells", "[[0,0]]", "--out", "{out}.json"],
    "solve --export": [
        "solve",
        "--task",
        SCREWDRIVER,
        "--method",
        "greedy",
        "--quiet",
        "--export",
        "{out}.json",
    ],
    "show --out": ["show", "--cells", "[[0,0]]", "--out", "{out}.png"],
    "show --html": ["show", "--cells", "[[0,0]]", "--html", "{out}.html"],
}
FOLDER_WRITERS = {
    "validate": ["validate", "--task", SCREWDRIVER, "--out", "{out}"],
    "score": ["score", "--out", "{out}"],
    "benchmarks.oracle": ["oracle", "--out", "{out}"],
    "benchmarks.env": ["env", "--out", "{out}"],
    "benchmarks.level_bounds": ["level_bounds", "--n-max", "1", "--out", "{out}"],
}
"""The commands that write a folder: ``modquad`` ones, and ``python -m benchmarks.NAME``."""


def run_command(capsys, name: str, argv: list[str]) -> tuple[int, str, str]:
    """(exit code, stdout, stderr) of the command ``name`` of :data:`FOLDER_WRITERS`."""
    if not name.startswith("benchmarks."):
        return run_main(capsys, *argv)
    code = run_script(argv[0], argv[1:])
    out, err = capsys.readouterr()
    return code, out, err


def _argv(template: list[str], out: Path) -> list[str]:
    return [a.replace("{out}", str(out)) for a in template]


def _no_work(monkeypatch):
    """Any search or simulation fails the test: the outputs are checked first."""
    import importlib

    def boom(*args, **kwargs):
        raise AssertionError("work started before the outputs were checked")

    monkeypatch.setattr(importlib.import_module("modquad_gym.sim.validate"), "validate", boom)
    monkeypatch.setattr("modquad_gym.cli.solve.solver", boom)


@pytest.mark.parametrize("name", sorted(FILE_WRITERS))
def test_a_dangling_link_at_an_output_file_is_kept(tmp_path, capsys, monkeypatch, name):
    """Every command that writes a file: a symbolic link to nothing at the output path is what
    the user put there; it is refused without --force (it was replaced before)."""
    monkeypatch.chdir(tmp_path)
    argv = _argv(FILE_WRITERS[name], tmp_path / "link")
    link = Path(next(a for a in argv if a.startswith(str(tmp_path / "link"))))
    link.symlink_to(tmp_path / "elsewhere")
    before = files_under(tmp_path)
    code, _, err = run_main(capsys, *argv)
    assert_one_line_error(code, err, str(link), "symbolic link", "--force")
    assert files_under(tmp_path) == before and not (tmp_path / "elsewhere").exists()


def test_force_replaces_the_link_not_its_target(tmp_path, capsys):
    link = tmp_path / "m.json"
    link.symlink_to(tmp_path / "elsewhere.json")
    code, _, err = run_main(
        capsys, "task", "motion", "--kind", "hover", "--out", str(link), "--force"
    )
    assert code == 0, err
    assert not link.is_symlink() and json.loads(link.read_text())["kind"] == "dynamic"
    assert not (tmp_path / "elsewhere.json").exists()


@pytest.mark.parametrize("name", sorted(FOLDER_WRITERS))
@pytest.mark.parametrize("where", ["folder", "report"])
def test_a_dangling_link_in_an_output_folder_is_kept(tmp_path, capsys, monkeypatch, name, where):
    """Every command that writes a folder: --out a link to nothing (mkdir would fail after the
    work), or a report name in it a link to nothing (it would be replaced)."""
    _no_work(monkeypatch)
    monkeypatch.chdir(tmp_path)
    folder = tmp_path / "out"
    if where == "folder":
        folder.symlink_to(tmp_path / "nowhere")
    else:
        from test_fuzz_outputs import _report_names

        folder.mkdir()
        what = {"validate": None, "score": "agents"}.get(name, name.split(".")[-1])
        first = "report.md" if what is None else _report_names(what)[0]
        (folder / first).symlink_to(tmp_path / "nowhere")
    before = files_under(tmp_path)
    code, _, err = run_command(capsys, name, _argv(FOLDER_WRITERS[name], folder))
    assert code == 2 and "Traceback" not in err, err
    assert "error: " in err.strip().splitlines()[-1] and "out" in err.strip().splitlines()[-1]
    assert files_under(tmp_path) == before and not (tmp_path / "nowhere").exists()


def test_check_output_file_api(tmp_path):
    link = tmp_path / "a.json"
    link.symlink_to("missing.json")
    with pytest.raises(outputs.OutputError, match="symbolic link"):
        outputs.check_output_file(link)
    assert outputs.check_output_file(link, force=True) == link
    parent = tmp_path / "gone"
    parent.symlink_to(tmp_path / "nowhere")
    with pytest.raises(outputs.OutputError, match="symbolic link"):
        outputs.check_output_file(parent / "sub" / "a.json")
    with pytest.raises(outputs.OutputError, match="symbolic link"):
        outputs.check_output_dir(parent)


# ------------------------------------------------------------- 3. outputs checked together
@pytest.mark.parametrize(
    ("out", "html", "force"),
    [
        ("p.png", "p.png", []),
        ("p", "p.png", []),  # '.png' is added to --out
        ("sub/../p.png", "p.png", []),
        ("p.png", "alias.png", ["--force"]),  # a link to the other (kept without --force)
    ],
)
def test_show_refuses_one_file_for_two_outputs_before_writing(
    tmp_path, capsys, monkeypatch, out, html, force
):
    """`show --out X --html X` wrote the PNG, then refused the HTML (half a result): now both
    are checked together, first (also through a folder step or a link to the other)."""
    monkeypatch.chdir(tmp_path)
    (tmp_path / "sub").mkdir()
    (tmp_path / "alias.png").symlink_to(tmp_path / "p.png")
    before = files_under(tmp_path)
    code, _, err = run_main(
        capsys, "show", "--cells", "[[0,0]]", "--out", out, "--html", html, *force
    )
    assert_one_line_error(code, err, "--html", "--out")
    assert files_under(tmp_path) == before


def test_check_outputs_api(tmp_path):
    a = tmp_path / "a.png"
    got = outputs.check_outputs({"--out": a, "--html": tmp_path / "a.html", "--x": None})
    assert got == {"--out": a, "--html": tmp_path / "a.html"}
    with pytest.raises(outputs.OutputError, match="--b: .* also the file of --a"):
        outputs.check_outputs({"--a": a, "--b": tmp_path / "." / "a.png"})
    a.write_text("kept")
    with pytest.raises(outputs.OutputError, match="exists"):
        outputs.check_outputs({"--a": tmp_path / "b.png", "--b": a})
    assert a.read_text() == "kept"


# ------------------------------------------------------------- 4. nothing silently ignored
def _ignored_cases(tmp: Path, dynamic: Path) -> list[tuple[list[str], str]]:
    out = str(tmp / "out.json")
    motion = ["task", "motion", "--kind", "hover", "--out", out]
    solve = ["solve", "--task", SCREWDRIVER, "--quiet"]
    validate = ["validate", "--task", SCREWDRIVER, "--out", str(tmp / "v")]
    export = ["export", "--cells", "[[0,0]]", "--out", out]
    show = ["show", "--cells", "[[0,0]]", "--out", str(tmp / "s.png")]
    return [
        ([*solve, "--csv-header", "yes"], "--csv-header"),  # a JSON file has no header row
        ([*validate, "--csv-header", "no"], "--csv-header"),
        (["optima", "--task", SCREWDRIVER, "--csv-header", "no", "--out", out], "--csv-header"),
        ([*show, "--method", "greedy"], "--method"),
        ([*show, "--n-max", "20"], "--n-max"),
        ([*show, "--time-limit", "5"], "--time-limit"),
        ([*show, "--csv-header", "no"], "--csv-header"),
        ([*show, "--task", SCREWDRIVER, "--seed", "3"], "--seed"),
        ([*motion, "--payload-offset", "0,0,-0.2"], "--payload-offset"),
        ([*motion, "--payload-mass", "0", "--payload-offset", "0,0,-0.2"], "--payload-offset"),
        ([*motion, "--payload-off", "0,0,-0.2"], "--payload-offset"),  # an abbreviation
        (["task", "example", "--out", out], "--out"),
        ([*export, "--method", "greedy"], "--method"),
        ([*export, "--n-max", "3"], "--n-max"),
        ([*export, "--time-limit", "5"], "--time-limit"),
        ([*export, "--seed", "4"], "--seed"),
        ([*export, "--csv-header", "yes"], "--csv-header"),
        ([*solve, "--method", "exhaustive", "--seed", "3"], "--seed"),
        ([*solve, "--method", "exhaustive", "--see", "3"], "--seed"),  # an abbreviation
        ([*solve, "--method", "greedy", "--seed", "3"], "--seed"),
        ([*solve, "--method", "centrosymmetric", "--seed", "3"], "--seed"),
        ([*solve, "--method", "exhaustive", "--time-limit", "5"], "--time-limit"),
        ([*solve, "--workers", "1", "--ray-address", "127.0.0.1:1"], "--ray-address"),
        (
            [
                "export",
                "--task",
                SCREWDRIVER,
                "--method",
                "exhaustive",
                "--seed",
                "2",
                "--out",
                out,
            ],
            "--seed",
        ),
        ([*validate, "--method", "exhaustive", "--time-limit", "9"], "--time-limit"),
        ([*validate, "--all-wrenches", "--max-hover-wrenches", "3"], "--max-hover-wrenches"),
        ([*validate, "--known-load-only", "--load-ramp-seconds", "0.5"], "--load-ramp-seconds"),
        (
            ["validate", "--task", str(dynamic), "--infeasible-demo", "--out", str(tmp / "v")],
            "--infeasible-demo",
        ),
        (
            [
                "validate",
                "--task",
                str(dynamic),
                "--load-ramp-seconds",
                "0.5",
                "--out",
                str(tmp / "v"),
            ],
            "--load-ramp-seconds",
        ),
        (
            [
                "optima",
                "--suite",
                "heldout_planted",
                "--csv-header",
                "no",
                "--out",
                str(tmp / "o.jsonl"),
            ],
            "--csv-header",
        ),
    ]


def test_options_that_would_be_ignored_are_refused(tmp_path, capsys, monkeypatch, dynamic_task):
    """Each option that changed nothing (`--payload-offset` without a payload exited 0 with
    the offset dropped): one line naming it, exit 2, nothing written, no work started."""
    _no_work(monkeypatch)
    for argv, option in _ignored_cases(tmp_path, dynamic_task):
        before = files_under(tmp_path)
        code, _, err = run_main(capsys, *argv)
        assert_one_line_error(code, err, option)
        assert files_under(tmp_path) == before, argv


def test_the_same_options_where_they_apply_are_used(tmp_path, capsys):
    out = tmp_path / "m.json"
    code, _, err = run_main(
        capsys,
        "task",
        "motion",
        "--kind",
        "hover",
        "--payload-mass",
        "0.1",
        "--payload-offset",
        "0,0,-0.2",
        "--out",
        str(out),
    )
    assert code == 0, err
    assert json.loads(out.read_text())["payload"] == {"mass": 0.1, "offset": [0.0, 0.0, -0.2]}
    csv = ROOT / "examples" / "paper_seed0.csv"  # --csv-header applies to the CSV file here
    argv = ["solve", "--task", SCREWDRIVER, "--task", str(csv), "--csv-header", "yes"]
    code, _, err = run_main(capsys, *argv, "--method", "greedy", "--quiet", "--n-max", "3")
    assert code == 0, err
    code, out_text, err = run_main(
        capsys,
        "solve",
        "--task",
        SCREWDRIVER,
        "--method",
        "random",
        "--seed",
        "3",
        "--json",
        "--n-max",
        "3",
    )
    assert code == 0 and json.loads(out_text)["feasible"], err


# ------------------------------------------------------------- 5. complex numbers refused
T = np.linspace(0.0, 1.0, 11)
P = np.zeros((11, 3))
A = mq.Structure([(0, 0), (1, 0)]).configuration_matrix()
W = np.array([[0.0, 0.0, 1.0, 0.0, 0.0, 0.0]])
C = W.astype(complex) + 1e-3j
M = mq.TModule()
COMPLEX_ENTRIES = {
    "feasible(W)": (lambda: mq.feasible(A, C), "wrenches"),
    "feasible(list W)": (lambda: mq.feasible(A, [[0, 0, 1j, 0, 0, 0]]), "wrenches"),
    "feasible(A)": (lambda: mq.feasible(A.astype(complex), W), "A"),
    "margin": (lambda: mq.margin(A, C), "wrenches"),
    "lambda_ratio": (lambda: mq.lambda_ratio(A, C), "wrenches"),
    "allocate": (lambda: mq.allocate(A, C), "w: wrenches"),  # its argument is w
    "Zonotope": (lambda: mq.Zonotope(A.astype(complex)), "A"),
    "TaskRequirement": (lambda: mq.TaskRequirement(C), "wrenches"),
    "TaskRequirement(list)": (lambda: mq.TaskRequirement([list(C[0])]), "wrenches"),
    "exhaustive_search": (lambda: mq.exhaustive_search(C, n_max=2), "wrenches"),
    "anytime_search": (lambda: mq.anytime_search(C, n_max=2), "wrenches"),
    "greedy_search": (lambda: mq.greedy_search(C, n_max=2), "wrenches"),
    "Trajectory.t": (lambda: mq.Trajectory(T + 0j, P), "t"),
    "Trajectory.t(list)": (lambda: mq.Trajectory(list(T + 0j), P), "t"),
    "Trajectory.position": (lambda: mq.Trajectory(T, P + 0j), "position"),
    "Trajectory.quaternion": (
        lambda: mq.Trajectory(T, P, np.tile([1.0, 0, 0, 0], (11, 1)) + 0j),
        "quaternion",
    ),
    "Trajectory.velocity": (lambda: mq.Trajectory(T, P, velocity=[[1j, 0, 0]] * 11), "velocity"),
    "Payload.offset": (lambda: mq.Payload(1.0, np.zeros(3) + 0j), "payload.offset"),
    "DynamicTask.exerted": (
        lambda: mq.DynamicTask(mq.Trajectory(T, P), exerted=np.zeros((11, 6)) + 0j),
        "exerted",
    ),
    "ModuleType.positions": (
        lambda: mq.ModuleType(M.positions + 0j, M.directions, M.spins),
        "positions",
    ),
    "ModuleType.inertia": (
        lambda: mq.ModuleType(M.positions, M.directions, M.spins, inertia=np.eye(3) * 1e-3 + 0j),
        "inertia",
    ),
}


@pytest.mark.parametrize("entry", sorted(COMPLEX_ENTRIES))
def test_complex_input_is_refused_naming_the_argument(entry):
    """A complex array lost its imaginary part with only a ComplexWarning: now a ValueError
    naming the argument, and no warning on the way."""
    call, name = COMPLEX_ENTRIES[entry]
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        with pytest.raises(ValueError, match=rf"^{name} must hold real numbers"):
            call()


def test_complex_npy_task_file_is_refused(tmp_path, capsys):
    path = tmp_path / "c.npy"
    np.save(path, C)
    code, _, err = run_main(capsys, "solve", "--task", str(path))
    assert_one_line_error(code, err, str(path))


# ------------------------------------------------------------- 6. numba settings
NUMBA_VALUES = [
    ("NUMBA_NUM_THREADS", "0"),
    ("NUMBA_NUM_THREADS", "-1"),
    ("NUMBA_NUM_THREADS", "abc"),
    ("NUMBA_NUM_THREADS", ""),
    ("NUMBA_OPT", "9"),
    ("NUMBA_DISABLE_JIT", "x"),
]


@pytest.mark.parametrize(("name", "value"), NUMBA_VALUES)
def test_bad_numba_setting_is_one_line(capsys, monkeypatch, name, value):
    monkeypatch.setenv(name, value)
    code, _, err = run_main(capsys, "solve", "--task", SCREWDRIVER)
    assert_one_line_error(code, err, f"{name}={value!r}")


def test_good_numba_settings_pass():
    from modquad_gym.core.caches import setting_error

    good = {"NUMBA_NUM_THREADS": "2", "NUMBA_OPT": "max", "NUMBA_DISABLE_JIT": "0"}
    assert setting_error(good) is None
    assert "NUMBA_OPT" in setting_error({**good, "NUMBA_OPT": "4"})


def test_numba_setting_before_the_import_is_one_line_exit_2():
    """The import itself (numba's would end in a traceback): the command says one line, a
    program importing the package gets a ValueError naming the variable."""
    env = {**ENV, "NUMBA_NUM_THREADS": "0"}
    run = subprocess.run(
        [sys.executable, "-m", "modquad_gym.cli", "--version"],
        env=env,
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert run.returncode == 2 and "Traceback" not in run.stderr, run.stderr
    assert run.stderr.strip().splitlines() == [
        "modquad: error: NUMBA_NUM_THREADS='0' in the environment: expected numba's thread "
        "count: an integer >= 1 (or unset it)"
    ]
    run = subprocess.run(
        [sys.executable, "-c", "import modquad_gym"],
        env=env,
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert run.returncode == 1 and "SettingError: NUMBA_NUM_THREADS='0'" in run.stderr
    run = subprocess.run(
        [sys.executable, "train.py", "--help"],
        cwd=ROOT,
        env=env,
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert run.returncode == 2 and run.stderr.startswith("python train.py: error: NUMBA_NUM")


# ------------------------------------------------------------- 7. messages naming the file
def _dynamic_variants() -> dict[str, tuple[dict, str]]:
    """A dynamic task changed at the edges of floating point, and the field its error names."""
    ok = dy.hover(1.0, rate=20.0).to_dict()
    t = [i * 1e-300 for i in range(9)]
    zeros = [[0.0, 0.0, 0.0]] * len(ok["trajectory"]["t"])
    big_acc = [[1e200, 0.0, 0.0]] + zeros[1:]
    big_rate = [[0.0, 0.0, 1e200]] + zeros[1:]
    return {
        "tiny times": (
            {"trajectory": {"t": t, "position": [[0.0, 0.0, 0.0]] * 9}},
            "trajectory.acceleration",
        ),
        "tiny times, 3 samples": (
            {"trajectory": {"t": t[:3], "position": [[0, 0, 0], [1e-3, 0, 0], [0, 0, 0]]}},
            "trajectory.acceleration",
        ),
        "huge f_max": ({"f_max": 1e301}, "f_max"),
        "huge payload": ({"payload": {"mass": 1e300}}, "payload.mass"),
        "huge payload and f_max": ({"payload": {"mass": 1e200}, "f_max": 1e12}, "payload.mass"),
        "huge exerted": ({"exerted": [[1e200, 0, 0, 0, 0, 0]] * len(zeros)}, "exerted"),
        "huge exerted beside a payload": (
            {"exerted": [[1e200, 0, 0, 0, 0, 0]] * len(zeros), "payload": {"mass": 0.1}},
            "exerted",
        ),
        "huge acceleration": (  # the positions (a hover) imply none: refused as they disagree
            {"trajectory": {**ok["trajectory"], "acceleration": big_acc}},
            "trajectory.acceleration: sample 1 is [1e+200, 0, 0] m/s^2",
        ),
        "huge body rate": (
            {
                "trajectory": {
                    **ok["trajectory"],
                    "angular_velocity": big_rate,
                    "quaternion": [[1.0, 0, 0, 0]] * len(zeros),
                }
            },
            "trajectory.angular_velocity: sample 1 is [0, 0, 1e+200] rad/s",
        ),
    }


def _write_variant(folder: Path, name: str) -> tuple[Path, str]:
    change, field = _dynamic_variants()[name]
    data = {**dy.hover(1.0, rate=20.0).to_dict(), **change}
    path = folder / (name.replace(" ", "_").replace(",", "") + ".json")
    path.write_text(json.dumps(data))
    return path, field


@pytest.mark.filterwarnings("error")
@pytest.mark.parametrize("name", sorted(_dynamic_variants()))
def test_dynamic_task_file_at_the_edges_names_file_and_field(tmp_path, capsys, name):
    """Times 1e-300 s apart, a huge f_max or payload: non-finite wrench rows, numpy
    RuntimeWarnings and errors without the file before; now one line with both, no warning."""
    path, field = _write_variant(tmp_path, name)
    code, _, err = run_main(capsys, "solve", "--task", str(path), "--quiet")
    assert_one_line_error(code, err, str(path), field)


COMMANDS_READING_TASKS = {
    "solve": ["solve", "--task", "{task}", "--quiet"],
    "export": ["export", "--task", "{task}", "--out", "{tmp}/e.json"],
    "show": ["show", "--task", "{task}", "--out", "{tmp}/p.png"],
    "validate": ["validate", "--task", "{task}", "--out", "{tmp}/v"],
}


@pytest.mark.filterwarnings("error")
@pytest.mark.parametrize("command", sorted(COMMANDS_READING_TASKS))
def test_every_command_names_the_dynamic_task_file(tmp_path, capsys, monkeypatch, command):
    _no_work(monkeypatch)
    path, field = _write_variant(tmp_path, "huge payload")
    argv = [
        a.replace("{task}", str(path)).replace("{tmp}", str(tmp_path))
        for a in COMMANDS_READING_TASKS[command]
    ]
    code, _, err = run_main(capsys, *argv)
    assert_one_line_error(code, err, str(path), field)
    assert sorted(p.name for p in tmp_path.iterdir()) == [path.name]


def test_dynamic_task_api_refuses_what_overflows():
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        with pytest.raises(ValueError, match=r"^payload\.mass: .* beyond 1e\+100"):
            dy.hover(payload=1e300)
        with pytest.raises(ValueError, match=r"^f_max = 1e\+301 is outside 1e-300\.\.1e12 "):
            dy.hover(f_max=1e301)
        with pytest.raises(ValueError, match=r"^acceleration: not finite at sample"):
            mq.Trajectory([0.0, 1e-300, 2e-300], [[0, 0, 0], [1e-3, 0, 0], [0, 0, 0]])


def _full_disk(module, monkeypatch, name: str) -> None:
    """``module.os.NAME`` fails as a full disk does (the rest of ``os`` unchanged)."""

    def full(*args, **kwargs):
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

    proxy = types.SimpleNamespace(**{k: getattr(os, k) for k in dir(os) if not k.startswith("__")})
    setattr(proxy, name, full)
    monkeypatch.setattr(module, "os", proxy)


DISK_WRITERS = {
    "task motion": ["task", "motion", "--kind", "hover", "--out", "{out}.json"],
    "task generate": ["task", "generate", "--kind", "paper", "--out", "{out}.csv"],
    "task example": ["task", "example", "screwdriver", "--out", "{out}.json"],
    "export": ["export", "--cells", "[[0,0]]", "--out", "{out}.xml"],
    "show": ["show", "--cells", "[[0,0]]", "--out", "{out}.png"],
}


@pytest.mark.parametrize("name", sorted(DISK_WRITERS))
def test_a_full_disk_names_the_output(tmp_path, capsys, monkeypatch, name):
    """'No space left on device' without a file name before: now the output it was writing."""
    _full_disk(atomic_files, monkeypatch, "replace")
    argv = _argv(DISK_WRITERS[name], tmp_path / "out")
    target = next(a for a in argv if a.startswith(str(tmp_path)))
    code, _, err = run_main(capsys, *argv)
    assert_one_line_error(code, err, f"{target}: No space left on device")
    assert list(tmp_path.iterdir()) == []  # no temporary file left either


def test_a_full_disk_names_the_optima_dataset(tmp_path, capsys, monkeypatch):
    import modquad_gym.scoring.optima as optima

    _full_disk(optima, monkeypatch, "fsync")
    out = tmp_path / "o.jsonl"
    code, _, err = run_main(
        capsys,
        "optima",
        "--task",
        SCREWDRIVER,
        "--out",
        str(out),
        "--n-max",
        "3",
        "--workers",
        "1",
        "--quiet",
    )
    assert_one_line_error(code, err, f"{out}: No space left on device")


@pytest.mark.parametrize("what", sorted(MOVED))
def test_benchmark_usage_names_its_command(capsys, what):
    """`python -m benchmarks.X --bogus`: one error line that names that command (no usage
    block: `--help` shows it)."""
    code = run_script(what, ["--bogus"])
    err = capsys.readouterr().err
    assert code == 2, err
    command = f"python -m benchmarks.{what}"
    assert err == f"{command}: error: unrecognized arguments: --bogus\n", err


@pytest.mark.parametrize("argv", [["score"], ["bench", "agents"]])
def test_score_usage_names_the_command_typed(capsys, argv):
    """`modquad score --limit 0`, and its deprecated name `modquad bench agents --limit 0`."""
    code, _, err = run_main(capsys, *argv, "--limit", "0")
    command = "modquad " + " ".join(argv)
    assert code == 2 and "python -m" not in err and "usage:" not in err, err
    assert err.strip().splitlines()[-1].startswith(f"{command}: error: argument --limit: "), err


def test_bench_agents_still_scores_and_says_it_is_deprecated(tmp_path, capsys):
    """`modquad bench agents` is `modquad score` for one release: the same report, stdout
    untouched, one note on stderr; the report gives the new command."""
    argv = ["--limit", "1", "--methods", "greedy", "--no-progress"]
    code, out, err = run_main(capsys, "bench", "agents", *argv, "--out", str(tmp_path / "old"))
    assert code == 0, err
    assert "deprecated: use `modquad score`" in err and "deprecated" not in out
    report = (tmp_path / "old" / "benchmark.md").read_text()
    assert out.startswith(report.splitlines()[0]) and "modquad score --limit 1" in report
    code, _, err = run_main(capsys, "score", *argv, "--out", str(tmp_path / "new"))
    assert code == 0 and not err.strip(), err
    assert "modquad score --limit 1" in (tmp_path / "new" / "benchmark.md").read_text()


@pytest.mark.parametrize("what", ["oracle", "level-bounds", "nope"])
def test_removed_bench_commands_say_where_they_went(capsys, what):
    code, _, err = run_main(capsys, "bench", what)
    line = assert_one_line_error(code, err, f"modquad bench {what}")
    name = what.replace("-", "_")
    assert (f"python -m benchmarks.{name}" if what != "nope" else "modquad score") in line


def test_optima_takes_task_like_every_command_and_still_tasks(tmp_path, capsys):
    out = tmp_path / "o.jsonl"
    base = ["--out", str(out), "--n-max", "3", "--workers", "1", "--quiet"]
    code, text, err = run_main(capsys, "optima", "--task", SCREWDRIVER, *base)
    assert code == 0 and "1 records written" in text and "note" not in err, err
    code, text, err = run_main(capsys, "optima", "--tasks", SCREWDRIVER, *base)  # deprecated
    assert code == 0 and "1 already there" in text and not err.strip(), err
    code, text, _ = run_main(capsys, "optima", "--help")
    assert "--task DIR|GLOB|FILE" in text and "deprecated" in text


def _all_helps(capsys) -> dict[str, str]:
    """The --help text of every command, action and benchmark."""
    argvs = [[c] for c in ("solve", "optima", "show", "export", "validate", "score")]
    argvs += [*(["task", a] for a in ("generate", "motion", "example")), ["bench", "agents"]]
    helps = {}
    for argv in argvs:
        code, out, err = run_main(capsys, *argv, "--help")
        assert code == 0, err
        helps[" ".join(argv)] = out
    for name in MOVED:
        assert run_script(name, ["--help"]) == 0
        helps[f"python -m benchmarks.{name}"] = capsys.readouterr().out
    return helps


def test_every_help_states_each_default_once(capsys):
    """`modquad score --help` printed "(default: the tier's) (default: None)"."""
    for name, text in _all_helps(capsys).items():
        flat = " ".join(text.split())
        assert "(default: None)" not in flat, name
        for option_help in flat.split(" --")[1:]:
            assert option_help.lower().count("(default") <= 1, (name, option_help)


def test_defaults_help_formatter():
    import argparse

    from modquad_gym.core.options import DefaultsHelpFormatter

    p = argparse.ArgumentParser(prog="x", formatter_class=DefaultsHelpFormatter)
    p.add_argument("--a", default=3, help="count")
    p.add_argument("--b", default=None, help="path")
    p.add_argument("--c", default=2, help="size (default: the tier's)")
    p.add_argument("--d", action="store_true", help="flag")
    text = " ".join(p.format_help().split())
    assert "count (default: 3)" in text and "path --c" in text
    assert "(default: the tier's) --d" in text and text.count("(default") == 2


def test_missing_extras_are_refused_before_any_work(monkeypatch, tmp_path, capsys):
    """Without matplotlib (show --out), plotly (show --html) or MuJoCo (validate) the command
    says which extra to install in one line before it searches, flies or writes anything."""
    import importlib.util

    from modquad_gym import cli

    real = importlib.util.find_spec
    for missing, argv in [
        ("matplotlib", ["show", "--task", "example:screwdriver", "--out", str(tmp_path / "a.png")]),
        ("plotly", ["show", "--task", "example:screwdriver", "--html", str(tmp_path / "a.html")]),
        ("mujoco", ["validate", "--task", "example:screwdriver", "--out", str(tmp_path / "v")]),
    ]:
        monkeypatch.setattr(
            importlib.util,
            "find_spec",
            lambda name, *a, m=missing: None if name == m else real(name, *a),
        )
        code = cli.main(argv)
        err = capsys.readouterr().err
        monkeypatch.undo()
        assert code == 2 and err.count("\n") == 1 and missing in err and "modquad_gym[" in err
        assert not any(tmp_path.iterdir())
