"""Issue 24, family 7: every ``train.py`` option that used to end in a traceback (or started a
run it should refuse) now stops while parsing: one error line naming the option, exit 2, before
any environment, demonstration or model is made."""

from __future__ import annotations

from pathlib import Path

import pytest

from modquad_gym.policy.models import MODELS_DIR

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture()
def parse(tmp_path, monkeypatch):
    from agents.cli import parse_args

    monkeypatch.chdir(tmp_path)
    (tmp_path / "junk.zip").write_text("not a model")
    real = MODELS_DIR / "ppo_default" / "model.zip"
    if real.is_file():
        (tmp_path / "truncated.zip").write_bytes(real.read_bytes()[:3000])

    def run(*argv: str):
        return parse_args(["--out", str(tmp_path / "run"), *argv])

    return run


CASES = [
    (["--seed", "-1"], "--seed"),
    (["--n-max", "200"], "--n-max"),
    (["--env-kwargs", '{"bogus": 1}'], "--env-kwargs"),
    (["--hyperparameters", '{"learning_rate": -1}'], "learning_rate"),
    (["--hyperparameters", '{"net_arch": [0]}'], "net_arch"),
    (["--hyperparameters", '{"batch_size": 1}'], "batch_size"),
    (["--hyperparameters", '{"gamma": 2}'], "gamma"),
    (["--task-source", "nope"], "--task-source"),
    (["--n-eval", "0"], "--n-eval"),
    (["--resume", "junk.zip"], "--resume"),
    (["--resume", "."], "--resume"),
    (["--seeds", "-1", "2"], "--seeds"),
    (["--seeds", "2", "2"], "--seeds"),
    (["--n-envs", "100000"], "--n-envs"),
    (["--timesteps", "1_000"], "--timesteps"),
    (["--threads", "0"], "--threads"),
    (["--eval-freq", "-5"], "--eval-freq"),
    (["--checkpoint-freq", "0"], "--checkpoint-freq"),
    (["--demo-tasks", "0"], "--demo-tasks"),
    (["--bc-epochs", "-1"], "--bc-epochs"),
    (["--tensorboard", "/dev/null"], "--tensorboard"),
    (["--dagger-rounds", "-1"], "--dagger-rounds"),
    (["--dagger-tasks", "0"], "--dagger-tasks"),
    (["--seeds", "1", "2", "--seed-workers", "0"], "--seed-workers"),
]


@pytest.mark.parametrize("argv, option", CASES, ids=[" ".join(a) for a, _ in CASES])
def test_bad_train_options_stop_in_one_line(parse, capsys, argv, option):
    with pytest.raises(SystemExit) as exc:
        parse(*argv)
    err = capsys.readouterr().err
    assert exc.value.code == 2 and "Traceback" not in err
    assert option in err.strip().splitlines()[-1], err


def test_subprocess_environments_are_capped_to_the_machine(parse, capsys, monkeypatch):
    monkeypatch.setattr("agents.checks.usable_cpus", lambda: 2)
    with pytest.raises(SystemExit):
        parse("--n-envs", "8", "--vec-env", "subproc")
    assert "2 usable CPU(s)" in capsys.readouterr().err


def test_resume_refuses_a_truncated_model_and_another_tiers(parse, capsys):
    pytest.importorskip("sb3_contrib")
    mixed = MODELS_DIR / "ppo_mixed" / "model.zip"  # another tier's model
    for model in ("truncated.zip", str(mixed)):
        if not Path(model).is_file():
            continue
        with pytest.raises(SystemExit):
            parse("--resume", model)
        assert "--resume" in capsys.readouterr().err.splitlines()[-1]


def test_a_good_recipe_still_parses(parse):
    args = parse("--seed", "3", "--n-envs", "4", "--hyperparameters", '{"ent_coef": 0.02}')
    assert args.config.seed == 3 and args.config.n_envs == 4


def test_every_config_field_is_an_option_and_the_recorded_command_rebuilds_the_config(parse):
    """The options are derived from TrainConfig (issue 33, item 5): each field has its option,
    and the command line config.json records parses back to the same config."""
    import argparse
    import shlex
    from dataclasses import fields

    from agents.cli import add_config_options
    from agents.config import TrainConfig

    args = parse("--n-envs", "3", "--tier", "large", "--no-progress", "--seed", "4",
                 "--env-kwargs", '{"reward_weights": {"w_module": 0.2}}', "--bc-epochs", "0",
                 "--dagger-rounds", "0")  # fmt: skip
    config = args.config
    assert (config.n_envs, config.tier, config.progress, config.seed) == (3, "large", False, 4)
    assert config.env_kwargs == {"reward_weights": {"w_module": 0.2}}
    parser = argparse.ArgumentParser()
    add_config_options(parser)
    assert {a.dest for a in parser._actions} - {"help"} == {f.name for f in fields(TrainConfig)}
    again = parse(*shlex.split(config.command())[1:]).config
    assert again == config


def test_seeds_are_configs_and_the_report_is_a_function(tmp_path):
    """Seeds run as tasks over configs (no argv): each seed its own folder and one
    demonstration process; the report's options are refused when unknown."""
    from agents.config import TrainConfig
    from agents.seeds import seed_config
    from modquad_gym.scoring.agents import parse_args
    from modquad_gym.scoring.options import command_line, score_options

    config = TrainConfig(out=tmp_path / "seeds", workers=2)
    one = seed_config(config, 3)
    assert (one.seed, one.workers, one.progress) == (3, 1, False)
    assert one.out == tmp_path / "seeds" / "seed-3"
    assert one.timesteps == config.timesteps and one.tier == config.tier
    given = {"out": tmp_path / "r", "limit": 3, "force": True}
    argv = ["--out", str(tmp_path / "r"), "--limit", "3", "--force"]
    assert vars(score_options(**given)) == vars(parse_args(argv))
    assert command_line(**given) == f"modquad score --out {tmp_path / 'r'} --limit 3 --force"
    with pytest.raises(ValueError, match="unknown options \\['limits'\\]"):
        score_options(limits=3)


@pytest.fixture()
def fault_run(tmp_path):
    """A run folder holding a copy of the fault tier's shipped model and its config."""
    model = MODELS_DIR / "ppo_fault" / "model.zip"
    if not model.is_file():
        pytest.skip("no fault model")
    run = tmp_path / "fault-run"
    run.mkdir()
    for name in ("model.zip", "config.json"):
        (run / name).write_bytes((model.parent / name).read_bytes())
    return run


PUBLISH_DROPPED = [
    (["--tier", "mixed"], "--tier mixed: the run"),
    (["--quick"], "--quick: --publish-run trains nothing"),
    (["--timesteps", "5", "--seed", "3"], "--seed, --timesteps: --publish-run trains nothing"),
    (["--out", "elsewhere"], "--out: --publish-run"),
    (["--seed-workers", "2"], "--seed-workers: --publish-run"),
]


@pytest.mark.parametrize("argv, words", PUBLISH_DROPPED, ids=[a[0] for a, _ in PUBLISH_DROPPED])
def test_publish_run_refuses_what_it_would_drop(fault_run, capsys, argv, words):
    """--publish-run trains nothing and publishes the tier its run records: a training option
    or another --tier is refused in one line, not dropped."""
    from agents.cli import parse_args

    with pytest.raises(SystemExit) as exc:
        parse_args(["--publish-run", str(fault_run), *argv])
    err = capsys.readouterr().err.strip().splitlines()
    assert exc.value.code == 2 and words in err[-1], err


def test_publish_run_replaces_a_report_in_a_typed_folder_only_with_force(fault_run, capsys):
    """The tier's own report is the publish's to rewrite; one in a --report-dir the user typed
    needs --force. The run's own --tier and --no-progress are accepted."""
    pytest.importorskip("sb3_contrib")
    from agents.cli import parse_args

    mine = fault_run.parent / "mine"
    mine.mkdir()
    (mine / "benchmark.md").write_text("my report")
    argv = ["--publish-run", str(fault_run), "--tier", "fault", "--no-progress", "--report-dir",
            str(mine)]  # fmt: skip
    with pytest.raises(SystemExit):
        parse_args(argv)
    assert "--force" in capsys.readouterr().err.splitlines()[-1]
    args = parse_args([*argv, "--force"])
    assert (args.tier, args.report_dir, args.out) == ("fault", mine, fault_run)
    assert (mine / "benchmark.md").read_text() == "my report"  # parsing writes nothing


def test_publish_run_names_the_missing_file(fault_run, capsys):
    from agents.cli import parse_args

    (fault_run / "config.json").unlink()
    with pytest.raises(SystemExit):
        parse_args(["--publish-run", str(fault_run)])
    err = capsys.readouterr().err.splitlines()[-1]
    assert "no config.json in" in err and "model.zip" not in err


SEEDS_DROPPED = [
    (["--seeds", "1", "2", "--seed", "3"], "--seed with --seeds"),
    (["--seeds", "1", "2", "--report-dir", "r"], "--report-dir with --seeds"),
    (["--seed-workers", "2"], "--seed-workers: only with --seeds"),
    (["--no-report", "--report-dir", "r"], "--report-dir with --no-report"),
]


@pytest.mark.parametrize("argv, words", SEEDS_DROPPED, ids=[" ".join(a) for a, _ in SEEDS_DROPPED])
def test_options_seeds_cannot_honour_are_refused(parse, capsys, argv, words):
    with pytest.raises(SystemExit) as exc:
        parse(*argv)
    assert exc.value.code == 2 and words in capsys.readouterr().err.splitlines()[-1]
