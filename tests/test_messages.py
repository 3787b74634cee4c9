"""Issue 24, family 5: honest words. A heuristic that fails says it found nothing (not that
nothing exists); every message names the file, the 1-based row, the option or the argument."""

from __future__ import annotations

import argparse
import sys

import gymnasium as gym
import numpy as np
import pytest
from test_hardening import assert_rejected, run_bench, run_main

import modquad_gym as mq
from modquad_gym.cli.solve import print_result
from modquad_gym.search import SearchResult
from modquad_gym.tasks import TaskRequirement


def _printed(capsys, certified: bool, method: str) -> str:
    args = argparse.Namespace(json=False, method=method, n_max=7)
    result = SearchResult(
        structure=None, n_modules=None, evaluated=3, oracle_calls=3, seconds=0.0,
        certified=certified, method=method, n_max=7,
    )  # fmt: skip
    print_result(args, "t.json", TaskRequirement([[0, 0, 6, 0, 0, 0]], name="t"), result)
    return capsys.readouterr().out


@pytest.mark.parametrize("method", ["ppo", "random", "centrosymmetric", "greedy"])
def test_a_failed_heuristic_does_not_claim_that_nothing_exists(capsys, method):
    out = _printed(capsys, certified=False, method=method)
    assert f"no answer: {method} found no structure of up to 7 modules" in out
    assert "one may still exist" in out and "satisfies" not in out


def test_a_certified_search_says_that_nothing_exists(capsys):
    out = _printed(capsys, certified=True, method="exhaustive")
    said = "no structure of up to 7 modules satisfies the task (proved: it needs at least 8; try"
    assert f"infeasible: {said} --n-max 8 or more)" in out


def test_scale_errors_name_the_file_and_a_one_based_row(tmp_path, capsys):
    path = tmp_path / "scale.json"
    path.write_text('{"wrenches": [[0, 0, 1, 0, 0, 0], [0, 0, 1e300, 0, 0, 0]]}')
    code, _, err = run_main(capsys, "solve", "--task", str(path))
    assert_rejected(code, err, "scale.json", "wrench row 2")


def test_too_many_wrenches_name_the_file_and_a_batch_goes_on(tmp_path, capsys, monkeypatch):
    """A task of more wrenches than a search takes is refused before any work, naming its file;
    in a batch the other tasks are still solved."""
    monkeypatch.chdir(tmp_path)
    rows = "\n".join("0,0,1,0,0,0" for _ in range(10_001))
    (tmp_path / "a_big.csv").write_text(rows + "\n")
    (tmp_path / "b_ok.json").write_text('{"wrenches": [[0, 0, 1, 0, 0, 0]]}')
    code, _, err = run_main(capsys, "solve", "--task", "a_big.csv")
    assert_rejected(code, err, "a_big.csv", "10,001 wrenches")
    code, out, err = run_main(capsys, "solve", "--task", ".", "--json", "--workers", "1")
    assert code == 2 and "a_big.csv: the task has 10,001 wrenches" in err
    assert '"n_modules": 1' in out


def test_bench_oracle_names_its_missing_extra_before_work(tmp_path, capsys, monkeypatch):
    monkeypatch.setitem(sys.modules, "cvxpy", None)  # as if not installed
    code, _, err = run_bench(capsys, "oracle", "--out", str(tmp_path / "rep"))
    assert_rejected(code, err, "cvxpy", "modquad_gym[test]")
    assert not (tmp_path / "rep").exists() or not any((tmp_path / "rep").iterdir())


def test_score_refuses_a_bad_solver_before_the_benchmark_starts(tmp_path, capsys):
    code, _, err = run_main(capsys, "score", "--solver", "os:system", "--out",
                            str(tmp_path / "rep"))  # fmt: skip
    assert_rejected(code, err, "--solver 'os:system'", "standard-library")
    assert "benchmark:" not in err  # no progress bar: nothing was started


def test_generate_refuses_an_f_max_that_solve_would_refuse(tmp_path, capsys):
    out = tmp_path / "tiny.json"
    code, _, err = run_main(capsys, "task", "generate", "--kind", "paper", "--f-max", "1e-300",
                            "--out", str(out))  # fmt: skip
    assert_rejected(code, err, "--f-max 1e-300 is too small", "units of f_max")
    assert not out.exists()


def test_an_empty_task_path_is_refused(tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "a.json").write_text('{"wrenches": [[0, 0, 1, 0, 0, 0]]}')
    code, _, err = run_main(capsys, "solve", "--task", "")
    assert_rejected(code, err, "--task", "empty path")


def test_a_folder_as_model_is_named_a_folder(tmp_path, capsys):
    pytest.importorskip("sb3_contrib")
    task = tmp_path / "t.json"
    task.write_text('{"wrenches": [[0, 0, 1, 0, 0, 0]]}')
    argv = ["solve", "--task", str(task), "--method", "ppo", "--model", str(tmp_path)]
    code, _, err = run_main(capsys, *argv)
    assert_rejected(code, err, "--model", "a folder")


def test_validate_blames_only_options_the_user_gave(tmp_path, capsys, monkeypatch):
    """--hover-seconds 0.5 alone is fine (the default ramp is shortened); a ramp the user gave
    longer than the segment is refused naming it."""
    monkeypatch.setattr("modquad_gym.cli.common.load_task", lambda *a: pytest.fail("loaded"))
    task = str(tmp_path / "t.json")
    argv = ["validate", "--task", task, "--hover-seconds", "0.5", "--out", str(tmp_path / "v")]
    code, _, err = run_main(capsys, *argv, "--load-ramp-seconds", "2")
    assert_rejected(code, err, "--load-ramp-seconds", "0.5")
    with pytest.raises(pytest.fail.Exception, match="loaded"):  # the check passed
        run_main(capsys, *argv)


def test_api_errors_name_the_argument():
    A = mq.Structure([(0, 0), (1, 0)]).configuration_matrix()
    ragged = [[0, 0, 1, 0, 0, 0], [0, 0, 1]]
    for call in (lambda: mq.feasible(A, ragged), lambda: mq.TaskRequirement(ragged),
                 lambda: mq.exhaustive_search(ragged, n_max=2)):  # fmt: skip
        with pytest.raises(ValueError, match="wrenches must be a rectangular array: row 2 has 3"):
            call()
    with pytest.raises(ValueError, match="A must be a rectangular array"):
        mq.feasible([[1, 2], [3]], ragged[:1])
    with pytest.raises(ValueError, match="seed must be >= 0, got -1"):
        mq.random_search([[0, 0, 1, 0, 0, 0]], n_max=2, seed=-1)
    with pytest.raises(ValueError, match="modules must be"):
        mq.exhaustive_search([[0, 0, 1, 0, 0, 0]], n_max=2, modules=5)
    with pytest.raises(ValueError, match="modules must be"):
        gym.make("ModQuadAssembly-v0", modules=5)


def test_restore_refuses_none_and_states_of_other_environments():
    """An 11-module state into an n_max 7 env and a mixed state into a one-type env used to be
    accepted (same task object)."""
    from modquad_gym.envs.assembly import ModQuadAssemblyEnv
    from modquad_gym.tasks import PlantedTasks

    task = PlantedTasks(n_modules=11, n_wrenches=3)(np.random.default_rng(0))
    small, big = ModQuadAssemblyEnv(n_max=7), ModQuadAssemblyEnv(n_max=12)
    mixed = ModQuadAssemblyEnv(n_max=7, modules="t45,flat")
    for env in (small, big, mixed):
        env.reset(options={"task": task})
    for _ in range(10):
        big.step(int(np.flatnonzero(big.action_masks())[0]))
    with pytest.raises(ValueError, match="restore: state must be an AssemblyState"):
        small.restore(None)
    for other in (big, mixed):
        with pytest.raises(ValueError, match="restore: the state was made by another env"):
            small.restore(other.state)
    small.restore(small.state)  # its own state is fine
