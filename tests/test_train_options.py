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
    (["--seeds", "1", "2", "--workers", "4"], "--workers with --seeds"),
    (["--seed-workers", "2"], "--seed-workers: only with --seeds"),
    (["--no-report", "--report-dir", "r"], "--report-dir with --no-report"),
]


@pytest.mark.parametrize("argv, words", SEEDS_DROPPED, ids=[" ".join(a) for a, _ in SEEDS_DROPPED])
def test_options_seeds_cannot_honour_are_refused(parse, capsys, argv, words):
    with pytest.raises(SystemExit) as exc:
        parse(*argv)
    assert exc.value.code == 2 and words in capsys.readouterr().err.splitlines()[-1]


def test_a_seeds_config_with_its_own_workers_is_refused(tmp_path):
    """Each seed collects its demonstrations in one process: a config that asks for more is
    refused, not run with one (the recorded command said --workers 1)."""
    from agents.config import TrainConfig
    from agents.seeds import seed_config

    with pytest.raises(ValueError, match="--workers 4 with --seeds"):
        seed_config(TrainConfig(out=tmp_path / "seeds", workers=4), 0)
    unused = TrainConfig(out=tmp_path / "seeds", bc_epochs=0, dagger_rounds=0)
    assert seed_config(unused, 0).workers == unused.workers  # no demonstrations: nothing asked


def test_a_critic_warmup_as_long_as_the_run_is_refused(parse, capsys, tmp_path):
    """The actor would never train: --critic-warmup must stay below --timesteps."""
    from agents.config import TrainConfig

    for warmup, timesteps in ((512, 512), (100_000, 512)):
        with pytest.raises(SystemExit) as exc:
            parse("--critic-warmup", str(warmup), "--timesteps", str(timesteps))
        last = capsys.readouterr().err.strip().splitlines()[-1]
        assert exc.value.code == 2 and f"--critic-warmup {warmup}" in last
        assert f"--timesteps {timesteps}" in last
    assert parse("--critic-warmup", "511", "--timesteps", "512").config.critic_warmup == 511
    with pytest.raises(ValueError, match="--critic-warmup"):
        TrainConfig(out=tmp_path, critic_warmup=30_000)  # the recipe's 20,000 steps


def test_a_rollout_buffer_beyond_memory_is_refused_before_the_run_folder(
    parse, capsys, tmp_path, monkeypatch
):
    """n_steps x n_envs rows of the observations must fit in the memory available: refused in
    one line naming --hyperparameters n_steps, before the run folder exists."""
    room = 2**30
    monkeypatch.setattr("modquad_gym.core.resources.available_memory", lambda: room)
    with pytest.raises(SystemExit) as exc:
        parse("--hyperparameters", '{"n_steps": 1000000}')
    last = capsys.readouterr().err.strip().splitlines()[-1]
    assert exc.value.code == 2 and "--hyperparameters n_steps 1000000" in last, last
    assert "1.0 GiB are available" in last and not (tmp_path / "run").exists()
    assert parse("--hyperparameters", '{"n_steps": 256}').config  # the recipe's fits


def test_the_rollout_estimate_is_the_buffer_sb3_allocates(untrained_run):
    """:func:`rollout_bytes` counts every array of MaskablePPO's rollout buffer: its estimate
    less the one flattened copy is the buffer's size, for both networks."""
    from sb3_contrib import MaskablePPO

    from agents.checks import rollout_bytes

    for architecture in ("candidates", "mlp"):
        run = untrained_run(f"buffer-{architecture}", architecture=architecture,
                            hyperparameters={"n_steps": 16, "batch_size": 16})  # fmt: skip
        model = MaskablePPO.load(run / "model.zip", device="cpu")  # its spaces, one env
        buffer = model.rollout_buffer
        scalars = ("rewards", "returns", "episode_starts", "values", "log_probs", "advantages")
        arrays = [*buffer.observations.values(), buffer.actions, buffer.action_masks,
                  *(getattr(buffer, k) for k in scalars)]  # fmt: skip
        total, largest = sum(a.nbytes for a in arrays), max(a.nbytes for a in arrays)
        assert total + largest == rollout_bytes(model, 16, 1)


def test_help_states_the_evaluation_frequency_the_run_uses(tmp_path):
    """--eval-freq's default in --help is the one the run takes: timesteps / 20 with its
    floor (a 1,024-step run evaluates every 512 steps, not every 51)."""
    import argparse
    import re

    from agents.cli import add_config_options
    from agents.config import TrainConfig

    parser = argparse.ArgumentParser()
    add_config_options(parser)
    (action,) = [a for a in parser._actions if a.dest == "eval_freq"]
    floor = int(re.search(r"timesteps / 20, at least (\d+)", action.help).group(1))
    for timesteps in (1_024, 20 * floor, 200_000):
        config = TrainConfig(out=tmp_path, timesteps=timesteps)
        assert config.eval_every() == max(timesteps // 20, floor)
    assert TrainConfig(out=tmp_path, timesteps=1_024, eval_freq=100).eval_every() == 100


def test_init_from_a_network_of_another_width_is_refused_in_one_line(
    parse, capsys, tmp_path, untrained_run
):
    """PPO starts from the model's weights: a model of another hidden width (or net_arch) is
    refused while parsing, naming --init-from and both widths, before any folder is made; the
    Python door raises the same."""
    from agents.config import TrainConfig
    from agents.training import train

    start = untrained_run("wide")  # hidden 64, the recipe's
    with pytest.raises(SystemExit) as exc:
        parse("--init-from", str(start / "model.zip"), "--hyperparameters", '{"hidden": 32}',
              "--tensorboard", str(tmp_path / "tb"))  # fmt: skip
    last = capsys.readouterr().err.strip().splitlines()[-1]
    assert exc.value.code == 2 and "--init-from" in last and "Traceback" not in last
    assert "hidden is 64, this run's 32" in last, last
    with pytest.raises(ValueError, match="--init-from .*hidden is 64, this run's 32"):
        train(TrainConfig(out=tmp_path / "run", init_from=start / "model.zip",
                          tensorboard=tmp_path / "tb", hyperparameters={"hidden": 32}))  # fmt: skip
    assert not (tmp_path / "run").exists() and not (tmp_path / "tb").exists()
    mlp = untrained_run("mlp-start", architecture="mlp")
    with pytest.raises(SystemExit):
        parse("--init-from", str(mlp / "model.zip"), "--architecture", "mlp", "--hyperparameters",
              '{"net_arch": [64]}', "--tensorboard", str(tmp_path / "tb"))  # fmt: skip
    assert "net_arch is [256, 256], this run's [64]" in capsys.readouterr().err
