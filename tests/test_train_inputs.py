"""``train.py``'s JSON options and the options a run would not use (review 3, items 3, 5, 7, 13,
14, 17): a JSON option is an object with no key twice; every documented hyperparameter has a
check (``hidden``; ``target_kl`` null is off); an option the recipe would drop, or an
``--env-kwargs`` key the tier sets, stops in one line naming both options (exit 2), and the
Python door (:class:`~agents.config.TrainConfig`) refuses the same with the same words."""

from __future__ import annotations

import shlex

import pytest

from agents.config import HYPERPARAMETERS, TrainConfig


@pytest.fixture()
def parse(tmp_path, monkeypatch):
    """Parse train.py's options (nothing is trained) with a run folder under ``tmp_path``."""
    from agents.cli import parse_args

    monkeypatch.chdir(tmp_path)

    def run(*argv: str):
        return parse_args(["--out", str(tmp_path / "run"), "--no-report", "--tensorboard",
                           str(tmp_path / "tb"), *argv])  # fmt: skip

    return run


def refused(parse, capsys, argv: list[str]) -> str:
    """The one error line of train.py ``argv`` (exit 2, no traceback)."""
    with pytest.raises(SystemExit) as exc:
        parse(*argv)
    err = capsys.readouterr().err
    assert exc.value.code == 2 and "Traceback" not in err, err
    return err.strip().splitlines()[-1]


NOT_OBJECTS = [
    ("--env-kwargs", "null", "must be a JSON object {...}, got null"),
    ("--env-kwargs", "5", "got 5"),
    ("--hyperparameters", "null", "got null"),
    ("--hyperparameters", "5", "got 5"),
    ("--hyperparameters", "[1,2]", "got [1,2]"),
    ("--hyperparameters", '"x"', 'got "x"'),
    ("--env-kwargs", "{", "not valid JSON"),
    ("--hyperparameters", '{"ent_coef": 0.1, "ent_coef": 0.2}', "'ent_coef' is given twice"),
    ("--env-kwargs", '{"lookahead": true, "lookahead": false}', "'lookahead' is given twice"),
]


@pytest.mark.parametrize(
    "flag, text, words", NOT_OBJECTS, ids=[f"{f} {t}" for f, t, _ in NOT_OBJECTS]
)
def test_a_json_option_is_one_object_with_each_key_once(parse, capsys, flag, text, words):
    line = refused(parse, capsys, [flag, text])
    assert f"argument {flag}: " in line and words in line, line


@pytest.mark.parametrize("value", [None, 5, [1, 2], "x", {1: 2}])
def test_the_python_door_refuses_a_json_option_that_is_not_an_object(tmp_path, value):
    for name in ("env_kwargs", "hyperparameters"):
        with pytest.raises(TypeError, match=f"--{name.replace('_', '-')} must be a JSON object"):
            TrainConfig(out=tmp_path, **{name: value})


def test_every_documented_hyperparameter_is_checked_and_target_kl_null_is_off(parse, capsys):
    from agents.checks import HYPERPARAMETER_RANGES

    assert set(HYPERPARAMETERS) == {*HYPERPARAMETER_RANGES, "net_arch"}
    args = parse("--hyperparameters", '{"hidden": 32, "target_kl": null}')
    assert args.config.ppo_hyperparameters()["hidden"] == 32
    assert args.config.ppo_hyperparameters()["target_kl"] is None
    for bad in ('{"hidden": 0}', '{"hidden": 1.5}', '{"hidden": 5000}', '{"target_kl": 0}'):
        line = refused(parse, capsys, ["--hyperparameters", bad])
        assert "--hyperparameters: " in line and bad[2:8] in line, line


def test_the_candidates_network_takes_its_width(tmp_path):
    """``hidden`` reaches the network (it used to crash the option check)."""
    pytest.importorskip("sb3_contrib")
    from sb3_contrib import MaskablePPO
    from stable_baselines3.common.vec_env import DummyVecEnv

    from agents.training import _new_model
    from modquad_gym.policy.ppo import make_env

    config = TrainConfig(out=tmp_path, n_max=3, hyperparameters={"hidden": 8, "target_kl": None})
    venv = DummyVecEnv([lambda: make_env(**config.env_kwargs_full)])
    try:
        model = _new_model(config, venv, MaskablePPO)
    finally:
        venv.close()
    assert model.policy_kwargs["hidden"] == 8 and model.target_kl is None


RESUME = ["--resume", "junk.zip"]  # refused before the model is read
UNUSED = [  # (argv, the TrainConfig keywords of the same run, words of the line)
    (
        [*RESUME, "--hyperparameters", '{"ent_coef": 0.02}'],
        {"hyperparameters": {"ent_coef": 0.02}},
        "--hyperparameters: ent_coef is not used with --resume",
    ),
    (
        [*RESUME, "--critic-warmup", "100"],
        {"critic_warmup": 100},
        "--critic-warmup 100: not used with --resume",
    ),
    (
        [*RESUME, "--focus-tasks", "10"],
        {"focus_tasks": 10},
        "--focus-tasks 10: not used with --resume",
    ),
    ([*RESUME, "--bc-epochs", "3"], {"bc_epochs": 3}, "--bc-epochs 3: not used with --resume"),
    (
        ["--init-from", "junk.zip", "--demo-tasks", "5"],
        {"demo_tasks": 5},
        "--demo-tasks 5: not used with --init-from",
    ),
    (
        ["--bc-epochs", "0", "--critic-warmup", "100"],
        {"critic_warmup": 100},
        "--critic-warmup 100: not used with --bc-epochs 0",
    ),
    (
        ["--bc-epochs", "0", "--focus-tasks", "10"],
        {"focus_tasks": 10},
        "--focus-tasks 10: not used with --bc-epochs 0",
    ),
    (
        ["--bc-epochs", "0", "--demo-tasks", "5"],
        {"demo_tasks": 5},
        "--demo-tasks 5: not used with --bc-epochs 0",
    ),
    (
        ["--bc-epochs", "0", "--dagger-rounds", "2"],
        {"dagger_rounds": 2},
        "--dagger-rounds 2: not used with --bc-epochs 0",
    ),
    (
        ["--bc-epochs", "0", "--workers", "4"],
        {"workers": 4},
        "--workers 4: not used with --bc-epochs 0",
    ),
    (
        ["--bc-epochs", "0", "--hyperparameters", '{"kl_coef": 0.1}'],
        {"hyperparameters": {"kl_coef": 0.1}},
        "--hyperparameters: kl_coef is not used with --bc-epochs 0",
    ),
    (["--group-size", "4"], {"group_size": 4}, "--group-size 4: not used with --advantage gae"),
    (
        ["--focus-percent", "80"],
        {"focus_percent": 80},
        "--focus-percent 80: not used with --focus-tasks 0",
    ),
    (
        ["--dagger-rounds", "0", "--dagger-tasks", "50"],
        {"dagger_tasks": 50},
        "--dagger-tasks 50: not used with --dagger-rounds 0",
    ),
    (
        ["--hyperparameters", '{"net_arch": [64, 64]}'],
        {"hyperparameters": {"net_arch": [64, 64]}},
        "--hyperparameters: net_arch is not used with --architecture candidates",
    ),
    (
        ["--architecture", "mlp", "--hyperparameters", '{"hidden": 32}'],
        {"hyperparameters": {"hidden": 32}},
        "--hyperparameters: hidden is not used with --architecture mlp",
    ),
    (
        ["--tier", "fault", "--env-kwargs", '{"fault": null}'],
        {"env_kwargs": {"fault": None}},
        "--env-kwargs fault=None: the module types and the failure are the tier's",
    ),
    (
        ["--env-kwargs", '{"modules": "t45,flat"}'],
        {"env_kwargs": {"modules": "t45,flat"}},
        "--env-kwargs modules='t45,flat': the module types",
    ),
    (
        ["--tier", "mixed", "--env-kwargs", '{"initial_type": "t45"}'],
        {"env_kwargs": {"initial_type": "t45"}},
        "--env-kwargs initial_type='t45'",
    ),
    (
        ["--env-kwargs", '{"task": "example:screwdriver"}'],
        {"env_kwargs": {"task": "x"}},
        "--env-kwargs: give tasks and n_max with --task-source",
    ),
]


def _keywords(argv: list[str], kwargs: dict) -> dict:
    """The TrainConfig keywords of ``argv``'s run besides ``kwargs``: its switches."""
    words = dict(zip(argv[::2], argv[1:][::2]))
    switches = {"--resume": "resume", "--init-from": "init_from", "--bc-epochs": "bc_epochs",
                "--dagger-rounds": "dagger_rounds", "--architecture": "architecture",
                "--tier": "tier"}  # fmt: skip
    out = {}
    for flag, name in switches.items():
        if flag in words and name not in kwargs:
            text = words[flag]
            out[name] = text if not text.isdigit() else int(text)
    return {**out, **kwargs}


@pytest.mark.parametrize("argv, kwargs, words", UNUSED, ids=[" ".join(a) for a, _, _ in UNUSED])
def test_an_option_the_run_would_drop_is_refused_by_both_doors(
    parse, capsys, tmp_path, argv, kwargs, words
):
    (tmp_path / "junk.zip").write_text("not a model")
    line = refused(parse, capsys, argv)
    assert words in line, line
    with pytest.raises(ValueError) as exc:
        TrainConfig(out=tmp_path / "run", **_keywords(argv, kwargs))
    assert words in str(exc.value) and line.endswith(str(exc.value)), (line, exc.value)


TYPED_ONLY = [  # a typed value that is the default: only the command line knows it was typed
    (
        ["--bc-epochs", "0", "--dagger-rounds", "3"],
        "--dagger-rounds 3: not used with --bc-epochs 0",
    ),
    (["--group-size", "8"], "--group-size 8: not used with --advantage gae"),
    (["--focus-percent", "50"], "--focus-percent 50: not used with --focus-tasks 0"),
    (["--init-from", "junk.zip", "--bc-epochs", "30"], "--bc-epochs 30: not used with --init-from"),
    (["--bc-epochs", "0", "--expert", "all"], "--expert all: not used with --bc-epochs 0"),
]


@pytest.mark.parametrize("argv, words", TYPED_ONLY, ids=[" ".join(a) for a, _ in TYPED_ONLY])
def test_a_typed_option_the_run_would_drop_is_refused_at_its_default_too(
    parse, capsys, argv, words
):
    assert words in refused(parse, capsys, argv)


AGREEING = [
    "--bc-epochs 0 --dagger-rounds 0 --critic-warmup 0 --focus-tasks 0",
    "--bc-epochs 0 --hyperparameters '{\"kl_coef\": 0}'",
    "--advantage group --group-size 4",
    "--focus-tasks 10 --focus-percent 80",
    "--architecture mlp --hyperparameters '{\"net_arch\": [64, 64]}'",
    "--quick --bc-epochs 0",  # --quick's demonstration tasks are not asked for without cloning
    "--tier large --bc-epochs 0",  # nor the tier's
    "--env-kwargs '{\"lookahead\": true}'",
]


@pytest.mark.parametrize("argv", AGREEING)
def test_options_that_agree_with_the_run_pass_and_its_command_rebuilds_it(parse, argv):
    config = parse(*shlex.split(argv)).config
    assert parse(*shlex.split(config.command())[1:]).config == config


def test_a_seed_keeps_the_workers_it_does_not_use(tmp_path):
    from agents.seeds import seed_config

    assert seed_config(TrainConfig(out=tmp_path), 1).workers == 1
    assert seed_config(TrainConfig(out=tmp_path, bc_epochs=0), 1).workers == 2
    assert seed_config(TrainConfig(out=tmp_path, tier="large", bc_epochs=0), 1).demo_tasks == 800


@pytest.mark.parametrize("option", ["--resume", "--init-from"])
@pytest.mark.parametrize("name", ["best_model.zip", "final_model.zip", "cloned_model.zip"])
def test_a_start_model_the_run_would_replace_is_refused_and_kept(
    parse, capsys, tmp_path, option, name
):
    """A run removes its log folder's best and cloned models at its start and writes its final
    one there: starting from one of them would delete or overwrite the model it reads."""
    model = tmp_path / "tb" / f"{tmp_path.name}-run" / "train" / name
    model.parent.mkdir(parents=True)
    model.write_bytes(b"a model the user keeps")
    trust = ["--trust-model"] if option == "--resume" else []
    line = refused(parse, capsys, [option, str(model), *trust])
    assert f"{option}: {model} is the {name} this run replaces" in line, line
    assert model.read_bytes() == b"a model the user keeps"
