"""Shared test set-up: one torch thread (DESIGN.md pitfall), headless rendering, SB3's logs in
pytest's temporary folder; a module written for a test to import (:func:`importable`)."""

import importlib
import os
import sys

import pytest

os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("MUJOCO_GL", "egl")
os.environ.setdefault("MPLBACKEND", "Agg")


@pytest.fixture(autouse=True, scope="session")
def sb3_logs(tmp_path_factory):
    """SB3's ``learn`` without a logger of the caller's makes a new ``SB3-<date>`` folder in the
    system's temporary folder at each call, unless ``SB3_LOGDIR`` names one: the tests' all go
    to one folder of pytest's, which pytest clears."""
    with pytest.MonkeyPatch.context() as m:
        m.setenv("SB3_LOGDIR", str(tmp_path_factory.mktemp("sb3")))
        yield


@pytest.fixture(scope="module")
def importable(tmp_path_factory):
    """``importable(name, source)``: the module ``name`` written from ``source`` and imported
    (an outside agent the scoring loads by ``name:Class``), for the test module's tests; its
    folder leaves sys.path and the module sys.modules afterwards."""
    folder = tmp_path_factory.mktemp("importable")
    names: list[str] = []
    sys.path.insert(0, str(folder))

    def write(name: str, source: str):
        (folder / f"{name}.py").write_text(source)
        names.append(name)
        return importlib.import_module(name)

    yield write
    sys.path.remove(str(folder))
    for name in names:
        sys.modules.pop(name, None)


@pytest.fixture(scope="module")
def untrained_run(tmp_path_factory):
    """``untrained_run(name, **fields)``: a run folder holding the ``model.zip`` of a new,
    untrained MaskablePPO of the :class:`~agents.config.TrainConfig` ``fields`` and a
    ``config.json`` naming its tier, environment and architecture (a network to publish or
    start from, without training); nothing else."""
    import json

    pytest.importorskip("sb3_contrib")
    folder = tmp_path_factory.mktemp("untrained")

    def make(name: str, **fields):
        from sb3_contrib import MaskablePPO
        from stable_baselines3.common.vec_env import DummyVecEnv

        from agents.config import TrainConfig
        from agents.training import _new_model
        from modquad_gym.policy.ppo import make_env

        config = TrainConfig(out=folder / name, tensorboard=folder / "tb", **fields)
        venv = DummyVecEnv([lambda: make_env(**config.env_kwargs_full)])
        config.out.mkdir()
        _new_model(config, venv, MaskablePPO).save(config.out / "model.zip")
        venv.close()
        record = {"tier": config.tier, "env_kwargs": config.env_kwargs_full,
                  "architecture": config.architecture}  # fmt: skip
        (config.out / "config.json").write_text(json.dumps(record))
        return config.out

    return make


@pytest.fixture(scope="module")
def blind_model(untrained_run):
    """The model.zip of an untrained size-free network of the support rows alone
    (``lookahead=True``): a model that does not see greedy's choice, as models before the exact
    lookahead were (no shipped model is one)."""
    return untrained_run("blind", env_kwargs={"lookahead": True}) / "model.zip"
