"""Issue 24, family 4: bounded before work. Sizes are checked before reading (bytes, rows, an
.npy header), memory before the searches allocate, workers against the machine, time estimates
before a simulation starts, a cluster address before Ray retries."""

from __future__ import annotations

import time

import numpy as np
import pytest
from test_hardening import assert_rejected, run_main

import modquad_gym as mq
from modquad_gym.core import resources
from modquad_gym.core.distributed import Engine, ray_installed
from modquad_gym.tasks import TaskFileError, TaskRequirement, load_suite


def test_csv_rows_are_refused_past_the_limit_without_parsing_the_rest(tmp_path, monkeypatch):
    monkeypatch.setattr("modquad_gym.tasks.csvfile.MAX_WRENCHES", 100)
    path = tmp_path / "big.csv"
    path.write_text("0,0,1,0,0,0\n" * 100_000)
    t0 = time.perf_counter()
    with pytest.raises(TaskFileError, match="more than the 100 wrenches"):
        TaskRequirement.load(path)
    assert time.perf_counter() - t0 < 5  # stopped at row 101, not after 100,000


def test_json_arrays_are_counted_before_parsing(tmp_path, monkeypatch):
    monkeypatch.setattr("modquad_gym.tasks.files.MAX_JSON_CONTAINERS", 50)
    path = tmp_path / "big.json"
    path.write_text('{"wrenches": [' + ", ".join(["[0, 0, 1, 0, 0, 0]"] * 60) + "]}")
    with pytest.raises(TaskFileError, match="62 JSON arrays and objects, more than the 50"):
        TaskRequirement.load(path)


def test_special_files_are_refused_before_reading(tmp_path):
    with pytest.raises(TaskFileError, match="not a regular file"):
        load_suite("/dev/zero")  # would read forever


def test_typed_search_memory_is_estimated_before_it_allocates():
    """40 types at n_max 4 asked for 1 TiB, 127 types at n_max 3 more than 4 GB: refused at
    once, naming the sizes."""
    types = [mq.ModuleType.from_tilts([0.01 * i, -0.01 * i] * 2, name=f"t{i}") for i in range(127)]
    for k, n in ((40, 4), (127, 3), (16, 7)):
        t0 = time.perf_counter()
        with pytest.raises(resources.ResourceError, match=f"n_max={n} with {k} module types"):
            mq.exhaustive_search([[0, 0, 2.0, 0, 0, 0]], n_max=n, modules=types[:k])
        assert time.perf_counter() - t0 < 2


def test_memory_check_names_what_and_how_much(monkeypatch):
    monkeypatch.setattr(resources, "available_memory", lambda: 2 * resources.GIB)
    resources.check_memory(resources.GIB, "a small run")
    with pytest.raises(resources.ResourceError, match=r"a big run needs about 4 GiB.*2\.0 GiB"):
        resources.check_memory(4 * resources.GIB, "a big run")


def test_optima_records_list_a_bounded_number_of_structures():
    """A level where every structure is optimal: the record keeps the first ones, counts all."""
    from modquad_gym.search import optimal_level

    W = np.array([[0.0, 0.0, 4 * 0.7071 * 3 + 0.3, 0.0, 0.0, 0.0]])  # needs 4 modules of lift
    full = optimal_level(W, n_max=4)
    capped = optimal_level(W, n_max=4, max_keys=3)
    assert full.n_modules == capped.n_modules == 4 and full.count == len(full.keys) == 19
    assert capped.keys == full.keys[:3] and capped.count == 19


def test_workers_are_capped_to_the_machine(capsys):
    engine = Engine(256, option="--workers")
    assert engine.workers == resources.usable_cpus()
    if engine.workers < 256:
        assert "--workers 256" in capsys.readouterr().err


@pytest.mark.skipif(not ray_installed(), reason="Ray not installed")
def test_an_unreachable_cluster_fails_at_once_in_one_line(tmp_path, capsys):
    task = tmp_path / "t.json"
    task.write_text('{"wrenches": [[0, 0, 6, 0, 0, 0]]}')
    t0 = time.perf_counter()
    argv = ["optima", "--tasks", str(task), "--out", str(tmp_path / "o.jsonl")]
    code, _, err = run_main(capsys, *argv, "--ray-address", "127.0.0.1:1", "--workers", "2")
    assert_rejected(code, err, "127.0.0.1:1", "nothing answers")
    assert len(err.strip().splitlines()) == 1 and time.perf_counter() - t0 < 20


def test_validate_refuses_an_absurd_run_before_simulating(tmp_path, capsys, monkeypatch):
    monkeypatch.setattr("modquad_gym.cli.solve.solver", lambda *a, **k: pytest.fail("solved"))
    path = tmp_path / "big.npy"  # within what a search takes, hours of hovering
    np.save(path, np.tile([0.0, 0, 3, 0, 0, 0], (9_000, 1)))
    argv = ["validate", "--task", str(path), "--all-wrenches", "--out", str(tmp_path / "v")]
    code, _, err = run_main(capsys, *argv)
    assert_rejected(code, err, "big.npy", "9,000 wrenches", "--allow-long")
    np.save(path, np.tile([0.0, 0, 3, 0, 0, 0], (200_000, 1)))  # more than a search takes
    code, _, err = run_main(capsys, *argv)
    assert_rejected(code, err, "big.npy", "200,000 wrenches", "at most 10,000")


def test_show_refuses_a_structure_too_large_to_draw(tmp_path, capsys):
    cells = str([[i % 100, i // 100] for i in range(10_000)])
    code, _, err = run_main(capsys, "show", "--cells", cells, "--out", str(tmp_path / "s.png"))
    assert_rejected(code, err, "10,000 modules", "at most 256")
