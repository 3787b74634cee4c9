"""The training recipe: one machine trains bit for bit the same model twice, tiers and the
publish step of train.py, the config's checks."""

from __future__ import annotations

import importlib.util
import io
import json
import zipfile
from pathlib import Path

import numpy as np
import pytest

from agents.config import TrainConfig
from agents.training import train
from modquad_gym.scoring.tiers import TIERS
from modquad_gym.tasks import PlantedTasks, save_suite

torch = pytest.importorskip("torch")
ROOT = Path(__file__).resolve().parents[1]


def _parameters(model_zip: Path) -> dict:
    with zipfile.ZipFile(model_zip) as z:
        return torch.load(io.BytesIO(z.read("policy.pth")), map_location="cpu")


def _short_run(tmp: Path, name: str, suite: Path, seed: int = 0, n_max: int = 3) -> Path:
    config = TrainConfig(
        out=tmp / name, task_source=str(suite), n_max=n_max, timesteps=512, eval_freq=256,
        demo_tasks=12, bc_epochs=3, workers=1, n_eval=3, tensorboard=tmp / "tb", seed=seed,
        progress=False,
    )  # fmt: skip
    return train(config)


@pytest.fixture(scope="module")
def suite(tmp_path_factory) -> Path:
    gen = PlantedTasks(n_modules=2, n_wrenches=24)
    tasks = [gen(np.random.default_rng(s)) for s in (0, 1, 2)]
    return save_suite(tasks, tmp_path_factory.mktemp("suite") / "tiny.json")


def test_a_short_run_twice_gives_the_same_parameters(tmp_path, suite):
    """Cloning and PPO on one machine are deterministic: same seed, same weights, same
    learning curve; another seed differs (the check can fail)."""
    a = _parameters(_short_run(tmp_path, "a", suite))
    b = _parameters(_short_run(tmp_path, "b", suite))
    c = _parameters(_short_run(tmp_path, "c", suite, seed=1))
    assert a.keys() == b.keys() and len(a) > 4
    assert all(torch.equal(a[k], b[k]) for k in a)
    assert not all(torch.equal(a[k], c[k]) for k in a)
    ea, eb = (np.load(tmp_path / n / "evaluations.npz") for n in "ab")
    assert np.array_equal(ea["results"], eb["results"]) and ea["timesteps"][0] == 0
    config = json.loads((tmp_path / "a" / "config.json").read_text())
    assert config["tier"] == "current" and config["env_id"] == "ModQuadAssembly-v0"


def test_config_takes_the_tier_defaults(tmp_path):
    large = TrainConfig(out=tmp_path, tier="large")
    assert large.max_modules == 12 and large.source == TIERS["large"].source
    assert large.env_kwargs_full == {"tasks": "planted-large", "n_max": 12, "lookahead": "exact"}
    assert large.dagger_tasks == large.demo_tasks // 10
    assert large.validation_source == "planted-large"
    assert (large.expert, large.timesteps) == ("one", TIERS["large"].recipe["timesteps"])
    assert TrainConfig(out=tmp_path, tier="large", timesteps=7).timesteps == 7  # given wins
    current = TrainConfig(out=tmp_path, task_source=str(tmp_path / "tasks.json"))
    assert current.max_modules == 7 and current.validation_source == "mixed"
    assert TIERS["large"].model.parent.name == "ppo_default"  # the size-free default model
    mixed = TrainConfig(out=tmp_path, tier="mixed")  # several types: each episode a random start
    assert mixed.env_kwargs_full == {
        "tasks": "planted-mixed-external",
        "n_max": 7,
        "modules": "t45,t45m,flat",
        "lookahead": "exact",
        "initial_type": "random",
    }
    assert mixed.eval_env_kwargs == {"modules": "t45,t45m,flat", "lookahead": "exact"}
    assert mixed.expert == "one"
    mlp = TrainConfig(out=tmp_path, architecture="mlp")  # the grid MLP: no lookahead rows
    assert mlp.env_kwargs_full == {"tasks": "mixed", "n_max": 7}
    assert TIERS["current"].results == "results"


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"tier": "huge"}, "unknown tier"),
        ({"hyperparameters": {"lr": 1}}, "unknown keys"),
        ({"env_kwargs": {"n_max": 3}}, "--n-max"),
        ({"expert": "best"}, "expert must be"),
        ({"architecture": "cnn"}, "architecture must be"),
    ],
)
def test_config_rejects_what_it_cannot_train(tmp_path, kwargs, message):
    with pytest.raises(ValueError, match=message):
        TrainConfig(out=tmp_path, **kwargs)


def _script():
    spec = importlib.util.spec_from_file_location("train_script", ROOT / "train.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_publish_run_installs_an_earlier_run_without_training(tmp_path, suite, monkeypatch):
    """--publish-run copies the run's files to its tier's shipped model (redirected here)."""
    script = _script()
    _short_run(tmp_path, "run", suite, n_max=7)  # the current tier's actions
    target = tmp_path / "shipped" / "model.zip"
    monkeypatch.setattr("modquad_gym.policy.models.DEFAULT_MODEL", target)
    assert script.main(["--publish-run", str(tmp_path / "run"), "--no-report"]) == 0
    for name in ("model.zip", "config.json", "evaluations.npz"):
        assert (target.parent / name).read_bytes() == (tmp_path / "run" / name).read_bytes()


def test_train_script_errors_are_one_line(capsys, tmp_path):
    script = _script()
    with pytest.raises(SystemExit) as exc:
        script.main(["--hyperparameters", '{"lr": 1}', "--out", str(tmp_path / "x")])
    assert exc.value.code == 2
    assert "unknown keys" in capsys.readouterr().err
    with pytest.raises(SystemExit):
        script.main(["--publish-run", str(tmp_path)])
    assert "no model.zip" in capsys.readouterr().err


def test_log_names_keep_runs_of_different_folders_apart(tmp_path):
    from agents.training import log_name

    runs = tmp_path / "runs"
    assert log_name(runs / "ppo-seed0", runs) == "ppo-seed0"
    a = log_name(runs / "seeds-large" / "seed-0", runs)
    b = log_name(runs / "seeds-current" / "seed-0", runs)
    assert a == "seeds-large-seed-0" and a != b
