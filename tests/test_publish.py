"""Publishing a run as a shipped model (``train.py --publish-run``, ``agents.publishing``): the
slot then holds that run's files only, a grid MLP never becomes the size-free default model,
no shipped model names a TensorBoard folder, and the docs' recipe for ``ppo_scale`` ships
every file of that slot."""

from __future__ import annotations

import json
import re
import shlex
import zipfile
from pathlib import Path

import pytest

from modquad_gym.policy.models import MODELS_DIR

pytest.importorskip("sb3_contrib")
ROOT = Path(__file__).resolve().parents[1]
STALE = {"model.zip": b"old model", "config.json": b"{}", "evaluations.npz": b"old curve",
         "model_actor.npz": b"old export"}  # fmt: skip
"""A slot's files before the publish: the model it replaces."""


def _slot(folder: Path) -> Path:
    folder.mkdir()
    for name, data in STALE.items():
        (folder / name).write_bytes(data)
    return folder / "model.zip"


def test_a_publish_leaves_none_of_the_replaced_models_files(tmp_path, untrained_run, monkeypatch):
    """A run without a learning curve (no evaluation ran) or a NumPy export: the slot keeps no
    evaluations.npz of the model it replaces, and its export is the new model's."""
    from agents.cli import main
    from modquad_gym.policy.inference import exported

    run = untrained_run("plain")
    assert not (run / "evaluations.npz").exists() and not (run / "model_actor.npz").exists()
    slot = _slot(tmp_path / "shipped")
    monkeypatch.setattr("modquad_gym.policy.models.DEFAULT_MODEL", slot)
    assert main(["--publish-run", str(run), "--no-report"]) == 0
    assert sorted(p.name for p in slot.parent.iterdir()) == [
        "config.json", "model.zip", "model_actor.npz"]  # fmt: skip
    assert slot.read_bytes() == (run / "model.zip").read_bytes()
    assert (slot.parent / "config.json").read_bytes() == (run / "config.json").read_bytes()
    found = exported(slot)  # the new model's actor, of its very bytes
    assert found is not None and found.path == slot


def test_a_grid_model_leaves_no_export_of_the_model_it_replaces(tmp_path, untrained_run):
    """A grid MLP has no NumPy export: the one of the replaced model is removed (its SHA would
    make inference ignore it, but the slot would hold another model's file)."""
    from agents.publishing import publish

    run = untrained_run("mlp-fault", tier="fault", architecture="mlp")  # the fault tier's
    slot = _slot(tmp_path / "ppo_fault")
    assert publish(run, slot) == slot
    assert sorted(p.name for p in slot.parent.iterdir()) == ["config.json", "model.zip"]


def test_a_grid_mlp_is_never_the_size_free_default_model(tmp_path, untrained_run, monkeypatch,
                                                         capsys):  # fmt: skip
    """The default model serves every budget below 16 modules and the large tier: a grid MLP
    (one n_max) is refused in one line naming --architecture mlp, by --publish-run, by
    --publish before training and by publish(), and the slot is left as it was."""
    from agents.cli import main, parse_args

    run = untrained_run("mlp", architecture="mlp")
    slot = _slot(tmp_path / "shipped")
    monkeypatch.setattr("modquad_gym.policy.models.DEFAULT_MODEL", slot)
    argvs = (["--publish-run", str(run), "--no-report"],
             ["--architecture", "mlp", "--publish", "--out", str(tmp_path / "new"),
              "--tensorboard", str(tmp_path / "tb"), "--no-report"])  # fmt: skip
    for argv, names in zip(argvs, ("--publish-run", "--publish")):
        with pytest.raises(SystemExit) as stop:
            (main if "--publish-run" in argv else parse_args)(argv)
        last = capsys.readouterr().err.strip().splitlines()[-1]
        assert stop.value.code == 2 and names in last and "--architecture mlp" in last, last
    from agents.publishing import publish

    with pytest.raises(ValueError, match="--architecture candidates"):
        publish(run, slot)
    assert {p.name: p.read_bytes() for p in slot.parent.iterdir()} == STALE
    assert not (tmp_path / "new").exists()


def _naming_a_folder(model: Path, folder: Path) -> Path:
    """``model`` saved again by SB3 naming the TensorBoard folder ``folder`` (as a model
    trained with ``tensorboard_log=folder`` is, and one loaded from it)."""
    from sb3_contrib import MaskablePPO

    MaskablePPO.load(model, device="cpu", tensorboard_log=str(folder)).save(model)
    return model


def _members(path: Path) -> list[tuple[str, bytes]]:
    with zipfile.ZipFile(path) as archive:
        return [(info.filename, archive.read(info)) for info in archive.infolist()]


def test_a_published_model_names_no_tensorboard_folder(tmp_path, untrained_run):
    """A run whose model names the folder it logged to (a developer's path): the shipped copy
    names none, so SB3's ``learn`` after ``MaskablePPO.load`` on a user's machine writes no
    events there; every other member is the run's, and the export is of the installed bytes."""
    from sb3_contrib import MaskablePPO

    from agents.publishing import publish
    from modquad_gym.policy.inference import exported

    run = untrained_run("logged")
    _naming_a_folder(run / "model.zip", tmp_path / "dev-runs")
    slot = publish(run, _slot(tmp_path / "shipped"))
    ran, shipped = _members(run / "model.zip"), _members(slot)
    assert json.loads(dict(ran)["data"])["tensorboard_log"] == str(tmp_path / "dev-runs")
    assert json.loads(dict(shipped)["data"]) == {**json.loads(dict(ran)["data"]),
                                                 "tensorboard_log": None}  # fmt: skip
    assert [m for m in shipped if m[0] != "data"] == [m for m in ran if m[0] != "data"]
    assert [m[0] for m in shipped] == [m[0] for m in ran]
    assert MaskablePPO.load(slot, device="cpu").tensorboard_log is None
    assert exported(slot) is not None


def test_a_resumed_or_iterated_model_names_no_tensorboard_folder(tmp_path, untrained_run):
    """``train.py --resume`` and expert iteration load a model that may name a folder: the
    model they train and save names none (SB3 would keep its start's)."""
    from sb3_contrib import MaskablePPO
    from stable_baselines3.common.vec_env import DummyVecEnv

    from agents.config import TrainConfig
    from agents.expert_iteration import load_for_training
    from agents.training import _new_model
    from modquad_gym.policy.ppo import make_env

    start = _naming_a_folder(untrained_run("start") / "model.zip", tmp_path / "dev-runs")
    config = TrainConfig(out=tmp_path / "resumed", tensorboard=tmp_path / "tb", resume=start)
    venv = DummyVecEnv([lambda: make_env(**config.env_kwargs_full)])
    assert MaskablePPO.load(start, device="cpu").tensorboard_log is not None
    assert _new_model(config, venv, MaskablePPO).tensorboard_log is None
    assert load_for_training(start, 9).tensorboard_log is None
    venv.close()


def test_the_docs_recipe_for_ppo_scale_ships_every_file_of_its_slot():
    """The learned designer's page retrains ppo_scale and copies the run's files into it:
    every file the shipped slot holds (a model.zip without its fresh model_actor.npz would
    leave a stale export beside it), each one the expert iteration writes."""
    from agents.expert_iteration import OUTPUTS

    text = (ROOT / "docs" / "learned-designer.md").read_text()
    (line,) = [s for s in text.splitlines() if re.match(r"cp .*ppo_scale/?$", s.strip())]
    *sources, target = shlex.split(line)[1:]
    assert Path(target) == Path("modquad_gym/data/models/ppo_scale")
    copied = {Path(s).name for s in sources}
    assert copied == {p.name for p in (MODELS_DIR / "ppo_scale").iterdir()}
    assert copied <= set(OUTPUTS) and {Path(s).parent for s in sources} == {Path("runs/exit")}
