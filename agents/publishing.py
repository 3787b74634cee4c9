"""Publishing a run: its model, config and learning curve become a tier's shipped model.

``train.py --publish`` (after training) and ``--publish-run RUN`` (a run trained before) install
a run folder's files into the tier's slot under ``modquad_gym/data/models/`` (``ppo_default`` on
the current tier, ``ppo_<tier>`` on the others). The slot then holds that run's files only: a
file the run lacks is removed from it (no learning curve or NumPy export of the model it
replaces stays beside the new one). The run is checked first, and nothing is replaced
otherwise: its model must play the tier's environment, and a slot that serves other sizes (the
default model: every learned method below 16 modules, the large tier) takes only the
size-free network (``--architecture candidates``). The installed model.zip names no TensorBoard
folder (:func:`without_log_folder`).
"""

from __future__ import annotations

import filecmp
import json
import shutil
import zipfile
from pathlib import Path

from agents.checks import check_model
from agents.config import TrainConfig
from agents.training import RUN_FILES
from modquad_gym.core.outputs import atomic_write
from modquad_gym.policy.inference import export, export_path, exported
from modquad_gym.policy.models import SCALE_FROM
from modquad_gym.scoring.tiers import TIERS


def run_tier(config: Path) -> str:
    """The tier a run folder's ``config.json`` names (``--publish-run``)."""
    try:
        tier = json.loads(Path(config).read_text()).get("tier", "current")
    except (OSError, ValueError, AttributeError) as exc:
        raise ValueError(f"--publish-run: {config} is not a run's config ({exc})") from None
    if tier not in TIERS:
        raise ValueError(f"--publish-run: {config} names an unknown tier {tier!r}")
    return tier


def tier_env_kwargs(tier: str) -> dict:
    """The environment a tier's shipped model plays (its recipe's training environment)."""
    return TrainConfig(out=Path("."), tier=tier).env_kwargs_full


def size_free_slot(tier: str) -> str | None:
    """Why the shipped model of ``tier`` must act at any n_max (it serves other sizes than the
    tier's own), or None when it plays its tier only."""
    uses = [f"the {t.name} tier's model (n_max {t.n_max})" for t in TIERS.values()
            if t.model_tier == tier]  # fmt: skip
    if tier == "current":
        uses.insert(0, f"the learned methods' default model below {SCALE_FROM} modules")
    return " and ".join(uses) or None


def refuse_grid_model(tier: str, what: str) -> None:
    """A ValueError for a grid MLP (``what``: the run or option that gives it) published as the
    shipped model of ``tier`` when that slot must act at any size (:func:`size_free_slot`)."""
    uses = size_free_slot(tier)
    if uses:
        raise ValueError(
            f"{what}: a grid MLP (--architecture mlp) acts at one n_max only; the {tier} "
            f"tier's shipped model is {uses}: publish a --architecture candidates run"
        )


def check_publishable(run: Path, tier: str) -> None:
    """A run folder whose model may become ``tier``'s shipped model: its config is readable,
    its model loads and plays its own environment and the tier's actions, and it is size-free
    where the slot must be (``--publish-run``)."""
    try:
        config = json.loads((Path(run) / "config.json").read_text())
        env_kwargs = dict(config.get("env_kwargs", {}))
    except (OSError, ValueError, AttributeError, TypeError) as exc:
        raise ValueError(f"--publish-run {run}: its config.json is not a run's ({exc})") from None
    network = check_model(Path(run) / "model.zip", env_kwargs, "--publish-run",
                          tier_env_kwargs(tier))  # fmt: skip
    if not getattr(type(network), "size_free", False):
        refuse_grid_model(tier, f"--publish-run {run}")


def publish(run: Path, model: Path | None = None) -> Path:
    """Install a run's model, config and learning curve as its tier's shipped model (``model``:
    the model.zip path to write; default the tier's, :attr:`~modquad_gym.scoring.tiers.Tier.
    model`) and return it. The run is checked first (:func:`check_publishable`): nothing is
    replaced otherwise. Every file of :data:`~agents.training.RUN_FILES` the run lacks is
    removed from the slot; the model.zip names no TensorBoard folder (:func:`without_log_folder`);
    the NumPy export is the run's own when fresh for the installed bytes, else written anew (none
    for a grid MLP)."""
    run = Path(run)
    tier = run_tier(run / "config.json")
    check_publishable(run, tier)
    target = Path(model) if model is not None else TIERS[tier].model
    target.parent.mkdir(parents=True, exist_ok=True)
    actor = export_path(run / "model.zip")
    for name in RUN_FILES:
        path = target if name == "model.zip" else target.with_name(name)
        if name == actor.name:  # the export: below
            continue
        copy = without_log_folder if name == "model.zip" else shutil.copyfile
        if (run / name).is_file():
            atomic_write(path, lambda tmp, n=name, c=copy: c(run / n, tmp))
        else:
            path.unlink(missing_ok=True)
    if exported(run / "model.zip") is not None and filecmp.cmp(run / "model.zip", target, False):
        # the run's export, of these very bytes
        atomic_write(export_path(target), lambda tmp: shutil.copyfile(actor, tmp))
    elif export(target) is None:  # a grid MLP: no NumPy export, and none of the old model
        export_path(target).unlink(missing_ok=True)
    print(f"published {run} as the shipped model {target}")
    return target


def without_log_folder(source: Path, target: Path) -> None:
    """Write the saved model ``source`` to ``target`` naming no TensorBoard folder
    (``tensorboard_log`` null in its ``data``): SB3 saves the folder a model was trained with
    (a resumed model keeps its start's), and its ``learn`` after ``MaskablePPO.load`` writes
    events there, on the user's machine, unless given a logger. Only ``data`` changes: every
    other member keeps its bytes, place and compression. A model that names no folder is
    copied byte for byte."""
    with zipfile.ZipFile(source) as archive:
        data = json.loads(archive.read("data"))
        if not isinstance(data, dict) or data.get("tensorboard_log") is None:
            shutil.copyfile(source, target)
            return
        data["tensorboard_log"] = None
        written = json.dumps(data, indent=4).encode()  # as SB3 writes it
        with zipfile.ZipFile(target, "w") as out:
            for info in archive.infolist():
                out.writestr(info, written if info.filename == "data" else archive.read(info))
