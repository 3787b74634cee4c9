"""Expert iteration at 8-32 modules (agents/expert_iteration.py): labels are the smaller answer
of the default search and the policy's guided search, the expert episode reaches its target, and
the training draws are neither held-out nor validation tasks."""

from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("sb3_contrib")

from agents.expert_iteration import (  # noqa: E402
    DRAWS,
    EXIT_SEED0,
    SIZES,
    label_chunk,
    summary,
    training_task,
)
from benchmarks.scale_suites import SCALE_SEED0, SCALE_VALIDATION_SEED0, draw  # noqa: E402


def test_training_tasks_are_fresh_draws_of_the_one_type_families():
    tasks = [training_task(0, 1, i) for i in range(4)]
    assert [t.meta["family"] for t in tasks] == ["planted", "torque"] * 2
    assert all(SIZES[0] <= t.meta["planted"] <= SIZES[1] for t in tasks)
    again = training_task(0, 1, 0)
    np.testing.assert_array_equal(again.wrenches, tasks[0].wrenches)
    assert EXIT_SEED0 not in (SCALE_SEED0, SCALE_VALIDATION_SEED0)
    for family in ("planted", "torque"):  # no training task is a validation draw of its band
        for t in tasks:
            if t.meta["family"] == family:
                other = draw(family, t.meta["planted"], 0, validation=True)
                assert other.wrenches.shape != t.wrenches.shape or not np.allclose(
                    other.wrenches, t.wrenches
                )


def test_training_draws_follow_their_families_and_sizes_in_turn():
    draws = (("torque", 40, 64), ("planted", 16, 20), ("torque", 40, 64))
    tasks = [training_task(0, 2, i, draws) for i in range(6)]
    assert [t.meta["family"] for t in tasks] == ["torque", "planted", "torque"] * 2
    assert all(lo <= t.meta["planted"] <= hi for t, (_, lo, hi) in zip(tasks, draws * 2))
    default = training_task(0, 1, 1)  # the default draws are the earlier runs' draws
    np.testing.assert_array_equal(default.wrenches, training_task(0, 1, 1, DRAWS).wrenches)


def test_a_label_is_the_better_answer_and_its_episode_reaches_it():
    task = training_task(0, 1, 3)  # low force, high torque, 10 modules planted
    # the search proves its answer optimal in well under a second here and stops; 10 s leaves
    # room for a loaded machine (the label must not depend on the machine's speed)
    alone, _ = label_chunk((None, [task], 36, 10.0, 8, [0, 1, 0], False, False))
    demos, rows = label_chunk((None, [task], 36, 10.0, 8, [0, 1, 0], True, True))
    (row,) = rows  # with greedy's answer among the labels
    answers = [n for n in (row["search"], row["guided"], row["greedy"]) if n is not None]
    assert row["greedy"] is not None
    assert row["target"] == min(answers) and row["bound"] <= row["target"]
    assert alone is not None and len(alone) >= 1 and alone.n_tasks == 1
    # with the learner's own episode: its states join the expert's, each labelled
    assert len(demos) > len(alone) and demos.n_tasks == 2
    assert demos.good.any(axis=1).all() and not (demos.good & ~demos.valid).any()


def test_summary_counts_wins_against_greedy():
    rows = [{"ppo": 10, "greedy": 12, "ppo_s": 1.0, "greedy_s": 2.0},
            {"ppo": None, "greedy": 20, "ppo_s": 1.0, "greedy_s": 2.0},
            {"ppo": 15, "greedy": 15, "ppo_s": 1.0, "greedy_s": 2.0}]  # fmt: skip
    s = summary(rows)
    assert (s["ppo_solved"], s["greedy_solved"], s["fewer"], s["equal"], s["more"]) == (
        2,
        3,
        1,
        1,
        0,
    )
    assert s["ppo_mean"] == 12.5 and s["greedy_mean"] == 13.5


def test_label_summary_means_each_answer_over_the_tasks_it_solved():
    from agents.scale_scores import label_summary

    labels = [{"round": "1", "search": "10", "guided": "9", "ppo": "", "target": "9"},
              {"round": "1", "search": "12", "guided": "", "ppo": "14", "target": "12"},
              {"round": 2, "search": 8, "guided": 8, "ppo": 9, "target": 8}]  # fmt: skip
    one, two = label_summary(labels)
    assert (one["search"], one["guided"], one["ppo"], one["target"]) == (11, 9, 14, 10.5)
    assert one["guided_smaller"] == 1 and two["guided_smaller"] == 0 and two["tasks"] == 1


def test_a_rounds_config_names_its_command_and_its_start_without_a_machines_folder(
    tmp_path, monkeypatch
):
    import argparse
    import json

    from agents.expert_iteration import write_config
    from modquad_gym.policy import DEFAULT_MODEL

    monkeypatch.chdir(DEFAULT_MODEL.parents[4])  # the repository (or the install's site folder)
    args = argparse.Namespace(model=DEFAULT_MODEL, n_max=40, argv=["--rounds", "1"], rounds=1,
                              tasks=4, search_seconds=1.0, budget=8, seed=3, epochs=2,
                              learner=True, replay=0)  # fmt: skip
    write_config(tmp_path, args, 1, 10)
    config = json.loads((tmp_path / "config.json").read_text())
    made = config["expert_iteration"]
    assert made["start"] == "modquad_gym/data/models/ppo_default/model.zip"
    assert made["command"] == "python -m agents.expert_iteration --rounds 1"
    assert (made["round"], made["rounds"], made["states"], made["seed"]) == (1, 1, 10, 3)
    assert config["env_kwargs"]["n_max"] == 40 and config["env_kwargs"]["lookahead"] == "exact"


def test_a_negative_replay_is_refused_in_one_line_before_any_work(tmp_path, capsys):
    from agents.expert_iteration import main

    out = tmp_path / "exit"
    with pytest.raises(SystemExit) as stop:
        main(["--replay", "-5", "--out", str(out)])
    assert stop.value.code == 2 and not out.exists()
    err = capsys.readouterr().err
    assert "--replay -5" in err.strip().splitlines()[-1] and "Traceback" not in err


def test_a_runs_page_names_its_draws_rounds_and_labels():
    import argparse

    from agents.scale_scores import report

    args = argparse.Namespace(argv=["--greedy"], score_start=False, tasks=4, greedy=True,
                              draws=[("torque", 10, 24), ("planted", 16, 40)], learner=True,
                              replay=0, bands=[16], per_family=1, n_max=40,
                              search_seconds=4.0)  # fmt: skip
    labels = [{"round": 3, "family": "torque", "search": 12, "greedy": 14, "guided": 13,
               "ppo": 13, "target": 12}]  # fmt: skip
    text = report([{"round": 3, "states": 9}], args, 60.0, labels, [3])
    assert "Rounds 3: 4 training tasks" in text and "torque 10-24, planted 16-40" in text
    assert "greedy's (first on ties)" in text and "| 3 | torque | 1 | 12 | 14 | 13 |" in text


def test_the_options_keep_their_defaults_and_cross_checks(tmp_path, capsys):
    """Every option's default, as a run without options reads them; each check across options
    is argparse's one line and exit 2, before any work."""
    from pathlib import Path

    from agents.expert_iteration import parse_args
    from modquad_gym.policy.models import DEFAULT_MODEL

    out = tmp_path / "exit"
    args = vars(parse_args(["--out", str(out)]))
    assert args == {
        "model": DEFAULT_MODEL, "rounds": 2, "tasks": 48, "search_seconds": 4.0, "budget": 64,
        "epochs": 25, "learning_rate": 3e-4, "n_max": 40, "draws": list(DRAWS),
        "greedy": False, "bands": [16, 24, 32], "first_round": 1, "score_start": True,
        "per_family": 3, "workers": 2, "learner": True, "replay": 800, "seed": 0, "out": out,
        "force": False, "trust_model": False, "argv": ["--out", str(out)],
    }  # fmt: skip
    assert parse_args(["--out", str(out), "--draws", "payload:16-64"]).draws == [
        ("payload", 16, 64)
    ]
    for bad, says in ((["--learning-rate", "2"], "--learning-rate 2: give a rate in (0, 1]"),
                      (["--bands", "16", "16"], "argument --bands: 16 is given twice"),
                      (["--model", str(tmp_path / "none.zip")], "does not exist"),
                      (["--draws", "planted:1-8"], "sizes LOW-HIGH")):  # fmt: skip
        with pytest.raises(SystemExit) as stop:
            parse_args(["--out", str(out), *bad])
        last = capsys.readouterr().err.strip().splitlines()[-1]
        assert stop.value.code == 2 and says in last, (bad, last)
    assert not out.exists() and isinstance(args["model"], Path)


def test_empty_paths_an_unbounded_replay_and_a_grid_start_are_refused_before_work(
    tmp_path, capsys, monkeypatch, untrained_run
):
    """--out '' and --model '' (the working folder, unnamed), a --replay beyond 10,000,000 or
    beyond what memory holds (its states at --n-max), and a start model that cannot act at
    --n-max (a grid MLP of n_max 7) each stop in one line naming the option, exit 2, before
    --out exists."""
    from agents.exit_checks import replay_bytes
    from agents.expert_iteration import main
    from modquad_gym.policy.policy import Policy

    out = tmp_path / "exit"
    monkeypatch.chdir(tmp_path)
    room = 4 * 2**30
    monkeypatch.setattr("modquad_gym.core.resources.available_memory", lambda: room)
    env = Policy(n_max=40).env  # the default start model's labelling environment
    fits = int(0.8 * room / replay_bytes(env, 1))
    grid = untrained_run("grid", architecture="mlp") / "model.zip"
    for argv, says in ((["--out", ""], "argument --out: an empty path"),
                       (["--model", ""], "argument --model: an empty path"),
                       (["--replay", "99999999999"], "--replay 99999999999: give a number"),
                       (["--replay", str(fits + 1)], f"--replay {fits + 1} (its demonstrations"),
                       (["--model", str(grid)], f"--model {grid}: n_max=40 exceeds")):  # fmt: skip
        with pytest.raises(SystemExit) as stop:
            main([*(["--out", str(out)] if "--out" not in argv else []), *argv])
        last = capsys.readouterr().err.strip().splitlines()[-1]
        assert stop.value.code == 2 and says in last, (argv, last)
    assert list(tmp_path.iterdir()) == []  # nothing made, here (the working folder) either
    from agents.expert_iteration import parse_args

    assert parse_args(["--out", str(out), "--replay", str(fits)]).replay == fits
