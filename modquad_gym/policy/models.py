"""The PPO models shipped with the package, and loading a saved one."""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from modquad_gym.core.extras import import_optional

MODELS_DIR = Path(__file__).resolve().parents[1] / "data" / "models"
"""Where the shipped models lie: one folder per model (``model.zip`` and ``config.json``)."""

DEFAULT_MODEL = MODELS_DIR / "ppo_default" / "model.zip"
"""The default PPO model shipped with the package (its config.json lies beside it)."""

SCALE_MODEL = MODELS_DIR / "ppo_scale" / "model.zip"
"""The shipped model for budgets of :data:`SCALE_FROM` modules and more: the default recipe's
model after expert iteration on tasks of 8-32 modules (``agents.expert_iteration``)."""
SCALE_FROM = 16
"""The budget (n_max) from which a learned method without ``--model`` uses :data:`SCALE_MODEL`."""
TOP_K = 8
"""Children the learned solvers (``ppo``, ``ppo-guided``) decide exactly per step with a model
that reads the exact lookahead (the env's ``lookahead_top_k``: the others, ranked lower by cheap
support bounds, are masked out); their option ``top_k`` (None: every child, as in training).
Chosen on validation draws: ``results/lookahead_top_k/``."""
FALLBACK = 0.7
"""At budgets of :data:`SCALE_FROM` modules and more, the ``ppo`` single pass docks greedy's
choice (the exact lookahead's flag) wherever the policy gives its own most likely docking at most
this probability: the policy decides where it is sure, greedy's rule where it is not (its option
``fallback``; 0: the policy always). Chosen on validation draws (``results/fallback/``): fewer
modules than the policy alone at 16-64 modules, fewer optimal designs at 7 (where the policy is
trained and greedy is weaker), so smaller budgets keep the policy alone."""
EXTRA_FALLBACKS = (0.0, 1.0)
"""At budgets of :data:`SCALE_FROM` modules and more, the ``ppo`` decoding also follows the
deterministic episodes of these fallbacks (the policy alone; greedy's choice among the
shortlist), branching from its own where they dock elsewhere, and keeps the smallest verified
structure (its option ``extra_fallbacks``), where its own episode ends with more than
:data:`EXTRA_FROM` modules. Chosen on validation draws (``results/extra_fallbacks/``): at 16-64
modules fewer modules than greedy on 40 of 128 draws and more on 4 (the single pass: 36 and
12), in 0.22 of greedy's CPU time (0.11)."""
EXTRA_FROM = 16
"""The default extra passes run where the first one ends with more modules than this: each
costs about as much as the first, and a pass takes a third of greedy's time at 16 modules, a
sixth at 32 (``results/extra_fallbacks/``)."""
GUIDED_BUDGET = 64
"""Structures the ``ppo-guided`` search evaluates per task below :data:`SCALE_FROM` modules (its
option ``budget``)."""
BUDGET_PER_MODULE = 20
"""From :data:`SCALE_FROM` modules, ``ppo-guided`` evaluates up to this many structures per
module of its dive's answer (at least :data:`GUIDED_BUDGET`): its time then grows with the
structure as beam's does. Chosen on validation draws (``results/guided_budget/``): at 16-64
modules fewer modules than beam in 0.95 of its time (2.7 times it at 16, where beam is fastest),
where 64 structures gave as many in 0.18."""
QUEUE_MEMORY = 128 * 2**20
"""Bytes of environment states that default budget may keep queued (an expanded structure's
state stays while a child of it waits): at 128 modules with three types a state takes 0.67 MB."""


def default_model(n_max: int | None = None, modules: Any = None) -> Path:
    """The model a learned method uses without ``--model`` (one pair, the same network): with
    one module type and a budget of at least :data:`SCALE_FROM` modules :data:`SCALE_MODEL`,
    which has seen the long lever arms of large one-type structures, else
    :data:`DEFAULT_MODEL`, the better one on small tasks (``results/expert_iteration``) and
    the one with a palette of ``modules``."""
    if n_max is not None and n_max >= SCALE_FROM and not modules:
        return globals()["SCALE_MODEL"]
    return globals()["DEFAULT_MODEL"]  # looked up per call: tests redirect it


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


@dataclass(frozen=True)
class SavedModel:
    """A saved MaskablePPO read for inference: its policy class, keywords, spaces, weights, and
    the config.json beside it ({} when none)."""

    path: Path
    policy_class: type
    policy_kwargs: dict
    observation_space: Any
    action_space: Any
    weights: dict
    config: dict

    @property
    def size_free(self) -> bool:
        """Whether its weights fit any grid size and palette (rebuilt for any environment)."""
        return bool(getattr(self.policy_class, "size_free", False))

    def build(self, observation_space=None, action_space=None, **overrides):
        """The policy network (evaluation mode) for the given spaces (default the saved ones;
        others only for a :attr:`size_free` model), its saved keywords updated by
        ``overrides``."""
        spaces = (observation_space or self.observation_space, action_space or self.action_space)
        kwargs = {**self.policy_kwargs, **overrides, "optimizer_class": NoOptimizer}
        try:
            policy = self.policy_class(*spaces, lambda _: 0.0, **kwargs)
            policy.load_state_dict(self.weights)
        except LOAD_ERRORS as exc:  # a state dict of another network
            reason = " ".join(str(exc).split()) or type(exc).__name__
            raise ValueError(f"--model {self.path}: cannot rebuild its policy ({reason})") from None
        policy.set_training_mode(False)
        return policy


def model_file(path: str | Path | None = None) -> Path:
    """``path`` (default :data:`DEFAULT_MODEL`) as a Path; ValueError when it is a folder or
    does not exist, or when it is empty (``Path("")`` would be the working folder)."""
    if isinstance(path, str) and not path:
        from modquad_gym.core.options import EMPTY_PATH

        raise ValueError(f"--model: {EMPTY_PATH}")
    path = Path(path) if path is not None else DEFAULT_MODEL
    if path.is_dir():
        raise ValueError(f"--model {path}: a folder; give the model .zip file in it")
    if not path.is_file():
        hint = " (train it with `python train.py`)" if path == DEFAULT_MODEL else ""
        raise ValueError(f"PPO model file {path} does not exist{hint}")
    return path


def read_model(path: str | Path | None = None) -> SavedModel:
    """The saved MaskablePPO at ``path`` (default :data:`DEFAULT_MODEL`), without the PPO
    algorithm and its optimizer, which inference does not need.

    Raises ValueError when the file does not exist or is not a saved MaskablePPO model. Sets torch
    to one thread."""
    torch = import_optional("torch")
    import_optional("sb3_contrib")  # the policy classes a saved model names
    load_from_zip_file = import_optional("stable_baselines3.common.save_util").load_from_zip_file

    torch.set_num_threads(1)
    path = model_file(path)
    try:
        data, params, _ = load_from_zip_file(path, device="cpu", print_system_info=False)
        spaces = data["observation_space"], data["action_space"]
        saved = (data["policy_class"], dict(data["policy_kwargs"]), *spaces, params["policy"])
    except LOAD_ERRORS as exc:  # no model data, zipfile/pickle/torch errors
        reason = " ".join(str(exc).split()) or type(exc).__name__
        raise ValueError(f"--model {path}: not a MaskablePPO model .zip ({reason})") from None
    return SavedModel(path, *saved, read_config(path))


def read_config(model_path: str | Path) -> dict:
    """The config.json beside the model at ``model_path`` ({} when there is none); ValueError
    naming the file when it is not a JSON object (with an ``env_kwargs`` object, if any)."""
    path = Path(model_path).with_name("config.json")
    if not path.is_file():
        return {}
    try:
        config = json.loads(path.read_text())
    except (OSError, ValueError) as exc:  # unreadable, not UTF-8, not JSON
        raise ValueError(f"{path}: not a model's config ({' '.join(str(exc).split())})") from None
    if not isinstance(config, dict) or not isinstance(config.get("env_kwargs", {}), dict):
        raise ValueError(f"{path}: not a model's config (a JSON object, env_kwargs an object)")
    return config


def load_model(path: str | Path | None = None):
    """(policy network, config dict) of the saved model at ``path`` (see :func:`read_model`),
    for the spaces it was trained with."""
    saved = read_model(path)
    return saved.build(), saved.config
