"""Train the PPO agent of modquad_gym (MaskablePPO on ``ModQuadAssembly-v0``) and write the
benchmark report.

``python train.py`` runs the default recipe (below) into a new run folder ``runs/<name>/``
(default name ``ppo-seed<seed>``: ``model.zip``, ``config.json``, ``evaluations.npz`` and the
benchmark report in ``report/``); it refuses a run folder that exists unless ``--force``.
``--publish`` also installs the model as the package's default
(``modquad_gym/data/models/ppo_default/``) and writes the report into ``results/``.
``python train.py --quick`` is a short smoke run (a few thousand steps) into ``runs/quick``.
``python train.py --help`` lists every option.

Default recipe (one policy for the whole task distribution, <= 30 min on 2 CPU cores):

1. Expert demonstrations: ``--demo-tasks`` training tasks from the task source (``mixed``:
   planted tasks of 2-6 modules and paper-like tasks, equal odds), drawn from
   ``default_rng([seed, 1])`` (disjoint from the validation and held-out seeds); for each, every
   optimal structure from the certified search and one expert episode that docks towards them
   (:mod:`modquad_gym.agents.imitation`), on ``--workers`` processes.
2. Behaviour cloning of the MaskablePPO actor-critic on them (``--bc-epochs``): the policy learns
   which dockings keep an optimal structure reachable, the critic the expert's return-to-go.
3. MaskablePPO fine-tuning on the environment's own reward (``--timesteps``), n_max 7, the
   ``MultiInputPolicy`` (occupancy grid, action mask, task and structure features, flattened and
   concatenated) with a [256, 256] MLP for policy and value, gamma 1 (episodes are at most
   n_max - 1 steps, so the module cost is counted exactly), 2 environments, one torch thread.

Evaluation on 40 validation tasks (seeds disjoint from the held-out suites, see
:mod:`modquad_gym.agents.suites`) after cloning (step 0) and periodically while fine-tuning;
the model with the best validation return is kept as ``model.zip``; its ``config.json`` holds
the exact environment keywords, hyperparameters, seed, timesteps, wall time and versions.
``--bc-epochs 0`` trains with PPO alone (from scratch), as in the first version of the recipe.

``python train.py --seeds 0 1 2`` trains one run per seed as parallel Ray tasks
(:mod:`modquad_gym.distributed`: an embedded Ray on the local cores, or the cluster of
``RAY_ADDRESS``), each exactly ``python train.py --seed S`` with the other options given, into
its own folder ``<out>/seed-S`` (default ``<out>``: ``runs/seeds``) with its report in
``<out>/seed-S/report``; each run collects its demonstrations in its own process.
"""

from __future__ import annotations

import argparse
import json
import platform
import shutil
import sys
import time
from pathlib import Path

from modquad_gym.agents.benchmark import REPORT_FILES
from modquad_gym.agents.solvers import DEFAULT_MODEL
from modquad_gym.outputs import OutputError, check_output_dir

ROOT = Path(__file__).resolve().parent
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
}
"""MaskablePPO hyperparameters of the default recipe (fine-tuning after behaviour cloning)."""
IMITATION = {"demo_tasks": 12_000, "bc_epochs": 40, "bc_batch_size": 256, "bc_learning_rate": 1e-3}
"""Behaviour-cloning settings of the default recipe (see :mod:`modquad_gym.agents.imitation`)."""
DEFAULT_TIMESTEPS = 200_000
QUICK_TIMESTEPS = 4_096
QUICK_DEMO_TASKS = 40


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    p = argparse.ArgumentParser(
        prog="python train.py",
        description="Train MaskablePPO on ModQuadAssembly-v0 (one policy for planted and "
        "paper-like tasks of mixed sizes), save the model with its config, then write the "
        "benchmark report (results/benchmark.md).",
    )
    p.add_argument(
        "--timesteps",
        type=int,
        default=None,
        help=f"total environment steps (default {DEFAULT_TIMESTEPS}, "
        f"{QUICK_TIMESTEPS} with --quick)",
    )
    p.add_argument(
        "--n-envs", type=int, default=2, help="parallel environments (default %(default)s)"
    )
    p.add_argument(
        "--vec-env",
        choices=("dummy", "subproc"),
        default="dummy",
        help="vectorised env class (default %(default)s: faster on 2 cores)",
    )
    p.add_argument(
        "--seed",
        type=int,
        default=0,
        help="training seed; env i uses seed + i (default %(default)s)",
    )
    p.add_argument(
        "--task-source",
        default="mixed",
        help="planted, paper, mixed, or a task/suite file (default %(default)s)",
    )
    p.add_argument(
        "--n-max", type=int, default=7, help="largest structure in modules (default %(default)s)"
    )
    p.add_argument(
        "--out",
        type=Path,
        default=None,
        help="run folder for model.zip, config.json, evaluations.npz and report/ "
        "(default runs/ppo-seed<seed>, runs/quick with --quick)",
    )
    p.add_argument(
        "--force", action="store_true", help="replace the files of an existing run folder"
    )
    p.add_argument(
        "--publish",
        action="store_true",
        help="also install the model as the package default (modquad_gym/data/models/"
        "ppo_default) and write the report into results/",
    )
    p.add_argument(
        "--demo-tasks",
        type=int,
        default=None,
        help=f"training tasks with an expert episode each for behaviour cloning (default "
        f"{IMITATION['demo_tasks']}, {QUICK_DEMO_TASKS} with --quick)",
    )
    p.add_argument(
        "--bc-epochs",
        type=int,
        default=IMITATION["bc_epochs"],
        help="behaviour-cloning epochs before PPO; 0: PPO alone from scratch (default %(default)s)",
    )
    p.add_argument(
        "--workers",
        type=int,
        default=2,
        help="processes that collect the expert demonstrations (default %(default)s)",
    )
    p.add_argument(
        "--resume",
        type=Path,
        default=None,
        help="continue PPO from this model .zip (no behaviour cloning)",
    )
    p.add_argument(
        "--seeds",
        type=int,
        nargs="+",
        default=None,
        metavar="SEED",
        help="train one run per seed, as parallel Ray tasks, each into <out>/seed-SEED "
        "(default <out>: runs/seeds)",
    )
    p.add_argument(
        "--seed-workers",
        type=int,
        default=None,
        help="with --seeds: runs at a time (default: one per seed, at most the local cores; "
        "every CPU of the cluster with RAY_ADDRESS)",
    )
    p.add_argument("--quick", action="store_true", help="a short smoke run (a few thousand steps)")
    p.add_argument("--no-report", action="store_true", help="skip the benchmark report")
    p.add_argument(
        "--report-dir",
        type=Path,
        default=None,
        help="where the report goes (default <out>/report, results with --publish)",
    )
    p.add_argument(
        "--eval-freq",
        type=int,
        default=None,
        help="evaluate every this many total steps (default timesteps / 20)",
    )
    p.add_argument("--n-eval", type=int, default=40, help="validation tasks (default %(default)s)")
    p.add_argument(
        "--checkpoint-freq",
        type=int,
        default=50_000,
        help="checkpoint every this many total steps, under --tensorboard (default %(default)s)",
    )
    p.add_argument(
        "--tensorboard",
        type=Path,
        default=ROOT / "runs",
        help="TensorBoard logs and checkpoints (default runs/, gitignored)",
    )
    p.add_argument("--threads", type=int, default=1, help="torch threads (default %(default)s)")
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    p.add_argument(
        "--env-kwargs",
        type=json.loads,
        default={},
        help='extra env keywords as JSON, e.g. \'{"reward_weights": {"w_module": 0.2}}\'',
    )
    p.add_argument(
        "--hyperparameters",
        type=json.loads,
        default={},
        help="MaskablePPO hyperparameters overriding the recipe, as JSON, e.g. "
        '\'{"ent_coef": 0.02, "net_arch": [256, 256]}\'',
    )
    args = p.parse_args(argv)
    if args.timesteps is None:
        args.timesteps = QUICK_TIMESTEPS if args.quick else DEFAULT_TIMESTEPS
    if args.demo_tasks is None:
        args.demo_tasks = QUICK_DEMO_TASKS if args.quick else IMITATION["demo_tasks"]
    if args.out is None and args.seeds:
        args.out = ROOT / "runs" / "seeds"
    if args.out is None:
        args.out = ROOT / "runs" / ("quick" if args.quick else f"ppo-seed{args.seed}")
    if args.report_dir is None:
        args.report_dir = ROOT / "results" if args.publish else args.out / "report"
    if args.eval_freq is None:
        args.eval_freq = max(args.timesteps // 20, 512)
    for name in ("timesteps", "n_envs", "n_max", "eval_freq", "checkpoint_freq", "threads",
                 "workers", "demo_tasks"):  # fmt: skip
        if getattr(args, name) < 1:
            p.error(f"--{name.replace('_', '-')} must be >= 1, got {getattr(args, name)}")
    if args.bc_epochs < 0:
        p.error(f"--bc-epochs must be >= 0, got {args.bc_epochs}")
    for name in ("env_kwargs", "hyperparameters"):
        if not isinstance(getattr(args, name), dict):
            p.error(f"--{name.replace('_', '-')} must be a JSON object")
    unknown = sorted(set(args.hyperparameters) - set(HYPERPARAMETERS))
    if unknown:
        p.error(f"--hyperparameters: unknown keys {unknown}; known: {sorted(HYPERPARAMETERS)}")
    if {"tasks", "n_max"} & set(args.env_kwargs):
        p.error("--env-kwargs: give tasks and n_max with --task-source and --n-max")
    if args.resume is not None and not args.resume.is_file():
        p.error(f"--resume: no model file {args.resume}")
    if args.seeds and args.publish:
        p.error("--publish installs one run: train the seeds, then publish the chosen one")
    if args.seed_workers is not None and args.seed_workers < 1:
        p.error(f"--seed-workers must be >= 1, got {args.seed_workers}")
    runs = [Path(args.out) / f"seed-{s}" for s in args.seeds] if args.seeds else [args.out]
    try:  # before any work: never replace a run, the shipped model or a report unasked
        for out in runs:
            check_output_dir(out, RUN_FILES, args.force, "--out")
            if not args.no_report:
                report = out / "report" if args.seeds else args.report_dir
                check_output_dir(report, REPORT_FILES, args.force or args.publish,
                                 "--report-dir")  # fmt: skip
    except OutputError as exc:
        p.error(str(exc))
    return args


def versions() -> dict:
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


def train(args: argparse.Namespace) -> Path:
    """Train, save ``model.zip`` + ``config.json`` + ``evaluations.npz`` in ``args.out``."""
    import numpy as np
    import torch
    from sb3_contrib import MaskablePPO
    from sb3_contrib.common.maskable.callbacks import MaskableEvalCallback
    from stable_baselines3.common.callbacks import CallbackList, CheckpointCallback
    from stable_baselines3.common.vec_env import DummyVecEnv, SubprocVecEnv

    from modquad_gym.agents.ppo import make_env
    from modquad_gym.agents.suites import CyclingTasks, validation_tasks
    from modquad_gym.outputs import atomic_write, write_text

    t_start = time.perf_counter()
    torch.set_num_threads(args.threads)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    run_name = out.name
    log_dir = Path(args.tensorboard) / run_name / "train"  # checkpoints, evaluations
    log_dir.mkdir(parents=True, exist_ok=True)

    source = args.task_source
    env_kwargs = {"tasks": source, "n_max": args.n_max, **args.env_kwargs}
    vec_cls = SubprocVecEnv if args.vec_env == "subproc" else DummyVecEnv
    venv = vec_cls([lambda: make_env(**env_kwargs) for _ in range(args.n_envs)])
    venv.seed(args.seed)
    val_source = source if source in ("planted", "paper", "mixed") else "mixed"
    val = validation_tasks(args.n_eval, val_source)
    eval_env = DummyVecEnv(
        [
            lambda: make_env(
                tasks=CyclingTasks(val, name="validation"), n_max=args.n_max, **args.env_kwargs
            )
        ]
    )

    hyperparameters = {**HYPERPARAMETERS, **args.hyperparameters}
    hp = dict(hyperparameters)
    policy_kwargs = {"net_arch": hp.pop("net_arch")}
    if args.resume is not None:
        model = MaskablePPO.load(
            args.resume, env=venv, device="cpu", tensorboard_log=str(args.tensorboard)
        )
    else:
        model = MaskablePPO(
            "MultiInputPolicy",
            venv,
            policy_kwargs=policy_kwargs,
            seed=args.seed,
            device="cpu",
            verbose=0,
            tensorboard_log=str(args.tensorboard),
            **hp,
        )
    per_env = lambda steps: max(steps // args.n_envs, 1)  # noqa: E731
    for stale in ("best_model.zip", "evaluations.npz"):  # from an earlier run into this folder
        (log_dir / stale).unlink(missing_ok=True)
    eval_cb = MaskableEvalCallback(eval_env, n_eval_episodes=len(val),
                                   eval_freq=per_env(args.eval_freq), log_path=str(log_dir),
                                   best_model_save_path=str(log_dir), deterministic=True,
                                   verbose=0)  # fmt: skip
    callbacks = CallbackList([
        eval_cb,
        CheckpointCallback(per_env(args.checkpoint_freq), str(log_dir / "checkpoints"),
                           name_prefix="ppo"),
    ])  # fmt: skip
    imitation = None
    if args.resume is None and args.bc_epochs > 0:
        imitation = pretrain(model, args, env_kwargs, Path(args.tensorboard) / run_name / "bc")
        evaluate_start(eval_cb, model, eval_env, len(val), log_dir)
    t0 = time.perf_counter()
    model.learn(
        total_timesteps=args.timesteps,
        callback=callbacks,
        tb_log_name=run_name,
        progress_bar=not args.no_progress,
        reset_num_timesteps=args.resume is None,
    )
    wall = time.perf_counter() - t0
    model.save(log_dir / "final_model.zip")
    if eval_cb.evaluations_timesteps:  # also when only the step-0 evaluation ran
        np.savez(log_dir / "evaluations.npz", timesteps=eval_cb.evaluations_timesteps,
                 results=eval_cb.evaluations_results, ep_lengths=eval_cb.evaluations_length,
                 successes=eval_cb.evaluations_successes)  # fmt: skip

    # keep the model with the best validation return (the last one if no evaluation ran)
    best = log_dir / "best_model.zip"
    chosen = best if best.is_file() else log_dir / "final_model.zip"
    atomic_write(out / "model.zip", lambda tmp: shutil.copyfile(chosen, tmp))
    evals = log_dir / "evaluations.npz"
    best_step = None
    if evals.is_file():
        atomic_write(out / "evaluations.npz", lambda tmp: shutil.copyfile(evals, tmp))
        data = np.load(evals)
        best_step = int(data["timesteps"][int(np.argmax(data["results"].mean(axis=1)))])
    config = {
        "env_id": "ModQuadAssembly-v0",
        "env_kwargs": env_kwargs,
        "algorithm": "MaskablePPO",
        "policy": "MultiInputPolicy",
        "hyperparameters": hyperparameters,
        "seed": args.seed,
        "n_envs": args.n_envs,
        "vec_env": args.vec_env,
        "timesteps": int(model.num_timesteps),
        "timesteps_requested": args.timesteps,
        "resumed_from": str(args.resume) if args.resume else None,
        "kept_model": "best validation return" if chosen == best else "final",
        "kept_model_timesteps": best_step if chosen == best else int(model.num_timesteps),
        "imitation": imitation,
        "validation": {"n_tasks": len(val), "source": val_source,
                       "seeds": "modquad_gym.agents.suites.VALIDATION_SEED0 + i"},
        "wall_seconds": round(time.perf_counter() - t_start, 1),
        "ppo_seconds": round(wall, 1),
        "steps_per_second": round(args.timesteps / wall, 1),
        "torch_threads": args.threads,
        "command": " ".join([Path(sys.argv[0]).name, *sys.argv[1:]]),
        "versions": versions(),
    }  # fmt: skip
    write_text(out / "config.json", json.dumps(config, indent=2) + "\n")
    venv.close()
    eval_env.close()
    print(f"trained {model.num_timesteps} steps in {wall:.0f} s; model: {out / 'model.zip'}")
    return out / "model.zip"


def pretrain(model, args: argparse.Namespace, env_kwargs: dict, log_dir: Path) -> dict:
    """Expert demonstrations, then behaviour cloning of ``model``'s policy (TensorBoard scalars
    ``bc/loss`` and ``bc/greedy_good`` per epoch in ``log_dir``). Returns what the config
    records about it."""
    import numpy as np
    from torch.utils.tensorboard import SummaryWriter

    from modquad_gym.agents.imitation import clone, collect_parallel
    from modquad_gym.tasks import make_generator

    t0 = time.perf_counter()
    generator = make_generator(env_kwargs["tasks"])
    rng = np.random.default_rng([args.seed, 1])  # never a validation or held-out seed
    tasks = [generator(rng) for _ in range(args.demo_tasks)]
    demos = collect_parallel(tasks, env_kwargs, args.n_max, seed=args.seed,
                             workers=args.workers, progress=not args.no_progress)  # fmt: skip
    collect_s = time.perf_counter() - t0
    writer = SummaryWriter(str(log_dir))

    def log(epoch: int, stats: dict) -> None:
        for key, value in stats.items():
            writer.add_scalar(f"bc/{key}", value, epoch)

    t1 = time.perf_counter()
    history = clone(model, demos, epochs=args.bc_epochs, batch_size=IMITATION["bc_batch_size"],
                    learning_rate=IMITATION["bc_learning_rate"], seed=args.seed,
                    progress=not args.no_progress, log=log)  # fmt: skip
    writer.close()
    return {
        "demo_tasks": args.demo_tasks,
        "expert_episodes": demos.n_tasks,
        "states": len(demos),
        "epochs": args.bc_epochs,
        "batch_size": IMITATION["bc_batch_size"],
        "learning_rate": IMITATION["bc_learning_rate"],
        "task_seed": f"default_rng([{args.seed}, 1])",
        "collect_seconds": round(collect_s, 1),
        "clone_seconds": round(time.perf_counter() - t1, 1),
        "final_loss": round(history[-1]["loss"], 4),
        "final_greedy_good": round(history[-1]["greedy_good"], 4),
    }


def evaluate_start(eval_cb, model, eval_env, n_episodes: int, log_dir: Path) -> None:
    """Evaluate the cloned policy before PPO (step 0 of the learning curve) and make it the
    best model so far, so fine-tuning is kept only if it beats cloning on validation."""
    import numpy as np
    from sb3_contrib.common.maskable.evaluation import evaluate_policy

    successes: list[bool] = []

    def on_step(locals_: dict, _globals: dict) -> None:
        if locals_["done"]:
            successes.append(bool(locals_["info"].get("is_success", False)))

    rewards, lengths = evaluate_policy(model, eval_env, n_eval_episodes=n_episodes,
                                       deterministic=True, return_episode_rewards=True,
                                       callback=on_step)  # fmt: skip
    eval_cb.evaluations_timesteps.append(0)
    eval_cb.evaluations_results.append(list(rewards))
    eval_cb.evaluations_length.append(list(lengths))
    eval_cb.evaluations_successes.append(successes)
    eval_cb.best_mean_reward = float(np.mean(rewards))
    model.save(log_dir / "best_model.zip")


def publish(run: Path) -> Path:
    """Install the run's model, config and learning curve as the package's default model."""
    from modquad_gym.outputs import atomic_write

    target = DEFAULT_MODEL.parent
    target.mkdir(parents=True, exist_ok=True)
    for name in RUN_FILES:
        if (run / name).is_file():
            atomic_write(target / name, lambda tmp, n=name: shutil.copyfile(run / n, tmp))
    print(f"published {run} as the default model {DEFAULT_MODEL}")
    return DEFAULT_MODEL


def train_seeds(args: argparse.Namespace, argv: list[str]) -> int:
    """One run of this script per seed of ``--seeds``, as parallel Ray tasks, each into
    ``<out>/seed-S`` (the other options as given). Returns 0 when every run finished."""
    import os

    from modquad_gym.distributed import Engine, Failed

    seeds = list(dict.fromkeys(args.seeds))
    runs = [_seed_argv(argv, seed, Path(args.out) / f"seed-{seed}") for seed in seeds]
    local = min(len(runs), os.cpu_count() or 1)
    with Engine(args.seed_workers, local_default=local) as engine:
        results = engine.map(_train_run, runs, labels=[f"seed {s}" for s in seeds], catch=True,
                             progress=not args.no_progress, desc="training seeds")  # fmt: skip
    failed = [r for r in results if isinstance(r, Failed)]
    for seed, result in zip(seeds, results):
        print(f"seed {seed}: {result.error if isinstance(result, Failed) else result}")
    return 1 if failed else 0


def _seed_argv(argv: list[str], seed: int, out: Path) -> list[str]:
    """``argv`` without --seeds/--seed-workers/--seed/--out, for one run of ``seed`` in ``out``."""
    drop = {"--seeds": True, "--seed-workers": False, "--seed": False, "--out": False}
    kept, skip, many = [], 0, False
    for token in argv:
        name = token.split("=", 1)[0]
        if name in drop:
            many, skip = drop[name], 0 if "=" in token else 1
            continue
        if skip or (many and token.lstrip("-").isdigit()):
            skip = 0
            continue
        many = False
        kept.append(token)
    return [*kept, "--seed", str(seed), "--out", str(out), "--workers", "1",
            "--report-dir", str(out / "report"), "--no-progress"]  # fmt: skip


def _train_run(argv: list[str]) -> str:
    """One training run (in a Ray worker): the folder it wrote."""
    sys.argv = ["train.py", *argv]  # what its config.json records as the command
    if main(argv) != 0:
        raise RuntimeError(f"train.py {' '.join(argv)} failed")
    return argv[argv.index("--out") + 1]


def main(argv: list[str] | None = None) -> int:
    args = parse_args(argv)
    if args.seeds:
        return train_seeds(args, list(sys.argv[1:] if argv is None else argv))
    t0 = time.perf_counter()
    model_path = train(args)
    if args.publish:
        model_path = publish(args.out)
    if not args.no_report:
        from modquad_gym.agents import benchmark

        bench_args = ["--model", str(model_path), "--out", str(args.report_dir),
                      "--train-dir", str(model_path.parent), "--force"]  # fmt: skip
        if args.quick:
            bench_args += ["--limit", "3", "--samples", "2"]
        benchmark.main(bench_args)
    print(f"total {time.perf_counter() - t0:.0f} s")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
