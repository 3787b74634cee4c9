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


def load_model(path: str | Path | None = None):
    """(MaskablePPO model, its config dict or {}) from ``path`` (default :data:`DEFAULT_MODEL`).

    Raises ValueError when the file does not exist or is not a saved MaskablePPO model. Sets torch
    to one thread."""
    torch = import_optional("torch")
    MaskablePPO = import_optional("sb3_contrib").MaskablePPO

    torch.set_num_threads(1)
    path = Path(path) if path is not None else DEFAULT_MODEL
    if path.is_dir():
        raise ValueError(f"--model {path}: a folder; give the model .zip file in it")
    if not path.is_file():
        hint = " (train it with `python train.py`)" if path == DEFAULT_MODEL else ""
        raise ValueError(f"PPO model file {path} does not exist{hint}")
    try:
        model = MaskablePPO.load(path, device="cpu")
    except (AssertionError, EOFError, KeyError, OSError, RuntimeError, ValueError) as exc:
        # SB3 asserts on a zip without model data, zipfile/pickle/torch raise their own errors
        reason = " ".join(str(exc).split()) or type(exc).__name__
        raise ValueError(f"--model {path}: not a MaskablePPO model .zip ({reason})") from None
    config_path = path.with_name("config.json")
    config = json.loads(config_path.read_text()) if config_path.is_file() else {}
    return model, config
