"""Every file and array a user hands the package is read by one rule and refused in one line,
before any work: a training run's ``evaluations.npz``, the numbers of a task (from a file or
from Python), a certificate, an exported model read back, and the size of what is parsed."""

from __future__ import annotations

import shutil

import numpy as np
import pytest
from test_hardening import assert_one_line_error, run_main

import modquad_gym as mq

SHIPPED_RUN = mq.__path__[0] + "/data/models/ppo_default"


# --------------------------------------------------------- a training run's evaluations.npz
def _no_work(*args, **kwargs):
    raise AssertionError("the scoring started")


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
