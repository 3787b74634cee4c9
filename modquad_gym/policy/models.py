"""The PPO models shipped with the package, and loading a saved one."""

from __future__ import annotations

import json
from pathlib import Path

from modquad_gym.core.extras import import_optional

MODELS_DIR = Path(__file__).resolve().parents[1] / "data" / "models"
"""Where the shipped models lie: one folder per model (``model.zip`` and ``config.json``)."""

DEFAULT_MODEL = MODELS_DIR / "ppo_default" / "model.zip"
"""The default PPO model shipped with the package (its config.json lies beside it)."""


def shipped_model(name: str) -> Path:
    """The shipped model of a benchmark tier: ``ppo_default`` for ``current``, ``ppo_<name>``
    for the others."""
    default = globals()["DEFAULT_MODEL"]  # looked up per call: tests redirect it
    return default if name == "current" else MODELS_DIR / f"ppo_{name}" / default.name


LOAD_ERRORS = (AssertionError, EOFError, KeyError, OSError, RuntimeError, TypeError, ValueError)
"""What reading a file that is not a saved model raises (SB3, zipfile, pickle, torch)."""


class NoOptimizer:
    """Stands in for the optimizer when a policy is loaded for inference: building a torch
    optimizer imports torch's compiler (about 1.5 s), which inference never needs."""

    def __init__(self, *args, **kwargs) -> None:
        pass


def load_model(path: str | Path | None = None):
    """(policy network, its config dict or {}) from a saved MaskablePPO ``path`` (default
    :data:`DEFAULT_MODEL`): the trained actor-critic (an SB3 policy, in evaluation mode), without
    the PPO algorithm and its optimizer, which inference does not need.

    Raises ValueError when the file does not exist or is not a saved MaskablePPO model. Sets torch
    to one thread."""
    torch = import_optional("torch")
    import_optional("sb3_contrib")  # the policy classes a saved model names
    load_from_zip_file = import_optional("stable_baselines3.common.save_util").load_from_zip_file

    torch.set_num_threads(1)
    path = Path(path) if path is not None else DEFAULT_MODEL
    if path.is_dir():
        raise ValueError(f"--model {path}: a folder; give the model .zip file in it")
    if not path.is_file():
        hint = " (train it with `python train.py`)" if path == DEFAULT_MODEL else ""
        raise ValueError(f"PPO model file {path} does not exist{hint}")
    try:
        data, params, _ = load_from_zip_file(path, device="cpu", print_system_info=False)
        kwargs = {**data["policy_kwargs"], "optimizer_class": NoOptimizer}
        spaces = data["observation_space"], data["action_space"]
        policy = data["policy_class"](*spaces, lambda _: 0.0, **kwargs)
        policy.load_state_dict(params["policy"])
    except LOAD_ERRORS as exc:  # no model data, zipfile/pickle/torch errors, another net
        reason = " ".join(str(exc).split()) or type(exc).__name__
        raise ValueError(f"--model {path}: not a MaskablePPO model .zip ({reason})") from None
    policy.set_training_mode(False)
    config_path = path.with_name("config.json")
    config = json.loads(config_path.read_text()) if config_path.is_file() else {}
    return policy, config
