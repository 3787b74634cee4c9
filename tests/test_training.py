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
from modquad_gym.envs.assembly import ModQuadAssemblyEnv
from modquad_gym.policy.inference import exported
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


def test_the_fault_tier_trains_for_its_failure(tmp_path):
    """Its environment, its expert's optima, the learner's completions and its validation
    optima are all the failure's: none is a nominal answer."""
    from agents.dagger import completion_targets
    from agents.imitation import expert_targets
    from modquad_gym.search import optimal_structures
    from modquad_gym.tasks import load_task

    config = TrainConfig(out=tmp_path, tier="fault")
    assert config.env_kwargs_full["fault"] == "rotor" == config.eval_env_kwargs["fault"]
    task = load_task("example:screwdriver")  # optimum 3; 4 after any rotor failure
    assert expert_targets(task, 6, "all", None, "rotor") == optimal_structures(
        task, n_max=6, fault="rotor"
    )
    assert expert_targets(task, 6, "all")[0] == 3 and expert_targets(task, 6, "all", None,
                                                                      "rotor")[0] == 4  # fmt: skip
    env = ModQuadAssemblyEnv(tasks=[task], n_max=6, fault="rotor")
    env.reset(seed=0)
    (target,) = completion_targets(env, task, 6)
    assert len(target) == 4  # a minimum completion that survives, not the intact 3


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
    for name in ("model.zip", "model_actor.npz", "config.json", "evaluations.npz"):
        assert (target.parent / name).read_bytes() == (tmp_path / "run" / name).read_bytes()
    assert exported(target) is not None  # the run wrote its actor for NumPy inference


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


@pytest.mark.parametrize("warmup", [0, 10**6])
def test_critic_warmup_keeps_the_actor_and_fits_the_critic(tmp_path, suite, warmup):
    """During the warm-up PPO moves only the critic's own parameters (the cloned actor acts
    exactly as before); without it the actor moves too."""
    from sb3_contrib import MaskablePPO
    from stable_baselines3.common.vec_env import DummyVecEnv

    from agents.critic_warmup import critic_parameters, critic_warmup_class
    from agents.training import _new_model
    from modquad_gym.policy.ppo import make_env

    config = TrainConfig(out=tmp_path / "run", task_source=str(suite), n_max=3, seed=0,
                         tensorboard=tmp_path / "tb",
                         hyperparameters={"n_steps": 64, "batch_size": 32})  # fmt: skip
    venv = DummyVecEnv([lambda: make_env(**config.env_kwargs_full)])
    model = _new_model(config, venv, MaskablePPO)
    before = {n: p.detach().clone() for n, p in model.policy.named_parameters()}
    model.learn(128, callback=critic_warmup_class()(warmup))
    critic = critic_parameters(model.policy)
    assert critic and critic < set(before)
    moved = {n for n, p in model.policy.named_parameters() if not torch.equal(p, before[n])}
    assert moved & critic
    assert bool(moved - critic) == (warmup == 0)
    assert all(p.requires_grad for p in model.policy.parameters())  # thawed at the end


def test_the_report_says_what_fine_tuning_did_from_the_learning_curve(tmp_path):
    """The report's sentence on PPO is read off evaluations.npz: a falling curve is never
    called a rise, and a rise names its numbers."""
    from modquad_gym.scoring.fine_tuning import fine_tuning_words

    def words(returns, successes) -> str:
        path = tmp_path / "evaluations.npz"
        steps = np.arange(len(returns)) * 1000
        np.savez(path, timesteps=steps, results=np.array(returns)[:, None].repeat(2, axis=1),
                 successes=np.array(successes)[:, None].repeat(2, axis=1))  # fmt: skip
        return fine_tuning_words(path)

    fell = words([1.65, 1.62, 1.62], [1.0, 0.975, 0.975])
    assert "did not raise" in fell and "1.6500 at step 0, success 100.0 %" in fell
    assert "ended at 1.6200 at step 2000, success 97.5 %" in fell
    noise = words([1.6167, 1.6171, 1.6146], [0.975, 0.975, 0.975])  # a partial share: no module
    assert "did not raise" in noise and "best was 1.6171 at step 1000" in noise
    rose = words([1.60, 1.58, 1.64, 1.63], [0.95, 0.95, 1.0, 1.0])
    assert "raised the validation return from the cloned policy's 1.6000 at step 0" in rose
    assert "to 1.6400 at step 2000" in rose and "ended at 1.6300 at step 3000" in rose
    assert "(0.8 modules over the 2 validation tasks)" in rose


def test_config_records_the_rate_of_the_steps_trained(tmp_path, suite):
    """SB3 trains whole rollouts (here 2 envs x 64 steps for 64 asked): steps_per_second
    divides the steps trained, not the steps asked, by PPO's time."""
    config = TrainConfig(
        out=tmp_path / "run", task_source=str(suite), n_max=3, timesteps=64, bc_epochs=0,
        dagger_rounds=0, n_eval=1, tensorboard=tmp_path / "tb", progress=False,
        hyperparameters={"n_steps": 64, "batch_size": 32},
    )  # fmt: skip
    train(config)
    record = json.loads((tmp_path / "run" / "config.json").read_text())
    assert (record["timesteps_requested"], record["timesteps"]) == (64, 128)
    rate = record["timesteps"] / record["ppo_seconds"]  # ppo_seconds is rounded to 0.1 s
    assert record["steps_per_second"] == pytest.approx(rate, rel=0.1 / record["ppo_seconds"])
    assert record["steps_per_second"] > 1.5 * 64 / record["ppo_seconds"]
