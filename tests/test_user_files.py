"""Every file and array a user hands the package is read by one rule and refused in one line,
before any work: a training run's ``evaluations.npz``, the numbers of a task (from a file or
from Python), a certificate, an exported model read back, and the size of what is parsed."""

from __future__ import annotations

import json
import os
import re
import shutil
import threading
import time

import numpy as np
import pytest
from test_hardening import assert_one_line_error, run_main

import modquad_gym as mq
from modquad_gym.tasks import TaskFileError, TaskRequirement, as_task, load_suite, load_task

SHIPPED_RUN = mq.__path__[0] + "/data/models/ppo_default"


# --------------------------------------------------------- a training run's evaluations.npz
def _no_work(*args, **kwargs):
    raise AssertionError("the work started, before the refusal")


BAD_EVALUATIONS = {
    "no timesteps": (dict(foo=np.zeros(3)), "no 'timesteps' array"),
    "results flat": (dict(timesteps=np.arange(2), results=np.zeros(2)), "'results' must have"),
    "results short": (dict(timesteps=np.arange(3), results=np.zeros((2, 4))), "(3, n)"),
    "results nan": (dict(timesteps=np.arange(2), results=[[0.0, np.nan], [1, 1]]),
                    "'results' holds a value that is not finite"),
    "successes shape": (dict(timesteps=np.arange(2), results=np.zeros((2, 3)),
                             successes=np.ones((2, 2), bool)), "'successes' must have the shape"),
    "optimal strings": (dict(timesteps=np.arange(2), results=np.zeros((2, 3)),
                             optimal=np.full((2, 3), "y")), "'optimal' must hold numbers"),
    "objects": (dict(timesteps=np.arange(2), results=np.array([[1, None]] * 2, dtype=object)),
                "'results' is not a readable array"),
    "no timesteps rows": (dict(timesteps=np.zeros(0), results=np.zeros((0, 3))),
                          "'timesteps' must have shape (k,), k >= 1"),
}  # fmt: skip


def _write_evaluations(path, case):
    if case == "garbage":
        path.write_bytes(b"\x80\x04garbage that is no archive" * 10)
        return "not a NumPy .npz archive"
    arrays, words = BAD_EVALUATIONS[case]
    np.savez(path, **arrays)
    return words


@pytest.mark.parametrize("case", [*BAD_EVALUATIONS, "garbage"])
def test_a_bad_evaluations_file_is_refused_before_any_scoring(tmp_path, capsys, monkeypatch, case):
    monkeypatch.setattr("modquad_gym.scoring.agents.run_benchmark", _no_work)
    run = tmp_path / "run"
    run.mkdir()
    words = _write_evaluations(run / "evaluations.npz", case)
    out = tmp_path / "rep"
    argv = ["--train-dir", str(run), "--out", str(out), "--no-progress"]
    code, _, err = run_main(capsys, "score", "--methods", "greedy", "ppo", "--limit", "1", *argv)
    assert_one_line_error(code, err, f"{run / 'evaluations.npz'}: ", words)
    assert not out.exists()


def test_the_evaluations_beside_a_model_are_checked_too(tmp_path, capsys, monkeypatch):
    monkeypatch.setattr("modquad_gym.scoring.agents.run_benchmark", _no_work)
    shutil.copy(SHIPPED_RUN + "/model.zip", tmp_path / "model.zip")
    words = _write_evaluations(tmp_path / "evaluations.npz", "results flat")
    argv = ["--model", str(tmp_path / "model.zip"), "--out", str(tmp_path / "rep")]
    code, _, err = run_main(capsys, "score", "--methods", "ppo", "--limit", "1", *argv)
    assert_one_line_error(code, err, str(tmp_path / "evaluations.npz"), words)


def test_the_shipped_evaluations_read():
    from modquad_gym.scoring.fine_tuning import fine_tuning_words, read_evaluations

    for name in ("ppo_default", "ppo_dynamic", "ppo_fault", "ppo_mixed"):
        path = mq.__path__[0] + f"/data/models/{name}/evaluations.npz"
        data = read_evaluations(path)
        k, n = data["results"].shape
        assert data["timesteps"].shape == (k,) and k >= 1 and n >= 1
        assert fine_tuning_words(path).startswith("PPO fine-tuning")


# ------------------------------------------------------ numbers: one rule for every array
RISING = {"t": [0, 0.5, 1.0], "position": [[0, 0, 0], [0, 0, 0.01], [0, 0, 0.02]]}


def _dynamic(**change):
    data = {"name": "dyn", "f_max": 2.0, "trajectory": json.loads(json.dumps(RISING))}
    for key, value in change.items():
        if key in ("t", "position", "quaternion", "velocity", "angular_velocity"):
            data["trajectory"][key] = value
        else:
            data[key] = value
    return data


@pytest.mark.parametrize(
    "change, words",
    [
        ({"t": [0, " 1_0 ", 20]}, "trajectory.t: sample 2 is ' 1_0 ', not a number"),
        ({"t": ["0", "0x1", "1"]}, "trajectory.t: sample 1 is '0', not a number"),
        ({"position": [[0, 0, 0], [" 0", "0", "1 "], [0, 0, 0]]},
         "trajectory.position: sample 2 holds ' 0', not a number (column 1)"),
        ({"quaternion": [[1, 0, 0, 0], [1, 0, 0, 0], ["1", 0, 0, 0]]},
         "trajectory.quaternion: sample 3 holds '1', not a number (column 1)"),
        ({"velocity": [[0, 0, 0], [0, 0, None], [0, 0, 0]]},
         "trajectory.velocity: sample 2 holds None, not a number (column 3)"),
        ({"exerted": [[0] * 6, [0] * 6, [0, 0, "1", 0, 0, 0]]},
         "exerted: sample 3 holds '1', not a number (column 3)"),
        ({"payload": {"mass": 0.1, "offset": ["0", "0", "0.1"]}},
         "payload.offset: entry 1 is '0', not a number"),
    ],
)  # fmt: skip
def test_dynamic_task_files_refuse_strings_as_numbers(tmp_path, capsys, change, words):
    path = tmp_path / "d.json"
    path.write_text(json.dumps(_dynamic(**change)))
    with pytest.raises(TaskFileError) as info:
        load_task(path)
    assert str(info.value) == f"{path}: {words}"
    code, _, err = run_main(capsys, "solve", "--task", str(path), "--method", "greedy",
                            "--n-max", "2", "--quiet")  # fmt: skip
    assert_one_line_error(code, err, str(path), words)


W_ROW = [0, 0, 1, 0, 0, 0]


@pytest.mark.parametrize(
    "wrenches, words",
    [
        ([[0, 0, True, 0, 0, 0]], "wrenches: row 1 holds true, not a number (column 3, fz)"),
        ([W_ROW, ["0", "0", "1e0", "0", "0", " 1_0 "]],
         "wrenches: row 2 holds '0', not a number (column 1, fx)"),
        ([W_ROW, [0, 0, 1, 0, 0, np.str_("1")]],
         "wrenches: row 2 holds '1', not a number (column 6, tz)"),
        ([0, 0, 1, 0, False, 0], "wrenches: row 1 holds false, not a number (column 5, ty)"),
        (np.ones((1, 6), bool), "wrenches must hold real numbers, got dtype bool"),
        (np.array([W_ROW], dtype=object), "wrenches must hold real numbers, got dtype object"),
        (np.array([["0"] * 6]), "wrenches must hold real numbers, got dtype <U1"),
    ],
)  # fmt: skip
def test_the_python_doors_refuse_what_the_files_refuse(tmp_path, wrenches, words):
    """TaskRequirement(...), as_task(...) and the file reader name the same row and column."""
    rows = np.atleast_2d(np.asarray(wrenches, dtype=object)).tolist()
    for call in (
        lambda: TaskRequirement(wrenches),
        lambda: as_task(wrenches),
        lambda: mq.feasible(mq.Structure([(0, 0)]).configuration_matrix(), wrenches),
    ):
        with pytest.raises(ValueError) as info:
            call()
        assert str(info.value) == words
    if isinstance(wrenches, list) and isinstance(wrenches[0], list):  # as a file holds them
        path = tmp_path / "t.json"
        path.write_text(json.dumps({"wrenches": rows}))
        with pytest.raises(TaskFileError, match="^" + str(path) + ": wrenches: row"):
            TaskRequirement.load(path)


@pytest.mark.parametrize(
    "fields, words",
    [
        (dict(t=["0", "1"]), "t: sample 1 is '0', not a number"),
        (dict(t=np.array(["0", "1"])), "t must hold real numbers, got dtype <U1"),
        (dict(t=[0, True]), "t: sample 2 is true, not a number"),
        (dict(position=[[0, 0, 0], [0, "1", 0]]), "position: sample 2 holds '1'"),
        (dict(position=np.zeros((2, 3), dtype=object)),
         "position must hold real numbers, got dtype object"),
        (dict(velocity=[[0, 0, 0], [0, 0, b"0"]]), "velocity: sample 2 holds b'0'"),
    ],
)  # fmt: skip
def test_a_trajectory_refuses_strings_and_booleans(fields, words):
    given = {"t": [0.0, 1.0], "position": np.zeros((2, 3)), **fields}
    with pytest.raises(ValueError) as info:
        mq.Trajectory(**given)
    assert str(info.value).startswith(words), info.value


def test_numbers_of_every_kind_still_read():
    """NumPy scalars, ints and arrays of any real dtype pass the rule unchanged."""
    rows = [[np.float32(0.5), np.int64(0), 1, 0.0, np.float16(0), 0]]
    assert TaskRequirement(rows).wrenches.tolist() == [[0.5, 0, 1, 0, 0, 0]]
    assert as_task(np.ones((2, 6), np.int8)).wrenches.dtype == float
    traj = mq.Trajectory([np.float64(0), 1], [np.zeros(3), np.ones(3, np.float32)])
    assert traj.position[1].tolist() == [1.0, 1.0, 1.0]


# ---------------------------------------------------------------- modquad check: a certificate
@pytest.fixture(scope="module")
def certificate(tmp_path_factory):
    """The text of the screwdriver's certificate, as ``modquad solve --certificate`` writes it."""
    from modquad_gym.cli import main

    path = tmp_path_factory.mktemp("cert") / "c.json"
    argv = ["solve", "--task", "example:screwdriver", "--method", "exhaustive", "--quiet"]
    assert main([*argv, "--certificate", str(path)]) == 0
    return path.read_text()


def _feed(fifo, text: str, stop: threading.Event) -> threading.Thread:
    """A thread that writes ``text`` into ``fifo`` once a reader opens it, until ``stop`` is
    set: a reader that opens the pipe gets a certificate instead of blocking this test."""

    def run():
        while not stop.is_set():
            try:
                fd = os.open(fifo, os.O_WRONLY | os.O_NONBLOCK)
            except OSError:  # no reader yet
                time.sleep(0.01)
                continue
            try:
                os.set_blocking(fd, True)
                os.write(fd, text.encode())
            except OSError:  # the reader went away: it refused the pipe
                pass
            finally:
                os.close(fd)

    thread = threading.Thread(target=run, daemon=True)
    thread.start()
    return thread


@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="named pipes are POSIX")
def test_check_refuses_what_is_not_a_regular_file_before_reading(tmp_path, capsys, certificate):
    from modquad_gym.cli import main

    fifo = tmp_path / "fifo.json"
    os.mkfifo(fifo)
    stop = threading.Event()
    feeder = _feed(fifo, certificate, stop)
    try:
        for path in (fifo, tmp_path, "/dev/zero"):
            start = time.perf_counter()
            code = main(["check", str(path)])
            _, err = capsys.readouterr()
            assert_one_line_error(code, err, f"{path}: not a regular file")
            assert time.perf_counter() - start < 1.0  # /dev/zero: no 64 MiB read first
    finally:
        stop.set()
        feeder.join()


def test_check_reads_a_byte_order_mark_as_the_task_readers_do(tmp_path, capsys, certificate):
    from modquad_gym.cli import main

    path = tmp_path / "bom.json"
    path.write_bytes(b"\xef\xbb\xbf" + certificate.encode())
    assert main(["check", str(path)]) == 0
    assert capsys.readouterr().out.startswith("valid: the minimum is")


# ---------------------------------------------------------------- an export read back
def _unreadable_exports(tmp_path):
    """(path, words) of files the export readers must refuse, naming them."""
    pytest.importorskip("mujoco")
    folder = tmp_path / "adir.xml"
    folder.mkdir()
    garbage = tmp_path / "garbage.xml"
    garbage.write_bytes(b"<\xae\xff" * 50)
    cut = tmp_path / "cut.xml"
    cut.write_text('<mujoco model="m">\n  <worldbody>\n    <body name="structure">\n')
    large = tmp_path / "large.xml"
    with large.open("wb") as fh:
        fh.truncate((16 << 20) + 1)
    cases = [(folder, "not a regular file"), (garbage, "not UTF-8 text"),
             (cut, "XML parse error"), (large, "bytes, more than the"),
             (tmp_path / "none.xml", "cannot read")]  # fmt: skip
    if hasattr(os, "mkfifo"):
        os.mkfifo(tmp_path / "fifo.xml")
        cases.append((tmp_path / "fifo.xml", "not a regular file"))
    return cases


@pytest.mark.parametrize("reader", ["urdf_spec", "fly_mjcf"])
def test_the_export_readers_name_the_file_they_refuse(tmp_path, reader):
    from modquad_gym.sim.export import urdf_spec
    from modquad_gym.sim.export_flight import fly_mjcf

    read = {"urdf_spec": urdf_spec, "fly_mjcf": fly_mjcf}[reader]
    for path, words in _unreadable_exports(tmp_path):
        for given in (path, str(path)):
            with pytest.raises(ValueError) as info:
                read(given)
            message = str(info.value)
            assert message.startswith(f"{path}: ") and words in message, message
            assert "\n" not in message
    with pytest.raises(ValueError, match="^source must be a file path"):
        read("")  # not the working folder


# -------------------------------------------------------- what a JSON file may cost to parse
@pytest.mark.parametrize(
    "filler, words",
    [
        ("{}", "1,200,005 JSON arrays and objects, more than the 1,100,000 read"),
        ("[]", "1,200,005 JSON arrays and objects, more than the 1,100,000 read"),
        ("0", "8,100,006 commas between JSON values, more than the 8,000,000 read"),
    ],
)
def test_a_json_file_is_bounded_in_containers_and_values_before_parsing(tmp_path, filler, words):
    """An empty object costs 64 bytes parsed for 3 bytes of text: 33 million of them in `meta`
    (a 99 MB file) took 2.5 GB. Arrays and objects are counted together, values by their
    commas, before parsing."""
    n = 8_100_001 if filler == "0" else 1_200_000
    path = tmp_path / "big.json"
    path.write_text('{"wrenches": [[0, 0, 1, 0, 0, 0]], "meta": {"x": [' + ",".join([filler] * n))
    with path.open("a") as fh:
        fh.write("]}}")
    with pytest.raises(TaskFileError) as info:
        load_task(path)
    assert str(info.value).startswith(f"{path}: {words}"), info.value
    assert "refused before parsing" in str(info.value)


# ------------------------------------------------- a task larger than a search takes: refused early
def test_a_csv_beyond_the_task_limit_is_refused_before_parsing(tmp_path, monkeypatch):
    """The count of lines of numbers left room for a header of column numbers, so a file of
    limit + 1 wrenches was parsed whole; only a first row read as a header gets that room."""
    monkeypatch.setattr("modquad_gym.tasks.csvfile.MAX_WRENCHES", 100)
    monkeypatch.setattr("modquad_gym.tasks.csvfile._row", _no_work)  # no row may be parsed
    rows = "0,0,1,0,0,0\n" * 101
    for header, head in (("auto", "# f_max: 1\n"), ("yes", "fx,fy,fz,tx,ty,tz\n"),
                         ("no", ""), ("auto", "\ufeff"), ("auto", "")):  # fmt: skip
        path = tmp_path / "big.csv"
        path.write_text(head + rows.replace("\n", "\r" if header == "no" else "\n"))
        with pytest.raises(TaskFileError, match="more than the 100 wrenches .*before parsing"):
            TaskRequirement.load(path, csv_header=header)
    monkeypatch.undo()
    monkeypatch.setattr("modquad_gym.tasks.csvfile.MAX_WRENCHES", 100)
    path.write_text("0,1,2,3,4,5\n" + "0,0,1,0,0,0\n" * 100)  # a header of column numbers
    assert len(TaskRequirement.load(path, csv_header="yes")) == 100


@pytest.mark.parametrize("suffix", [".csv", ".npy"])
def test_solve_refuses_more_wrenches_than_a_search_takes_before_parsing(
    tmp_path, capsys, monkeypatch, suffix
):
    from modquad_gym.search.size import MAX_SEARCH_WRENCHES as MOST

    path = tmp_path / f"big{suffix}"
    TaskRequirement(np.tile([0.0, 0, 1, 0, 0, 0], (MOST + 1, 1))).save(path)
    reader = "read_csv" if suffix == ".csv" else "read_npy"
    monkeypatch.setattr(f"modquad_gym.tasks.requirement.{reader}", _no_work)
    code, _, err = run_main(capsys, "solve", "--task", str(path), "--method", "greedy",
                            "--n-max", "2")  # fmt: skip
    assert_one_line_error(code, err, f"{path}: the task has 10,001 wrenches", "convex hull")


def test_a_dynamic_task_too_long_to_search_is_told_to_sample_it_more_coarsely(tmp_path, capsys):
    k = 10_001
    t = np.linspace(0.0, 100.0, k)
    z = 1e-3 * np.sin(0.5 * t)  # every sample's acceleration its own
    task = mq.DynamicTask(mq.Trajectory(t, np.c_[0 * t, 0 * t, z]), f_max=2.0, name="long")
    words = "the task's trajectory has 10,001 distinct samples; a search takes at most 10,000"
    with pytest.raises(ValueError) as info:
        mq.SearchProblem(task, n_max=2)
    message = str(info.value)
    assert message.startswith(words) and "trajectory.t" in message and "hull" not in message
    path = tmp_path / "long.json"
    task.save(path)
    code, _, err = run_main(capsys, "solve", "--task", str(path), "--method", "greedy",
                            "--n-max", "2")  # fmt: skip
    assert_one_line_error(code, err, f"{path}: {words}", "sample the trajectory more coarsely")


# ------------------------------------------------ meta: read only what can be written back
@pytest.mark.parametrize(
    "name, text, words",
    [
        ("s.json", '{"wrenches": [[0, 0, 1, 0, 0, 0]], "meta": {"a": NaN}}',
         "meta['a'] is nan: JSON has no NaN or infinity"),
        ("s.csv", '# meta: {"a": {"b": [1, Infinity]}}\n0,0,1,0,0,0\n',
         "line 1: meta['a']['b'][1] is inf: JSON has no NaN or infinity"),
        ("d.json", json.dumps(_dynamic()).replace('"name"', '"meta": {"x": -Infinity}, "name"'),
         "meta['x'] is -inf: JSON has no NaN or infinity"),
    ],
)  # fmt: skip
def test_meta_that_cannot_be_written_back_is_refused_on_read(tmp_path, capsys, name, text, words):
    path = tmp_path / name
    path.write_text(text)
    with pytest.raises(TaskFileError) as info:
        load_task(path)
    assert str(info.value).startswith(f"{path}: {words}"), info.value
    suite = tmp_path / "suite.json"
    if name.endswith(".json"):  # a suite's task is read by the same rule
        suite.write_text('{"tasks": [' + text + "]}")
        with pytest.raises(TaskFileError, match=r"task 1: meta\["):
            load_suite(suite)
    code, _, err = run_main(capsys, "solve", "--task", str(path), "--method", "greedy")
    assert_one_line_error(code, err, f"{path}: ", words)


# -------------------------------------------------- small acceptances: refused as their peers are
def test_an_npy_file_holds_one_array_and_nothing_after_it(tmp_path, capsys):
    path = tmp_path / "extra.npy"
    np.save(path, np.array([[0, 0, 1, 0, 0, 0]]))
    whole = path.read_bytes()
    path.write_bytes(whole + b"garbage" * 100)  # np.load reads the array and ignores the rest
    words = "748 bytes of data where its header describes a 1 x 6 array of 48 (bytes after it)"
    with pytest.raises(TaskFileError, match=f"^{path}: {re.escape(words)}"):
        TaskRequirement.load(path)
    code, _, err = run_main(capsys, "solve", "--task", str(path), "--method", "greedy")
    assert_one_line_error(code, err, f"{path}: {words}")
    path.write_bytes(whole)
    assert TaskRequirement.load(path).wrenches.tolist() == [[0, 0, 1, 0, 0, 0]]


@pytest.mark.parametrize("digit", ["\u0661", "\uff11", "\u00b9", "\u0967"])
def test_csv_numbers_are_ascii_decimals(tmp_path, digit):
    """\\d matched any Unicode digit and float() read it: '0,0,\u0661,0,0,0' was a wrench."""
    path = tmp_path / "u.csv"
    path.write_text(f"0,0,{digit},0,0,0\n", encoding="utf-8")
    with pytest.raises(TaskFileError, match=f"fz = '{digit}' is not a number"):
        TaskRequirement.load(path)


@pytest.mark.parametrize("key", ["meta", "payload", "exerted"])
def test_null_is_refused_in_a_dynamic_task_as_in_a_static_one(tmp_path, key):
    words = {
        "meta": "'meta' must be an object, got None",
        "payload": "payload must be an object with 'mass' (kg), got None",
        "exerted": "exerted must be a list of [fx, fy, fz, tx, ty, tz] rows, got None",
    }
    path = tmp_path / "d.json"
    path.write_text(json.dumps(_dynamic(**{key: None})))
    with pytest.raises(TaskFileError, match=f"^{re.escape(f'{path}: {words[key]}')}$"):
        load_task(path)
    static = tmp_path / "s.json"
    static.write_text(json.dumps({"wrenches": [W_ROW], "meta": None}))
    with pytest.raises(TaskFileError, match="'meta' must be an object, got None"):
        load_task(static)


@pytest.mark.parametrize(
    "name, text",
    [
        ("s.json", '{"wrenches": [[0, 0, 1, 0, 0, 0]], "name": ""}'),
        ("d.json", json.dumps({**_dynamic(), "name": ""})),
        ("s.csv", '# name: ""\n0,0,1,0,0,0\n'),
    ],
)
def test_an_empty_task_name_is_refused(tmp_path, capsys, name, text):
    """A missing name takes the file's; an empty one was kept and printed as task ''."""
    path = tmp_path / name
    path.write_text(text)
    code, out, err = run_main(capsys, "solve", "--task", str(path), "--method", "greedy")
    assert_one_line_error(code, err, str(path), "name")
    assert "without a name" in err or "must be a non-empty string" in err
    path.write_text(text.replace('"name": "", ', "").replace(', "name": ""', ""))
    if not name.endswith(".csv"):
        assert load_task(path).name == path.stem
    for make in (lambda: TaskRequirement([W_ROW], name=""),
                 lambda: mq.DynamicTask(mq.Trajectory(**RISING), name="")):  # fmt: skip
        with pytest.raises(ValueError, match="^name must be a non-empty string, got ''"):
            make()


def test_a_dynamic_f_max_error_names_the_key_once(tmp_path):
    path = tmp_path / "d.json"
    path.write_text(json.dumps({**_dynamic(), "f_max": -0.0}))
    with pytest.raises(TaskFileError) as info:
        load_task(path)
    assert str(info.value) == f"{path}: f_max must be positive, got -0"
