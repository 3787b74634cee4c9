"""The training recipe: behaviour cloning on certified expert episodes, then MaskablePPO.

:class:`~agents.config.TrainConfig` holds one run's settings (the defaults are the recipe);
:func:`train` runs it into ``config.out`` (``model.zip``, ``config.json``,
``evaluations.npz``). ``train.py`` at the repository root is the command-line entry point; a
tier (:mod:`modquad_gym.scoring.tiers`) fixes the environment, the task source and n_max.

1. Expert demonstrations: ``demo_tasks`` training tasks from the tier's task source, drawn from
   ``default_rng([seed, 1])`` (disjoint from the validation and held-out seeds); for each, every
   optimal structure from the certified search and one expert episode that docks towards them
   (:mod:`.imitation`), on ``workers`` processes.
2. Behaviour cloning of the actor-critic on them (``bc_epochs``).
3. MaskablePPO fine-tuning on the environment's reward (``timesteps``), on fresh tasks and, with
   ``focus_tasks``, a share of tasks the cloned policy misses (:mod:`.focus`); evaluated on
   certified validation tasks after cloning (step 0) and every ``eval_freq`` steps
   (:mod:`.validation`); the model with the best validation optimal share is kept (the cloned
   one unless fine-tuning builds more optimal designs). The cloned policy stays beside the
   checkpoints (``cloned_model.zip``) to measure what RL added. With ``--critic-warmup N`` only
   the critic learns for the first N steps (:mod:`.critic_warmup`: the actor's parameters are
   frozen); off in the recipe.
"""

from __future__ import annotations

import json
import os
import platform
import shutil
import time
from pathlib import Path
from typing import Any

from agents.checks import check_environment, check_model, check_network
from agents.config import TrainConfig
from modquad_gym.core.outputs import atomic_write, write_text
from modquad_gym.policy.inference import export
from modquad_gym.scoring.tiers import get_tier

RUN_FILES = ("model.zip", "model_actor.npz", "config.json", "evaluations.npz")
"""What a training run writes into its run folder (``model_actor.npz``: the model's actor for
inference without torch, :mod:`modquad_gym.policy.inference`)."""
LOG_FILES = ("train", "bc", "ppo")
"""What a training run writes into its log folder (``tensorboard/<log_name>``): ``train/``
(checkpoints, evaluations, the best, final and cloned models), ``bc/`` (cloning scalars) and
``ppo/`` (PPO's TensorBoard events: one folder a run's ``--force`` clears and a ``--resume`` of
it goes on in, where SB3's own naming would add ``<log_name>_1``, ``_2``, ... beside it)."""

REPLACED = ("best_model.zip", "evaluations.npz", "cloned_model.zip", "final_model.zip")
"""Files of the log folder's ``train/`` a run removes at its start (the first three: an earlier
run's) or writes over, so a ``--resume`` or ``--init-from`` model cannot be one of them."""


def _ppo_start(config: TrainConfig, model: Any, run_logs: Path, log_dir: Path) -> tuple:
    """Give ``model`` the policy PPO starts from: a saved one (``init_from``) or the cloned one
    (behaviour cloning, saved as ``cloned_model.zip`` to measure what RL adds), anchored for a
    ``kl_coef`` term. (imitation record, the start's path), both None for PPO from scratch."""
    if config.init_from is not None:  # its weights alone: read without unpickling the file
        from modquad_gym.policy.models import read_model

        model.policy.load_state_dict(read_model(config.init_from).weights)
        imitation, cloned = {"init_from": str(config.init_from)}, str(config.init_from)
    elif config.resume is None and config.bc_epochs > 0:
        from agents.pretraining import pretrain

        imitation = pretrain(model, config, run_logs / "bc")
        model.save(log_dir / "cloned_model.zip")
        export(log_dir / "cloned_model.zip")
        cloned = str(log_dir / "cloned_model.zip")
    else:
        return None, None
    model.set_anchor()  # the cloned policy a kl_coef term pulls towards
    return imitation, cloned


def train(config: TrainConfig) -> Path:
    """Train; save ``model.zip``, ``config.json`` and ``evaluations.npz`` in ``config.out``.
    ``config.json`` records the log folder (``log_dir``: checkpoints, ``best_model.zip``) and
    the cloned start (``cloned_model``) relative to the run folder (:func:`beside`), and
    ``steps_per_second`` over the steps trained (whole rollouts: at least those asked)."""
    import torch
    from sb3_contrib import MaskablePPO
    from stable_baselines3.common.logger import configure

    if config.out is None:
        raise ValueError("--out: a run folder is needed")
    check_start(config)
    t_start = time.perf_counter()
    torch.set_num_threads(config.threads)
    out, name, log_dir = _run_folders(config)
    venv = _training_envs(config, config.source)
    modules = get_tier(config.tier).search_kwargs().get("modules")
    val, eval_env = _validation(config, modules)
    model = _new_model(config, venv, MaskablePPO)
    steps_before = int(model.num_timesteps)  # a resumed model's count goes on from its own
    for stale in REPLACED[:3]:  # an earlier run's
        (log_dir / stale).unlink(missing_ok=True)
    imitation, cloned = _ppo_start(config, model, Path(config.tensorboard) / name, log_dir)
    venv, focus = _training_tasks(config, model, modules, venv, imitation is not None)
    warmup = config.critic_warmup if imitation is not None else 0  # a cloned actor to keep
    model.set_logger(configure(str(Path(config.tensorboard) / name / "ppo"), ["tensorboard"]))
    t0 = time.perf_counter()
    model.learn(
        total_timesteps=config.timesteps,
        callback=_callbacks(config, eval_env, val, log_dir, imitation is not None, warmup),
        progress_bar=config.progress,
        reset_num_timesteps=config.resume is None,
    )
    wall = time.perf_counter() - t0
    trained = int(model.num_timesteps) - steps_before  # whole rollouts: often above asked
    model.save(log_dir / "final_model.zip")

    kept = keep_best(log_dir, out, int(model.num_timesteps), cloned)
    record = {
        **run_record(config, model, len(val)),
        **kept,
        "imitation": imitation,
        "critic_warmup_steps": warmup,
        "log_dir": beside(log_dir, out),
        "cloned_model": beside(Path(cloned), out) if cloned else None,
        "focus": focus,
        "wall_seconds": round(time.perf_counter() - t_start, 1),
        "ppo_seconds": round(wall, 1),
        "steps_per_second": round(trained / wall, 1),
    }
    write_text(out / "config.json", json.dumps(record, indent=2) + "\n")
    venv.close()
    eval_env.close()
    print(f"trained {model.num_timesteps} steps in {wall:.0f} s; model: {out / 'model.zip'}")
    return out / "model.zip"


def check_start(config: TrainConfig) -> None:
    """What ``train.py`` checks before any work, for a caller of :func:`train`: the environment
    and the rollout buffer's memory, a ``resume`` or ``init_from`` model of this environment
    (``init_from``: of this run's network too); ValueError naming the option."""
    check_environment(config)
    replaced = {}
    if config.out is not None:
        log_dir = Path(config.tensorboard) / log_name(Path(config.out), Path(config.tensorboard))
        replaced = {(log_dir / "train" / n).resolve(): n for n in REPLACED}
    for option in ("resume", "init_from"):
        if getattr(config, option) is not None:
            where = "--" + option.replace("_", "-")
            name = replaced.get(Path(getattr(config, option)).resolve())
            if name is not None:
                raise ValueError(f"{where}: {getattr(config, option)} is the {name} this run "
                                 "replaces in its log folder; copy it elsewhere first")  # fmt: skip
            check_model(getattr(config, option), config.env_kwargs_full, where)
    if config.init_from is not None:
        check_network(config.init_from, config)


def beside(path: Path, out: Path) -> str:
    """``path`` relative to the run folder ``out`` (how ``config.json`` records the log folder
    and the cloned start: found from the run folder from any working folder)."""
    return Path(os.path.relpath(Path(path).resolve(), Path(out).resolve())).as_posix()


def _run_folders(config: TrainConfig) -> tuple[Path, str, Path]:
    """The run folder, the run's name under ``tensorboard`` and its log folder (checkpoints,
    evaluations), created."""
    out = Path(config.out)
    out.mkdir(parents=True, exist_ok=True)
    name = log_name(out, Path(config.tensorboard))
    log_dir = Path(config.tensorboard) / name / "train"
    log_dir.mkdir(parents=True, exist_ok=True)
    return out, name, log_dir


def _training_envs(config: TrainConfig, tasks: Any) -> Any:
    """``n_envs`` seeded training environments drawing from ``tasks``."""
    from stable_baselines3.common.vec_env import DummyVecEnv, SubprocVecEnv

    from modquad_gym.policy.ppo import make_env

    vec_cls = SubprocVecEnv if config.vec_env == "subproc" else DummyVecEnv
    kwargs = {**config.env_kwargs_full, "tasks": tasks}
    venv = vec_cls([lambda: make_env(**kwargs) for _ in range(config.n_envs)])
    venv.seed(config.seed)
    return venv


def _validation(config: TrainConfig, modules: Any) -> tuple[list, Any]:
    """The certified validation tasks and the environment that cycles through them."""
    from stable_baselines3.common.vec_env import DummyVecEnv

    from agents.validation import certified_validation
    from modquad_gym.policy.ppo import make_env
    from modquad_gym.scoring.suites import CyclingTasks

    val = certified_validation(config.n_eval, config.validation_source, config.max_modules,
                               modules, config.eval_env_kwargs.get("fault"))  # fmt: skip
    val_tasks = CyclingTasks(val, name="validation")
    eval_env = DummyVecEnv(
        [lambda: make_env(tasks=val_tasks, n_max=config.max_modules, **config.eval_env_kwargs)]
    )
    return val, eval_env


def _training_tasks(config: TrainConfig, model: Any, modules: Any, venv: Any,
                    after_cloning: bool) -> tuple:  # fmt: skip
    """The training environments (new ones drawing focused tasks with ``focus_tasks`` after
    cloning) and the focus record; a group sampler on the same tasks with ``advantage
    group``."""
    from modquad_gym.envs.assembly import ModQuadAssemblyEnv
    from modquad_gym.tasks import make_generator

    tasks, focus = make_generator(config.source), None
    if config.focus_tasks and after_cloning:
        tasks, focus = _focus(config, model, modules, tasks)
        venv.close()
        venv = _training_envs(config, tasks)
        model.set_env(venv)
    if config.advantage == "group":
        sampler = ModQuadAssemblyEnv(**{**config.env_kwargs_full, "tasks": tasks})
        model.set_sampler(sampler, config.group_size, [config.seed, 4])
    return venv, focus


def _callbacks(config: TrainConfig, eval_env: Any, val: list, log_dir: Path,
               after_cloning: bool, warmup: int) -> Any:  # fmt: skip
    """Validation (from step 0 after cloning; the best model kept), checkpoints and the
    critic's warm-up of ``warmup`` steps."""
    from stable_baselines3.common.callbacks import CallbackList, CheckpointCallback

    from agents.critic_warmup import critic_warmup_class
    from agents.validation import optimal_eval_class

    per_env = lambda steps: max(steps // config.n_envs, 1)  # noqa: E731
    eval_cb = optimal_eval_class()(
        eval_env,
        optima={t.name: t.meta["optimum"] for t in val},
        n_eval_episodes=len(val),
        eval_freq=per_env(config.eval_every()),
        log_path=str(log_dir),
        best_model_save_path=str(log_dir),
        deterministic=True,
        verbose=0,
        at_start=after_cloning,
    )
    checkpoints = CheckpointCallback(
        per_env(config.checkpoint_freq), str(log_dir / "checkpoints"), name_prefix="ppo"
    )
    return CallbackList([eval_cb, checkpoints, critic_warmup_class()(warmup)])


def _focus(config: TrainConfig, model: Any, modules: Any, generator: Any) -> tuple:
    """The training tasks' generator that draws ``focus_percent`` % of them from those the
    cloned policy misses among ``focus_tasks`` fresh ones (:mod:`.focus`), and what the config
    records of it."""
    import numpy as np

    from agents.focus import FocusedTasks, missed_tasks
    from modquad_gym.envs.assembly import ModQuadAssemblyEnv

    t0 = time.perf_counter()
    rng = np.random.default_rng([config.seed, 3])  # never a validation or held-out seed
    fresh = [generator(rng) for _ in range(config.focus_tasks)]
    env = ModQuadAssemblyEnv(**config.env_kwargs_full)
    missed = missed_tasks(model.policy, env, fresh, config.max_modules, modules, config.progress)
    env.close()
    return FocusedTasks(generator, missed, config.focus_percent), {
        "tasks": config.focus_tasks, "missed": len(missed), "percent": config.focus_percent,
        "task_seed": f"default_rng([{config.seed}, 3])",
        "seconds": round(time.perf_counter() - t0, 1)}  # fmt: skip


def keep_best(log_dir: Path, out: Path, final_step: int, start: str | None = None) -> dict:
    """Copy the kept model and the learning curve from ``log_dir`` into ``out``: the best
    validation checkpoint, or the cloned ``start`` when the checkpoint does not beat it
    significantly (:func:`~modquad_gym.scoring.fine_tuning.kept_index`), or the final model if
    no evaluation ran; what the config records of it."""
    import numpy as np

    from modquad_gym.scoring.fine_tuning import best_index, kept_index

    best = log_dir / "best_model.zip"
    chosen, kept = (best, "best validation checkpoint") if best.is_file() else (
        log_dir / "final_model.zip", "final")  # fmt: skip
    evals = log_dir / "evaluations.npz"
    step, best_step = final_step, None
    if evals.is_file():
        atomic_write(out / "evaluations.npz", lambda tmp: shutil.copyfile(evals, tmp))
        data = np.load(evals)
        if chosen == best:
            best_step = step = int(data["timesteps"][best_index(data)])
            if start is not None and kept_index(data) == 0 != best_index(data):
                chosen, kept, step = Path(start), "cloned start (best not significantly better)", 0
    atomic_write(out / "model.zip", lambda tmp: shutil.copyfile(chosen, tmp))
    export(out / "model.zip")
    return {
        "kept_model": kept,
        "kept_model_timesteps": step,
        "best_checkpoint_timesteps": best_step,
    }


def log_name(out: Path, tensorboard: Path) -> str:
    """The run's folder name under ``tensorboard``: the run folder's name, prefixed by its
    parent's unless the run lies in ``tensorboard`` itself (so ``runs/seeds-large/seed-0`` and
    ``runs/seeds-current/seed-0`` never share checkpoints)."""
    if out.resolve().parent == tensorboard.resolve():
        return out.name
    return f"{out.resolve().parent.name}-{out.name}"


def _new_model(config: TrainConfig, venv: Any, MaskablePPO: Any) -> Any:
    """A fresh seeded MaskablePPO with the recipe's hyperparameters, or the ``resume`` model
    (naming no TensorBoard folder, which SB3 would save again: the run sets its own logger)."""
    if config.resume is not None:
        return MaskablePPO.load(config.resume, env=venv, device="cpu", tensorboard_log=None)
    hp = config.ppo_hyperparameters()
    del hp["net_arch"], hp["hidden"]  # the network's: config.policy()
    policy, policy_kwargs = config.policy()
    from agents.group_ppo import group_ppo_class

    return group_ppo_class()(
        policy,
        venv,
        policy_kwargs=policy_kwargs,
        seed=config.seed,
        device="cpu",
        verbose=0,
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
