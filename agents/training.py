"""The training recipe: behaviour cloning on certified expert episodes, then MaskablePPO.

:class:`TrainConfig` holds one run's settings (the defaults are the recipe); :func:`train` runs
it into ``config.out`` (``model.zip``, ``config.json``, ``evaluations.npz``). ``train.py`` at the
repository root is the command-line entry point; a tier (:mod:`.tiers`) fixes the environment,
the task source and n_max.

1. Expert demonstrations: ``demo_tasks`` training tasks from the tier's task source, drawn from
   ``default_rng([seed, 1])`` (disjoint from the validation and held-out seeds); for each, every
   optimal structure from the certified search and one expert episode that docks towards them
   (:mod:`.imitation`), on ``workers`` processes.
2. Behaviour cloning of the actor-critic on them (``bc_epochs``).
3. MaskablePPO fine-tuning on the environment's reward (``timesteps``), evaluated on validation
   tasks after cloning (step 0) and every ``eval_freq`` steps by :class:`EvalFromStart`; the
   model with the best validation return is kept.
"""

from __future__ import annotations

import json
import platform
import shlex
import shutil
import time
from dataclasses import MISSING, dataclass, field, fields
from pathlib import Path
from typing import Any

from agents.checks import (
    MAX_N_ENVS,
    MAX_STEPS,
    check_hyperparameters,
    check_numbers,
    check_publishable,
)
from agents.imitation import EXPERTS
from modquad_gym.core.extras import import_optional
from modquad_gym.core.options import MAX_SEED, seed_option
from modquad_gym.core.outputs import atomic_write, write_text
from modquad_gym.policy.models import DEFAULT_MODEL
from modquad_gym.scoring.tiers import TIERS, get_tier
from modquad_gym.tasks import GENERATORS

RUN_FILES = ("model.zip", "config.json", "evaluations.npz")
"""What a training run writes into its run folder."""

HYPERPARAMETERS = {
    "learning_rate": 1e-4,
    "n_steps": 256,
    "batch_size": 128,
    "n_epochs": 8,
    "gamma": 1.0,
    "gae_lambda": 0.95,
    "clip_range": 0.2,
    "ent_coef": 0.005,
    "vf_coef": 0.5,
    "max_grad_norm": 0.5,
    "net_arch": [256, 256],
    "hidden": 64,
}
"""MaskablePPO hyperparameters of the recipe (fine-tuning after behaviour cloning); ``net_arch``
shapes the ``mlp`` architecture, ``hidden`` the ``candidates`` one."""
IMITATION = {"demo_tasks": 6_000, "bc_epochs": 30, "bc_batch_size": 256, "bc_learning_rate": 1e-3,
             "dagger_rounds": 3, "dagger_epochs": 10}  # fmt: skip
"""Behaviour-cloning settings of the recipe (see :mod:`.imitation`) and of the expert in the
loop (:mod:`.dagger`: rounds, cloning epochs after each round; fresh tasks per round default
to a tenth of the demonstration tasks)."""
ARCHITECTURES = ("candidates", "mlp")
"""Policy networks: ``candidates`` scores each candidate docking with shared weights
(:mod:`modquad_gym.policy.network`: any n_max, any palette; the env's lookahead rows), ``mlp``
is SB3's MultiInputPolicy over the whole observation (one grid size)."""
LOOKAHEAD = "exact"
"""The lookahead rows the ``candidates`` network sees: the exact one-step lookahead (each
child's exact share, margin and greedy's choice, :mod:`modquad_gym.envs.assembly.lookahead`);
``--env-kwargs '{"lookahead": true}'`` trains on the support rows alone, as models before it."""
DEFAULT_TIMESTEPS = 20_000
VEC_ENVS = ("dummy", "subproc")


def option(default: Any, help: str, group: str = "recipe", **argparse: Any) -> Any:
    """A :class:`TrainConfig` field that is also the ``train.py`` option ``--name``
    (:mod:`agents.cli` derives the option from the field): its help (``{recipe}`` stands for
    the tiers' recipes of it), its group of ``--help``, an integer's ``limits`` (low, high;
    :func:`~agents.checks.check_numbers`) and argparse keywords besides the type and default,
    which come from the field."""
    metadata = {"help": help, "group": group, **argparse}
    if isinstance(default, dict):
        return field(default_factory=dict, metadata=metadata)
    return field(default=default, metadata=metadata)


@dataclass(frozen=True)
class TrainConfig:
    """One training run. Fields left None take the tier's value (``task_source``, ``n_max`` and
    the tier's ``recipe``), then the recipe's; ``eval_freq`` defaults to ``timesteps / 20``.
    Every field is a ``train.py`` option (``--n-envs`` for ``n_envs``; ``--no-progress`` for
    ``progress``)."""

    out: Path = option(
        None,
        "run folder for model.zip, config.json, evaluations.npz and report/ (default "
        "runs/ppo-seed<seed>; runs/<tier>-seed<seed> on other tiers; runs/ppo-seeds with "
        "--seeds; runs/quick with --quick)",
        "run",
    )
    tier: str = option(
        "current",
        "benchmark tier: its environment, task source, n_max and held-out suites",
        "run",
        choices=tuple(TIERS),
    )
    seed: int = option(
        0, "training seed; env i uses seed + i", "run", type=seed_option, limits=(0, MAX_SEED)
    )
    timesteps: int | None = option(
        None,
        f"total PPO environment steps (default {DEFAULT_TIMESTEPS}; {{recipe}})",
        limits=(1, MAX_STEPS),
    )
    n_envs: int = option(2, "parallel environments", limits=(1, MAX_N_ENVS))
    vec_env: str = option(
        "dummy", "vectorised env class (dummy: faster on 2 cores)", choices=VEC_ENVS
    )
    task_source: str | None = option(
        None,
        "a task generator name (planted, paper, mixed, planted-large, ...) or a task/suite "
        "file (default: the tier's: mixed on current)",
    )
    n_max: int | None = option(
        None,
        "largest structure in modules (default: the tier's, 7 on current)",
        limits=(1, 10**4),
    )
    demo_tasks: int | None = option(
        None,
        "training tasks with an expert episode each for behaviour cloning (default "
        f"{IMITATION['demo_tasks']}; {{recipe}})",
        "imitation",
        limits=(1, 10**7),
    )
    bc_epochs: int = option(
        IMITATION["bc_epochs"],
        "behaviour-cloning epochs before PPO; 0: PPO alone from scratch",
        "imitation",
        limits=(0, 10**5),
    )
    expert: str | None = option(
        None,
        "what the expert docks towards: all optimal structures, or one, the first the "
        "certified search finds (default all; {recipe})",
        "imitation",
        choices=EXPERTS,
    )
    architecture: str = option(
        "candidates",
        "policy network: candidates (one score per candidate docking, shared weights: acts at "
        "any n_max and palette; the env's lookahead rows) or mlp (SB3's MultiInputPolicy, one "
        "grid size)",
        choices=ARCHITECTURES,
    )
    dagger_rounds: int = option(
        IMITATION["dagger_rounds"],
        "rounds of the expert in the loop after cloning: the learner's own episodes on fresh "
        "tasks, every state labelled by the certified search, cloned again; 0: none",
        "imitation",
        limits=(0, 10**4),
    )
    dagger_tasks: int | None = option(
        None,
        "fresh training tasks per DAgger round (default a tenth of --demo-tasks)",
        "imitation",
        limits=(1, 10**7),
    )
    workers: int = option(
        2, "processes that collect the expert demonstrations", "imitation", limits=(1, 1024)
    )
    resume: Path | None = option(
        None, "continue PPO from this model .zip (no behaviour cloning)", "run"
    )
    eval_freq: int | None = option(
        None,
        "evaluate every this many total steps (default timesteps / 20)",
        limits=(1, MAX_STEPS),
    )
    n_eval: int = option(40, "validation tasks", limits=(1, 100_000))
    checkpoint_freq: int = option(
        50_000,
        "checkpoint every this many total steps, under --tensorboard",
        limits=(1, MAX_STEPS),
    )
    tensorboard: Path = option(
        Path("runs"), "TensorBoard logs and checkpoints (runs/ is gitignored)", "run"
    )
    threads: int = option(1, "torch threads", limits=(1, 1024))
    progress: bool = option(True, "no progress bars", "run")
    env_kwargs: dict = option(
        {}, 'extra env keywords as JSON, e.g. \'{"reward_weights": {"w_module": 0.2}}\''
    )
    hyperparameters: dict = option(
        {},
        "MaskablePPO hyperparameters overriding the recipe, as JSON, e.g. "
        f"'{{\"ent_coef\": 0.02}}'; known: {', '.join(HYPERPARAMETERS)}",
    )

    def __post_init__(self) -> None:
        tier = get_tier(self.tier)
        defaults = {
            "timesteps": DEFAULT_TIMESTEPS,
            "demo_tasks": IMITATION["demo_tasks"],
            "expert": "all",
            **tier.recipe,
        }
        for name, value in defaults.items():
            if getattr(self, name) is None:
                object.__setattr__(self, name, value)
        if self.dagger_tasks is None:
            object.__setattr__(self, "dagger_tasks", max(1, self.demo_tasks // 10))
        if self.expert not in EXPERTS:
            raise ValueError(f"expert must be one of {EXPERTS}, got {self.expert!r}")
        if self.architecture not in ARCHITECTURES:
            raise ValueError(
                f"architecture must be one of {ARCHITECTURES}, got {self.architecture!r}"
            )
        unknown = sorted(set(self.hyperparameters) - set(HYPERPARAMETERS))
        if unknown:
            raise ValueError(
                f"--hyperparameters: unknown keys {unknown}; known: {sorted(HYPERPARAMETERS)}"
            )
        check_numbers(self)  # every number in range, named by its train.py option
        check_hyperparameters(self.hyperparameters)
        if {"tasks", "n_max"} & set(self.env_kwargs):
            raise ValueError("--env-kwargs: give tasks and n_max with --task-source and --n-max")

    @property
    def source(self) -> str:
        """The training task source (the tier's unless given)."""
        return self.task_source or get_tier(self.tier).source or "mixed"

    @property
    def max_modules(self) -> int:
        return self.n_max if self.n_max is not None else get_tier(self.tier).n_max

    @property
    def env_kwargs_full(self) -> dict:
        """The training environment's keywords (what the model's config.json records): on a
        tier of several module types its palette, each episode starting with a random type."""
        return {"tasks": self.source, "n_max": self.max_modules, **self.eval_env_kwargs,
                **({"initial_type": "random"} if get_tier(self.tier).modules else {})}  # fmt: skip

    @property
    def eval_env_kwargs(self) -> dict:
        """Keywords of the validation environment besides its tasks and n_max (episodes start
        with the first type, as :class:`~.ppo.PPOSolver` does first)."""
        modules = get_tier(self.tier).modules
        lookahead = {"lookahead": LOOKAHEAD} if self.architecture == "candidates" else {}
        return {**({"modules": modules} if modules else {}), **lookahead, **self.env_kwargs}

    @property
    def validation_source(self) -> str:
        """The validation tasks' generator: the training source when it is a generator name,
        else (a task file) the tier's."""
        return self.source if self.source in GENERATORS else get_tier(self.tier).source or "mixed"

    def ppo_hyperparameters(self) -> dict:
        return {**HYPERPARAMETERS, **self.hyperparameters}

    def command(self) -> str:
        """The ``python train.py`` command line that runs this config (what ``config.json``
        records): the tier, the seed, the run folder and every field away from its default."""
        parts = ["train.py"]
        for f in fields(self):
            value = getattr(self, f.name)
            default = f.default_factory() if f.default is MISSING else f.default
            if f.name not in ("tier", "seed", "out") and _same(value, default):
                continue
            flag = "--" + f.name.replace("_", "-")
            if f.type == "bool":
                parts.append(f"--no-{f.name}")
            else:
                parts += [flag, json.dumps(value) if isinstance(value, dict) else str(value)]
        return shlex.join(parts)


def _same(value: Any, default: Any) -> bool:
    if isinstance(value, Path) and isinstance(default, Path):
        return value.resolve() == default.resolve()
    return value == default


def _eval_callback_class():
    """:class:`EvalFromStart`, built on first use so importing this module needs no SB3."""
    MaskableEvalCallback = import_optional(
        "sb3_contrib.common.maskable.callbacks"
    ).MaskableEvalCallback

    class EvalFromStart(MaskableEvalCallback):
        """MaskableEvalCallback that also evaluates when training starts (step 0 of the
        learning curve), so the cloned policy is the best model to beat: fine-tuning is kept
        only if it does better on validation."""

        def __init__(self, *args: Any, at_start: bool = True, **kwargs: Any) -> None:
            super().__init__(*args, **kwargs)
            self.at_start = at_start

        def _on_training_start(self) -> None:
            super()._on_training_start()
            if self.at_start:
                self._on_step()  # n_calls == 0: the parent's evaluation runs

    return EvalFromStart


def train(config: TrainConfig) -> Path:
    """Train; save ``model.zip``, ``config.json`` and ``evaluations.npz`` in ``config.out``."""
    import torch
    from sb3_contrib import MaskablePPO
    from stable_baselines3.common.callbacks import CallbackList, CheckpointCallback
    from stable_baselines3.common.vec_env import DummyVecEnv, SubprocVecEnv

    from modquad_gym.policy.ppo import make_env
    from modquad_gym.scoring.suites import CyclingTasks, validation_tasks

    if config.out is None:
        raise ValueError("--out: a run folder is needed")
    t_start = time.perf_counter()
    torch.set_num_threads(config.threads)
    out = Path(config.out)
    out.mkdir(parents=True, exist_ok=True)
    name = log_name(out, Path(config.tensorboard))
    log_dir = Path(config.tensorboard) / name / "train"  # checkpoints, evaluations
    log_dir.mkdir(parents=True, exist_ok=True)

    env_kwargs = config.env_kwargs_full
    vec_cls = SubprocVecEnv if config.vec_env == "subproc" else DummyVecEnv
    venv = vec_cls([lambda: make_env(**env_kwargs) for _ in range(config.n_envs)])
    venv.seed(config.seed)
    val = validation_tasks(config.n_eval, config.validation_source)
    val_tasks = CyclingTasks(val, name="validation")
    eval_env = DummyVecEnv(
        [lambda: make_env(tasks=val_tasks, n_max=config.max_modules, **config.eval_env_kwargs)]
    )
    model = _new_model(config, venv, MaskablePPO)
    per_env = lambda steps: max(steps // config.n_envs, 1)  # noqa: E731
    for stale in ("best_model.zip", "evaluations.npz"):  # from an earlier run into this folder
        (log_dir / stale).unlink(missing_ok=True)
    imitation = None
    if config.resume is None and config.bc_epochs > 0:
        from agents.pretraining import pretrain

        imitation = pretrain(model, config, Path(config.tensorboard) / name / "bc")
    eval_freq = config.eval_freq or max(config.timesteps // 20, 512)
    eval_cb = _eval_callback_class()(
        eval_env,
        n_eval_episodes=len(val),
        eval_freq=per_env(eval_freq),
        log_path=str(log_dir),
        best_model_save_path=str(log_dir),
        deterministic=True,
        verbose=0,
        at_start=imitation is not None,
    )
    checkpoints = CheckpointCallback(
        per_env(config.checkpoint_freq), str(log_dir / "checkpoints"), name_prefix="ppo"
    )
    t0 = time.perf_counter()
    model.learn(
        total_timesteps=config.timesteps,
        callback=CallbackList([eval_cb, checkpoints]),
        tb_log_name=name,
        progress_bar=config.progress,
        reset_num_timesteps=config.resume is None,
    )
    wall = time.perf_counter() - t0
    model.save(log_dir / "final_model.zip")

    kept = keep_best(log_dir, out, int(model.num_timesteps))
    record = {
        **run_record(config, model, len(val)),
        **kept,
        "imitation": imitation,
        "wall_seconds": round(time.perf_counter() - t_start, 1),
        "ppo_seconds": round(wall, 1),
        "steps_per_second": round(config.timesteps / wall, 1),
    }
    write_text(out / "config.json", json.dumps(record, indent=2) + "\n")
    venv.close()
    eval_env.close()
    print(f"trained {model.num_timesteps} steps in {wall:.0f} s; model: {out / 'model.zip'}")
    return out / "model.zip"


def keep_best(log_dir: Path, out: Path, final_step: int) -> dict:
    """Copy the model with the best validation return (the final one if no evaluation ran)
    and the learning curve from ``log_dir`` into ``out``; what the config records of it."""
    import numpy as np

    best = log_dir / "best_model.zip"
    chosen = best if best.is_file() else log_dir / "final_model.zip"
    atomic_write(out / "model.zip", lambda tmp: shutil.copyfile(chosen, tmp))
    evals = log_dir / "evaluations.npz"
    step = final_step
    if evals.is_file():
        atomic_write(out / "evaluations.npz", lambda tmp: shutil.copyfile(evals, tmp))
        data = np.load(evals)
        if chosen == best:
            step = int(data["timesteps"][int(np.argmax(data["results"].mean(axis=1)))])
    kept = "best validation return" if chosen == best else "final"
    return {"kept_model": kept, "kept_model_timesteps": step}


def log_name(out: Path, tensorboard: Path) -> str:
    """The run's folder name under ``tensorboard``: the run folder's name, prefixed by its
    parent's unless the run lies in ``tensorboard`` itself (so ``runs/seeds-large/seed-0`` and
    ``runs/seeds-current/seed-0`` never share checkpoints)."""
    if out.resolve().parent == tensorboard.resolve():
        return out.name
    return f"{out.resolve().parent.name}-{out.name}"


def _new_model(config: TrainConfig, venv: Any, MaskablePPO: Any) -> Any:
    """A fresh seeded MaskablePPO with the recipe's hyperparameters, or the ``resume`` model."""
    if config.resume is not None:
        return MaskablePPO.load(
            config.resume, env=venv, device="cpu", tensorboard_log=str(config.tensorboard)
        )
    hp = config.ppo_hyperparameters()
    net_arch, hidden = hp.pop("net_arch"), hp.pop("hidden")
    policy: Any = "MultiInputPolicy"
    policy_kwargs: dict = {"net_arch": net_arch}
    if config.architecture == "candidates":
        from modquad_gym.geometry.module import palette
        from modquad_gym.policy.network import CandidatePolicy, type_features

        policy = CandidatePolicy
        modules = get_tier(config.tier).modules
        types = palette(modules or "t45")
        policy_kwargs = {"hidden": hidden, "types": type_features(types)}
    return MaskablePPO(
        policy,
        venv,
        policy_kwargs=policy_kwargs,
        seed=config.seed,
        device="cpu",
        verbose=0,
        tensorboard_log=str(config.tensorboard),
        **hp,
    )


def run_record(config: TrainConfig, model: Any, n_validation: int) -> dict:
    """What ``config.json`` records about a run besides its results: everything needed to
    load the model and to repeat the run."""
    return {
        "env_id": get_tier(config.tier).env_id,
        "tier": config.tier,
        "env_kwargs": config.env_kwargs_full,
        "algorithm": "MaskablePPO",
        "policy": type(model.policy).__name__,
        "architecture": config.architecture,
        "hyperparameters": config.ppo_hyperparameters(),
        "seed": config.seed,
        "n_envs": config.n_envs,
        "vec_env": config.vec_env,
        "timesteps": int(model.num_timesteps),
        "timesteps_requested": config.timesteps,
        "resumed_from": str(config.resume) if config.resume else None,
        "validation": {
            "n_tasks": n_validation,
            "source": config.validation_source,
            "seeds": "modquad_gym.scoring.suites.VALIDATION_SEED0 + i",
        },
        "torch_threads": config.threads,
        "command": config.command(),
        "versions": versions(),
    }


def versions() -> dict:
    """Versions of the packages a trained model depends on, and the platform."""
    import gymnasium
    import numpy
    import sb3_contrib
    import stable_baselines3
    import torch

    import modquad_gym

    return {
        "python": platform.python_version(),
        "modquad_gym": modquad_gym.__version__,
        "numpy": numpy.__version__,
        "torch": torch.__version__,
        "gymnasium": gymnasium.__version__,
        "stable_baselines3": stable_baselines3.__version__,
        "sb3_contrib": sb3_contrib.__version__,
        "platform": platform.platform(),
    }


def report(model: Path, out: Path, tier: str, quick: bool = False, progress: bool = True) -> None:
    """The benchmark report of ``model`` on its tier's held-out suites, into ``out``
    (``modquad score``, called as a function; ``quick``: 3 tasks per suite, 2 samples)."""
    from modquad_gym.scoring.agents import score
    from modquad_gym.scoring.options import command_line, score_options

    given = {"model": shown(model), "out": shown(out), "tier": tier, "force": True,
             "train_dir": shown(Path(model).parent)}  # fmt: skip
    if quick:
        given.update(limit=3, samples=2)
    score(score_options(**given, no_progress=not progress), command_line(**given))


def shown(path: Path) -> Path:
    """``path`` relative to the working folder when it lies inside it (as reports print it)."""
    path, here = Path(path).resolve(), Path.cwd().resolve()
    return path.relative_to(here) if path.is_relative_to(here) else path


def publish(run: Path, model: Path = DEFAULT_MODEL) -> Path:
    """Install a run's model, config and learning curve as a shipped model (``model``: the
    model.zip path to write; default the package's default model). The run's model is checked
    first (a saved MaskablePPO of the run's own environment): nothing is replaced otherwise."""
    tier = json.loads((Path(run) / "config.json").read_text()).get("tier", "current")
    check_publishable(run, TrainConfig(out=Path(run), tier=tier).env_kwargs_full)
    target = Path(model).parent
    target.mkdir(parents=True, exist_ok=True)
    for name in RUN_FILES:
        if (run / name).is_file():
            atomic_write(target / name, lambda tmp, n=name: shutil.copyfile(run / n, tmp))
    print(f"published {run} as the shipped model {model}")
    return Path(model)
