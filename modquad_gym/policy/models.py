"""The PPO models shipped with the package, and loading a saved one."""

from __future__ import annotations

import contextlib
import json
import pickle
import zipfile
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from modquad_gym.core.extras import import_optional
from modquad_gym.core.validation import NOT_REGULAR, check_flag, check_int
from modquad_gym.search.options import check_seed, check_time_limit, count, share, shares

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
Chosen on validation draws: ``results/lookahead_top_k/``. A model's config.json may set its own
(:func:`model_top_k`)."""
MODEL_TOP_K = "model"
"""The learned solvers' default ``top_k``: the model's own (:func:`model_top_k`)."""
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
SMALL_EXTRA_FALLBACKS = (0.5, 1.0)
"""Below :data:`SCALE_FROM` modules, the ``ppo`` decoding also follows the deterministic episodes
of these fallbacks (greedy's choice where the policy is below even odds; greedy's choice among
the shortlist), branching from its own where they dock elsewhere, whatever size the first ends
at (its option ``extra_fallbacks``). Chosen on 200 small validation tasks with five training
seeds' models (``results/extra_fallbacks/small_seeds/``): optimal share 86.7 -> 89.9 %, in 1.16
times the single pass's CPU time (greedy: 83.0 % in 1.88 times it)."""
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


def check_top_k(value: Any, name: str) -> Any:
    """A learned solver's ``top_k``: an integer >= 1, or :data:`MODEL_TOP_K` (the model's own)."""
    if isinstance(value, str) and value == MODEL_TOP_K:
        return value
    return check_int(value, name, low=1)


def model_top_k(config: dict, where: str = "config") -> int | None:
    """The shortlist the learned solvers use by default with the model of ``config``: its
    ``top_k`` (an integer >= 1, or None: every child) where it has one, else :data:`TOP_K`.
    A model's own is chosen on its tier's validation tasks: the mixed tier's three module types
    give many more children per state than one type (``results/lookahead_top_k_mixed/``).
    ValueError naming ``where`` (``<folder>/config.json``) for another value."""
    if "top_k" not in config:
        return TOP_K
    value = config["top_k"]
    return None if value is None else check_int(value, f"{where}: top_k", low=1)


def check_model(value: Any, name: str) -> Any:
    """A learned method's ``model``: a path (str or Path) of a PPO .zip, a loaded
    :class:`~modquad_gym.policy.Policy`, or a loaded SB3 model or policy network; else a
    ValueError naming ``name`` (the file itself is read when the solver is made). A Policy and
    a network both have an ``observation_space``."""
    net = getattr(value, "policy", value)
    if isinstance(value, (str, Path)) or hasattr(net, "observation_space"):
        return value
    raise ValueError(
        f"{name} must be the path of a PPO model .zip or a loaded model (Policy, MaskablePPO), "
        f"got {value!r}"
    )


MAX_SAMPLES = 1000
"""The most sampled rollouts of ``ppo`` (``samples``, ``ppo-kN``, ``modquad score --samples``):
the documented runs take 8."""

LEARNED_CHECKS = {
    "model": check_model, "seed": check_seed, "samples": count(0, MAX_SAMPLES),
    "time_limit": check_time_limit, "top_k": check_top_k, "fallback": share,
    "extra_fallbacks": shares, "budget": count(1), "branching": count(1), "dive": check_flag,
    "trust_model": check_flag,
}  # fmt: skip
"""The one check of each option of the learned methods (``check(value, name) -> value``):
:func:`~modquad_gym.solvers.make_solver`'s options (:mod:`modquad_gym.methods`) and the
solver classes (:class:`~.ppo.PPOSolver`, :class:`~.guided.GuidedSolver`) call the same."""


def check_learned(name: str, value: Any) -> Any:
    """``value`` of the learned methods' option ``name`` checked (None passes: its default)."""
    return value if value is None else LEARNED_CHECKS[name](value, name)


def unused_seed(method: str, seed: int, samples: int) -> str | None:
    """Why a ``seed`` other than the default 0 is refused for ``method`` (ppo) with ``samples``
    0: its passes are then deterministic, it draws nothing at random (the words after the
    option's name, as for a method that takes no seed); None where the seed is used."""
    if seed == 0 or samples:
        return None
    return (f"method {method!r} does not take it without samples: it then draws nothing at "
            "random (its sampled rollouts do: ppo-kN)")  # fmt: skip


def one_default_type(modules: Any) -> bool:
    """Whether ``modules`` (None or a list of module types) is the default T-module alone, as
    no palette is: what the one-type models were trained with."""
    from modquad_gym.search.problem import DEFAULT_MODULE

    return not modules or len(modules) == 1 and modules[0].digest == DEFAULT_MODULE.digest


def default_model(n_max: int | None = None, modules: Any = None) -> Path:
    """The model a learned method uses without ``--model`` (one pair, the same network): with
    one module type, the T-module (no palette, or ``modules`` naming it alone:
    :func:`one_default_type`), and a budget of at least :data:`SCALE_FROM` modules
    :data:`SCALE_MODEL`, which has seen the long lever arms of large one-type structures, else
    :data:`DEFAULT_MODEL`, the better one on small tasks (``results/expert_iteration``) and
    the one with any other palette of ``modules``."""
    if n_max is not None and n_max >= SCALE_FROM and one_default_type(modules):
        return globals()["SCALE_MODEL"]
    return globals()["DEFAULT_MODEL"]  # looked up per call: tests redirect it


def shipped_model(name: str) -> Path:
    """The shipped model of a benchmark tier: ``ppo_default`` for ``current``, ``ppo_<name>``
    for the others."""
    default = globals()["DEFAULT_MODEL"]  # looked up per call: tests redirect it
    return default if name == "current" else MODELS_DIR / f"ppo_{name}" / default.name


LOAD_ERRORS = (AssertionError, EOFError, KeyError, OSError, RecursionError, RuntimeError,
               TypeError, ValueError, pickle.UnpicklingError, zipfile.BadZipFile)  # fmt: skip
"""What reading a file that is not a saved model raises (zipfile, JSON, torch's weights-only
reader)."""
UNTRUSTED = "a model .zip holds pickled Python objects that run code when loaded"
"""Why a model file is unpickled only when the user trusts it (``--trust-model``)."""


def check_trusted(path: str | Path, trust: bool, what: str, why: str) -> None:
    """ValueError naming ``what`` and ``path`` unless the model file may be unpickled (``why``
    says what would): ``trust`` given (``--trust-model``), or a model shipped with the package,
    which is as trusted as its code."""
    if trust or Path(path).resolve().is_relative_to(MODELS_DIR):
        return
    raise ValueError(f"{what} {path}: {why} unpickles it, and {UNTRUSTED}; give --trust-model "
                     "if you trust this file")  # fmt: skip


def reason_of(exc: BaseException) -> str:
    """Why a file is not a model, in one short line: the error's first sentence (torch's run
    on for a paragraph), at most 200 characters."""
    text = " ".join(str(exc).split()).split(". ")[0] or type(exc).__name__
    return text if len(text) <= 200 else text[:199] + "…"


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
            reason = reason_of(exc)
            raise ValueError(f"--model {self.path}: cannot rebuild its policy ({reason})") from None
        policy.set_training_mode(False)
        return policy


def model_file(path: str | Path | None = None) -> Path:
    """``path`` (default :data:`DEFAULT_MODEL`) as a Path; ValueError when it is a folder, not a
    regular file (a device or pipe) or does not exist, or when it is empty (``Path("")`` would
    be the working folder)."""
    if isinstance(path, str) and not path:
        raise ValueError("--model: an empty path; give the model .zip file")
    path = Path(path) if path is not None else DEFAULT_MODEL
    if path.is_dir():
        raise ValueError(f"--model {path}: a folder; give the model .zip file in it")
    if path.exists() and not path.is_file():
        raise ValueError(f"--model {path}: {NOT_REGULAR}")
    if not path.is_file():
        hint = " (train it with `python train.py`)" if path == DEFAULT_MODEL else ""
        raise ValueError(f"PPO model file {path} does not exist{hint}")
    return path


def read_model(path: str | Path | None = None, trust: bool = False) -> SavedModel:
    """The saved MaskablePPO at ``path`` (default :data:`DEFAULT_MODEL`) for inference, read
    without unpickling (:mod:`.model_zip`); a model that only unpickling reads is loaded so
    when ``trust`` is True (the user trusts the file: ``--trust-model``), else refused.

    Raises ValueError naming the file when it does not exist, is not a saved MaskablePPO of
    the assembly environment, or needs ``trust``."""
    from modquad_gym.policy import model_zip

    import_optional("torch")  # a missing extra: said before the file is read
    import_optional("sb3_contrib")  # the policy classes a saved model names
    path = model_file(path)
    try:
        saved = model_zip.read_safely(path)
    except model_zip.NeedsUnpicklingError as need:
        if not trust:
            raise ValueError(
                f"--model {path}: its {need.what} can only be read by unpickling it, and "
                f"{UNTRUSTED}; give --trust-model if you trust this file"
            ) from None
        saved = read_unpickled(path)
    except model_zip.NotAssemblyModelError as exc:
        raise ValueError(
            f"--model {path}: not a model of the assembly environment ({exc})"
        ) from None
    except LOAD_ERRORS as exc:  # no model data, zipfile/JSON/torch errors
        raise ValueError(
            f"--model {path}: not a MaskablePPO model .zip ({reason_of(exc)})"
        ) from None
    return SavedModel(path, *saved, read_config(path))


@contextlib.contextmanager
def one_torch_thread() -> Iterator[None]:
    """torch on one thread while the package's own torch network acts (one observation at a
    time: a second thread costs more than it gives), the caller's thread count restored after
    (docs/learned-designer.md)."""
    import torch

    before = torch.get_num_threads()
    torch.set_num_threads(1)
    try:
        yield
    finally:
        torch.set_num_threads(before)


def read_unpickled(path: Path) -> tuple:
    """What :func:`read_model` reads, by SB3's loader, which unpickles the file's ``data``
    (the caller trusts it); checked to be a masked policy of the assembly environment."""
    from sb3_contrib.common.maskable.policies import MaskableActorCriticPolicy

    from modquad_gym.policy.model_zip import OBSERVATION_KEYS

    load_from_zip_file = import_optional("stable_baselines3.common.save_util").load_from_zip_file
    try:
        data, params, _ = load_from_zip_file(path, device="cpu", print_system_info=False)
        spaces = data["observation_space"], data["action_space"]
        saved = (data["policy_class"], dict(data["policy_kwargs"]), *spaces, params["policy"])
    except Exception as exc:  # noqa: BLE001 - unpickling a broken file raises anything
        raise ValueError(
            f"--model {path}: not a MaskablePPO model .zip ({reason_of(exc)})"
        ) from None
    keys = getattr(spaces[0], "spaces", {})
    if not all(k in keys for k in OBSERVATION_KEYS):
        raise ValueError(f"--model {path}: not a model of the assembly environment (its "
                         f"observation space is {spaces[0]})")  # fmt: skip
    if not (isinstance(saved[0], type) and issubclass(saved[0], MaskableActorCriticPolicy)):
        name = getattr(saved[0], "__name__", saved[0])
        raise ValueError(f"--model {path}: not a MaskablePPO model .zip (its policy {name} is "
                         "not a masked one)")  # fmt: skip
    return saved


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


def load_model(path: str | Path | None = None, trust: bool = False):
    """(policy network, config dict) of the saved model at ``path`` (see :func:`read_model`),
    for the spaces it was trained with."""
    saved = read_model(path, trust)
    return saved.build(), saved.config
