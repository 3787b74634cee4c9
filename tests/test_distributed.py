"""The Ray engine (modquad_gym.core.distributed):
Ray gives the serial answers, in batches and in the
split search; faults (a task that raises, a worker killed mid-batch) leave the batch complete;
the optima dataset resumes; a two-node cluster started with `ray start` on this host works."""

import importlib.util
import json
import os
import secrets
import shutil
import signal
import socket
import subprocess
import sys
import time
from itertools import islice
from pathlib import Path

import numpy as np
import pytest

import modquad_gym.search.exhaustive as exhaustive
import modquad_gym.search.split as split
from modquad_gym.cli import main
from modquad_gym.core.distributed import Engine, Failed, map_tasks
from modquad_gym.geometry.polyominoes import PolyominoStream
from modquad_gym.scoring.optima import lock_path, read_dataset
from modquad_gym.search import exhaustive_search
from modquad_gym.tasks import PlantedTasks, save_suite, task_files

ray = pytest.importorskip("ray")
ROOT = Path(__file__).resolve().parents[1]


def no_seconds(record: dict) -> dict:
    """The record without its timings (seconds; the default search's history of them)."""
    return {k: v for k, v in record.items() if k not in ("seconds", "history")}


def planted_wrenches(n: int, t: int, seed: int) -> np.ndarray:
    task = PlantedTasks(n_modules=n, n_wrenches=t, boundary_fraction=1.0)
    return task(np.random.default_rng(seed)).wrenches


@pytest.fixture(scope="module")
def local_ray():
    """One embedded Ray (2 CPUs) for the module: every Engine below joins it. Functions of this
    test module travel by value (Ray's workers cannot import it)."""
    ray.cloudpickle.register_pickle_by_value(sys.modules[__name__])
    from modquad_gym.core.ray_session import shutdown, start_local

    options = {"include_dashboard": False, "log_to_driver": False, "logging_level": "ERROR"}
    session = start_local(ray, 2, options)
    yield
    shutdown(ray, session)  # its session folder too


@pytest.fixture
def task_dir(tmp_path):
    """Six small planted tasks and one malformed file."""
    folder = tmp_path / "tasks"
    folder.mkdir()
    gen = PlantedTasks(n_modules=(2, 4), n_wrenches=(8, 16))
    for i in range(6):
        gen(np.random.default_rng(40 + i)).save(folder / f"t{i}.json")
    (folder / "t_bad.json").write_text('{"wrenches": [[1, 2, 3]]}')
    return folder


def test_import_does_not_load_ray():
    code = "import sys, modquad_gym; print('ray' in sys.modules)"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "False"


def test_serial_engine_needs_no_ray():
    engine = Engine(1)
    assert not engine.use_ray
    assert engine.map(abs, [-1, 2, -3]) == [1, 2, 3]
    out = engine.map(lambda x: 1 // x, [1, 0], labels=["a", "b"], catch=True)
    assert out[0] == 1 and isinstance(out[1], Failed) and out[1].label == "b"
    with pytest.raises(ZeroDivisionError):
        engine.map(lambda x: 1 // x, [1, 0])
    assert engine.first(lambda x: x * x, range(10), lambda r: r > 10) == [0, 1, 4, 9, 16]


def test_ray_map_and_first_equal_serial(local_ray):
    items = list(range(23))
    work = lambda x: (x * 7919) % 31  # noqa: E731
    serial = Engine(1).map(work, items)
    with Engine(2) as engine:
        assert engine.use_ray
        assert engine.map(work, items, progress=True) == serial
        first = engine.first(work, items, lambda r: r > 25)
    k = next(i for i, r in enumerate(serial) if r > 25)
    assert first == serial[: k + 1]
    assert map_tasks(work, items, workers=2) == serial


def test_first_stops_early_without_a_soft_cancel(local_ray, monkeypatch):
    """What still runs after the accepted item is cancelled with force: Ray 2.60's soft cancel
    of a task that is just finishing aborts the driver (here: the test run) about once in a
    hundred early stops; 12 early stops here, each checked against the serial answer."""
    forced = []
    cancel = ray.cancel

    def recording_cancel(ref, *, force=False, recursive=True):
        forced.append(force)
        cancel(ref, force=force, recursive=recursive)

    monkeypatch.setattr(ray, "cancel", recording_cancel)

    def work(x):
        time.sleep(0.002 * (x % 3))
        return x

    with Engine(2) as engine:
        for trial in range(12):
            k = trial % 4
            assert engine.first(work, range(12), k.__eq__) == list(range(k + 1))
    assert forced and all(forced)


def test_raising_task_is_reported_by_label(local_ray):
    def parse(text):
        return int(text)

    out = map_tasks(parse, ["1", "x", "3"], workers=2, labels=["a", "b", "c"], catch=True)
    assert out[0] == 1 and out[2] == 3
    assert out[1] == Failed("b", "invalid literal for int() with base 10: 'x'")


def test_an_unexpected_failure_is_named_by_its_type_in_one_line():
    """The serial path reports as Ray's: an expected failure by its message, another (a bug in
    the item's code) with its type, a message of several lines on one."""

    def item(kind):
        raise {"value": ValueError("bad\nrow 3"), "zero": ZeroDivisionError("x / 0"),
               "bare": RuntimeError()}[kind]  # fmt: skip

    out = map_tasks(item, ["value", "zero", "bare"], workers=1, labels=list("abc"), catch=True)
    assert out == [Failed("a", "bad row 3"), Failed("b", "ZeroDivisionError: x / 0"),
                   Failed("c", "RuntimeError")]  # fmt: skip


def test_killed_worker_is_retried_with_identical_results(local_ray, tmp_path):
    """The first attempt at item 5 kills its own worker process (SIGKILL); Ray resubmits it."""
    marker = tmp_path / "killed"
    driver = os.getpid()

    def solve(seed):
        if seed == 5 and not marker.exists():
            marker.write_text(str(os.getpid()))
            if os.getpid() == driver:  # never kill the test run itself (a serial fallback)
                raise RuntimeError("item 5 ran in the driver process, not in a worker")
            os.kill(os.getpid(), signal.SIGKILL)
        return exhaustive_search(planted_wrenches(3, 12, seed), n_max=4).to_dict()

    seeds = list(range(8))
    marker.write_text("serial: no kill in this process")
    serial = [no_seconds(r) for r in Engine(1).map(solve, seeds)]
    marker.unlink()
    with Engine(2) as engine:
        distributed = engine.map(solve, seeds, catch=True)
    assert marker.exists(), "the worker was not killed"
    assert int(marker.read_text()) != os.getpid()
    assert [no_seconds(r) for r in distributed] == serial
    # without retries the same kill is a failure of that item only, reported by label
    marker.unlink()
    out = map_tasks(solve, seeds, workers=2, catch=True, max_retries=0)
    assert isinstance(out[5], Failed) and out[5].label == "5"
    assert [no_seconds(r) for i, r in enumerate(out) if i != 5] == serial[:5] + serial[6:]


def test_ranges_resume_the_enumeration_where_they_start():
    """A level cut into ranges (each a snapshot of the stream where it starts) holds the level's
    structures in canonical order, like the stream read in one go."""
    whole = np.concatenate(list(PolyominoStream(9, 97)))
    parts = []
    for count, state in split.ranges(9, 97):
        stream = PolyominoStream(9, 97)
        stream.restore(state)
        parts.extend(islice(stream, count))
    assert np.array_equal(np.concatenate(parts), whole)
    with pytest.raises(ValueError, match="another stream"):
        PolyominoStream(8, 97).restore(state)


def test_split_search_equals_serial(local_ray, monkeypatch):
    """Levels split into Ray tasks (threshold lowered so level 8 splits into 15 ranges of 2
    chunks of 97 structures) give the serial answer, for any number of workers."""
    monkeypatch.setattr(exhaustive, "PARALLEL_FROM", 1000)
    monkeypatch.setattr(split, "CHUNKS_PER_RANGE", 2)
    for seed in (1, 2):
        W = planted_wrenches(8, 12, seed)
        serial = exhaustive_search(W, n_max=8, chunk=97)
        two = exhaustive_search(W, n_max=8, chunk=97, engine=Engine(2))
        three = exhaustive_search(W, n_max=8, chunk=97, engine=Engine(3))
        assert serial.structure is not None
        assert serial.structure.key == two.structure.key == three.structure.key
        assert two.evaluated == three.evaluated  # each range learns alone: same work
    impossible = np.array([[0.0, 0.0, 1.0, 0.0, 0.0, 50.0]])  # no structure: every range runs
    r = exhaustive_search(impossible, n_max=8, chunk=97, engine=Engine(2))
    assert r.structure is None and r.certified


def test_solve_batch_reports_a_bad_file_and_finishes(local_ray, task_dir, capsys):
    rc = main(["solve", "--task", str(task_dir), "--n-max", "4", "--json", "--workers", "2"])
    captured = capsys.readouterr()
    assert rc == 2
    assert "t_bad.json" in captured.err and "6 of 7" not in captured.err
    lines = [json.loads(line) for line in captured.out.splitlines()]
    assert [Path(r["task"]).name for r in lines] == [f"t{i}.json" for i in range(6)]
    rc = main(["solve", "--task", str(task_dir / "t*.json"), "--n-max", "4", "--json",
               "--workers", "1"])  # fmt: skip
    serial = [json.loads(line) for line in capsys.readouterr().out.splitlines()]
    assert rc == 2 and [no_seconds(r) for r in lines] == [no_seconds(r) for r in serial]


def test_optima_dataset_serial_equals_ray_and_resumes(local_ray, task_dir, tmp_path, capsys):
    serial, ray_out, resumed = (tmp_path / f"{n}.jsonl" for n in ("serial", "ray", "resumed"))
    common = ["optima", "--tasks", str(task_dir), "--n-max", "5", "--quiet"]
    assert main([*common, "--out", str(serial), "--workers", "1"]) == 2  # the bad file
    assert "t_bad.json" in capsys.readouterr().err
    assert main([*common, "--out", str(ray_out), "--workers", "2"]) == 2
    by_task = lambda path: {r["task"]: no_seconds(r) for r in read_dataset(path)[0]}  # noqa: E731
    reference = by_task(serial)
    assert len(reference) == 6 and by_task(ray_out) == reference
    for record in reference.values():
        assert record["optimum"] == len(record["structures"][0]) and record["count"] >= 1
        W = json.loads(Path(record["task"]).read_text())["wrenches"]
        assert record["optimum"] == exhaustive_search(np.array(W), n_max=5).n_modules

    # an interrupted run: two records and half of a third were written
    lines = ray_out.read_bytes().splitlines(keepends=True)
    resumed.write_bytes(b"".join(lines[:2]) + lines[2][: len(lines[2]) // 2])
    assert main([*common, "--out", str(resumed), "--workers", "2"]) == 2
    out = capsys.readouterr().out
    assert "4 records written, 2 already there, an unfinished last line dropped" in out
    assert resumed.read_bytes().startswith(b"".join(lines[:2]))
    assert by_task(resumed) == reference
    assert main([*common, "--out", str(resumed), "--workers", "2"]) == 2  # nothing left to do
    assert "0 records written, 6 already there" in capsys.readouterr().out
    assert by_task(resumed) == reference

    # a rerun with another budget would mix two datasets: refused
    other = ["optima", "--tasks", str(task_dir), "--n-max", "6", "--quiet", "--workers", "1"]
    assert main([*other, "--out", str(resumed)]) == 2
    assert "another n_max" in capsys.readouterr().err


@pytest.mark.slow
def test_train_seeds_run_in_parallel_into_their_own_folders(local_ray, tmp_path):
    pytest.importorskip("sb3_contrib")
    spec = importlib.util.spec_from_file_location("train_script", ROOT / "train.py")
    train = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(train)
    gen = PlantedTasks(n_modules=2, n_wrenches=24)
    suite = save_suite([gen(np.random.default_rng(s)) for s in (0, 1)], tmp_path / "tiny.json")
    out = tmp_path / "runs"
    argv = ["--task-source", str(suite), "--n-max", "3", "--out", str(out), "--tensorboard",
            str(tmp_path / "tb"), "--no-report", "--no-progress", "--n-eval", "2", "--timesteps",
            "256", "--eval-freq", "128", "--demo-tasks", "8", "--bc-epochs", "2",
            "--seeds", "0", "1"]  # fmt: skip
    assert train.main(argv) == 0
    for seed in (0, 1):
        config = json.loads((out / f"seed-{seed}" / "config.json").read_text())
        assert config["seed"] == seed and (out / f"seed-{seed}" / "model.zip").is_file()
        assert "--seeds" not in config["command"] and f"--seed {seed}" in config["command"]
        assert config["imitation"]["expert_episodes"] == 8


def test_task_files_and_suite_names_are_checked(tmp_path, task_dir, capsys):
    assert [p.name for p in task_files([task_dir / "t1.json", str(task_dir / "t[12].json")])] == [
        "t1.json", "t2.json"]  # fmt: skip
    (tmp_path / "empty").mkdir()
    with pytest.raises(ValueError, match="holds no task file"):
        task_files([tmp_path / "empty"])
    with pytest.raises(ValueError, match="no file matches"):
        task_files([str(tmp_path / "*.csv")])
    out = tmp_path / "o.jsonl"
    assert main(["optima", "--suite", "nope", "--out", str(out), "--workers", "1"]) == 2
    assert "heldout_planted" in capsys.readouterr().err
    out.write_text("not a record\n")
    args = ["optima", "--tasks", str(task_dir / "t0.json"), "--out", str(out), "--workers", "1"]
    assert main([*args, "--quiet"]) == 2
    assert "line 1 is not an optima record" in capsys.readouterr().err
    assert main([*args, "--quiet", "--force"]) == 0
    assert len(read_dataset(out)[0]) == 1


def test_a_refused_cluster_join_names_token_authentication(task_dir, tmp_path, monkeypatch,
                                                          capsys):  # fmt: skip
    """A driver that sends no token to a head with token authentication (Ray >= 2.59 turns it on
    where a token exists) is refused by Ray after its retries: the one line says what to set."""
    with socket.socket() as head:  # something listens: the address passes the reachability check
        head.bind(("127.0.0.1", 0))
        head.listen()
        address = f"127.0.0.1:{head.getsockname()[1]}"

        def refused(*args, **kwargs):
            raise ConnectionError(f"Failed to connect to Ray cluster at {address}.")

        monkeypatch.setattr(ray, "is_initialized", lambda: False)
        monkeypatch.setattr(ray, "init", refused)
        args = ["optima", "--task", str(task_dir / "t[0-3].json"), "--out",
                str(tmp_path / "o.jsonl"), "--ray-address", address, "--quiet"]  # fmt: skip
        monkeypatch.delenv("RAY_AUTH_MODE", raising=False)
        assert main(args) == 2
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and f"Ray cluster {address}: Failed to connect" in err
        assert "RAY_AUTH_MODE=token" in err and "RAY_AUTH_TOKEN" in err
        out = tmp_path / "o.jsonl"  # refused before anything was made
        assert not out.exists() and not lock_path(out).exists()
        monkeypatch.setenv("RAY_AUTH_MODE", "token")  # sent a token: the hint would mislead
        assert main(args) == 2
        err = capsys.readouterr().err
        assert "Failed to connect" in err and "RAY_AUTH_MODE" not in err


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


DRIVER = """
import json, sys
import ray
from modquad_gym.core.distributed import Engine

def node(_):
    import time
    time.sleep(0.3)
    return ray.get_runtime_context().get_node_id()

with Engine() as engine:  # no options: RAY_ADDRESS names the cluster
    cpus = engine.cluster_cpus()
    ran_on = len(set(engine.map(node, range(8))))
print(json.dumps({"cpus": cpus, "ran_on": ran_on}))
"""


@pytest.mark.slow
def test_two_node_cluster_on_this_host(task_dir, tmp_path):
    """`ray start --head` and `ray start --address` on this host make a two-node cluster
    (each node one CPU, token authentication with a fresh token); a driver given only
    RAY_ADDRESS uses both nodes, and `modquad optima` on it writes the serial dataset."""
    ray_cli = Path(sys.executable).with_name("ray")
    ray_cli = str(ray_cli) if ray_cli.is_file() else shutil.which("ray")
    if ray_cli is None:
        pytest.skip("no `ray` command beside this Python")
    port = _free_port()
    env = {**os.environ, "RAY_AUTH_MODE": "token", "RAY_AUTH_TOKEN": secrets.token_hex(16),
           "PYTHONPATH": str(ROOT), "RAY_USAGE_STATS_ENABLED": "0"}  # fmt: skip
    env.pop("RAY_ADDRESS", None)
    common = ["--block", "--num-cpus=1", "--disable-usage-stats"]
    nodes = []
    try:
        nodes.append(subprocess.Popen(
            [ray_cli, "start", "--head", f"--port={port}", "--include-dashboard=false", *common],
            env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL))  # fmt: skip
        address = f"127.0.0.1:{port}"
        probe = [sys.executable, "-c", f"import ray; ray.init(address={address!r})"]
        deadline = time.monotonic() + 90
        while subprocess.run(probe, env=env, capture_output=True).returncode != 0:
            assert time.monotonic() < deadline, "the head node did not start"
            time.sleep(1)
        nodes.append(subprocess.Popen(
            [ray_cli, "start", f"--address={address}", *common],
            env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL))  # fmt: skip
        driver_env = {**env, "RAY_ADDRESS": address}
        deadline = time.monotonic() + 90
        while True:
            out = subprocess.run([sys.executable, "-c", DRIVER], env=driver_env, cwd=ROOT,
                                 capture_output=True, text=True, timeout=120)  # fmt: skip
            assert out.returncode == 0, out.stderr[-2000:]
            seen = json.loads(out.stdout.splitlines()[-1])
            if seen["cpus"] == 2 or time.monotonic() > deadline:
                break
            time.sleep(1)
        assert seen["cpus"] == 2 and seen["ran_on"] == 2, seen

        dataset = tmp_path / "cluster.jsonl"
        cmd = [sys.executable, "-m", "modquad_gym.cli", "optima", "--tasks", str(task_dir),
               "--n-max", "5", "--out", str(dataset), "--quiet"]  # fmt: skip
        out = subprocess.run(cmd, env=driver_env, cwd=ROOT, capture_output=True, text=True,
                             timeout=300)  # fmt: skip
        assert out.returncode == 2 and "t_bad.json" in out.stderr, out.stderr[-2000:]
    finally:
        for proc in reversed(nodes):  # SIGTERM: `ray start --block` stops what it started
            proc.terminate()
            try:
                proc.wait(timeout=60)
            except subprocess.TimeoutExpired:
                proc.kill()
    serial = tmp_path / "serial.jsonl"
    assert main(["optima", "--tasks", str(task_dir), "--n-max", "5", "--out", str(serial),
                 "--quiet", "--workers", "1"]) == 2  # fmt: skip
    by_task = lambda path: {r["task"]: no_seconds(r) for r in read_dataset(path)[0]}  # noqa: E731
    assert by_task(dataset) == by_task(serial) and len(by_task(serial)) == 6
