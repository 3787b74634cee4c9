"""The command line of ``train.py``: options, the run folder, training, publishing, the report.

See ``train.py --help`` and the module docstring of ``train.py`` for the options.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

from agents.checks import check_environment, check_model, check_publishable
from agents.imitation import EXPERTS
from agents.training import (
    ARCHITECTURES,
    DEFAULT_TIMESTEPS,
    HYPERPARAMETERS,
    IMITATION,
    RUN_FILES,
    TrainConfig,
    publish,
    train,
)
from modquad_gym.core.options import int_option, seed_option
from modquad_gym.core.outputs import OutputError, check_output_dir
from modquad_gym.scoring.agents import REPORT_FILES
from modquad_gym.scoring.tiers import TIERS

ROOT = Path(__file__).resolve().parents[1]
INTEGER = int_option(-(2**63), 2**63)
"""Integer options parse strictly (no ``1_000``); their ranges are checked with the recipe
(:mod:`agents.checks`)."""
QUICK_TIMESTEPS = 4_096
QUICK_DEMO_TASKS = 40
POSITIVE = (
    "timesteps",
    "n_envs",
    "n_max",
    "eval_freq",
    "checkpoint_freq",
    "threads",
    "workers",
    "demo_tasks",
    "seed_workers",
    "dagger_tasks",
)
"""Integer options that must be >= 1 when given."""


def recipe(name: str) -> str:
    """The tiers whose recipe sets ``name``, for the help text."""
    tiers = [f"{t.recipe[name]} on {t.name}" for t in TIERS.values() if name in t.recipe]
    return ", ".join(tiers) or "no tier changes it"


def add_run_options(p: argparse.ArgumentParser) -> None:
    """Where a run goes and what happens around training."""
    g = p.add_argument_group("run")
    g.add_argument(
        "--tier",
        choices=tuple(TIERS),
        default="current",
        help="benchmark tier: its environment, task source, n_max and held-out "
        "suites (default %(default)s)",
    )
    g.add_argument(
        "--seed",
        type=seed_option,
        default=0,
        help="training seed; env i uses seed + i (default %(default)s)",
    )
    g.add_argument(
        "--out",
        type=Path,
        default=None,
        help="run folder for model.zip, config.json, evaluations.npz and report/ "
        "(default runs/ppo-seed<seed>; runs/<tier>-seed<seed> on other tiers; "
        "runs/ppo-seeds with --seeds; runs/quick with --quick)",
    )
    g.add_argument(
        "--force", action="store_true", help="replace the files of an existing run folder"
    )
    g.add_argument(
        "--publish",
        action="store_true",
        help="also install the model as the tier's shipped model (modquad_gym/data/"
        "models/ppo_default, ppo_<tier> on other tiers) and write the report into "
        "results/ (results/tier_<tier>)",
    )
    g.add_argument(
        "--publish-run",
        type=Path,
        default=None,
        metavar="RUN",
        help="install the model of an earlier run folder (e.g. one seed of --seeds) "
        "as its tier's shipped model and write its report, without training",
    )
    g.add_argument(
        "--resume",
        type=Path,
        default=None,
        help="continue PPO from this model .zip (no behaviour cloning)",
    )
    g.add_argument(
        "--seeds",
        type=seed_option,
        nargs="+",
        default=None,
        metavar="SEED",
        help="train one run per seed, as parallel Ray tasks, each into "
        "<out>/seed-SEED (default <out>: runs/ppo-seeds, runs/<tier>-seeds)",
    )
    g.add_argument(
        "--seed-workers",
        type=INTEGER,
        default=None,
        help="with --seeds: runs at a time (default: one per seed, at most the local "
        "cores; every CPU of the cluster with RAY_ADDRESS)",
    )
    g.add_argument("--quick", action="store_true", help="a short smoke run (a few thousand steps)")
    g.add_argument("--no-report", action="store_true", help="skip the benchmark report")
    g.add_argument(
        "--report-dir",
        type=Path,
        default=None,
        help="where the report goes (default <out>/report, results with --publish)",
    )
    g.add_argument(
        "--tensorboard",
        type=Path,
        default=ROOT / "runs",
        help="TensorBoard logs and checkpoints (default runs/, gitignored)",
    )
    g.add_argument("--no-progress", action="store_true", help="no progress bar")


def add_recipe_options(p: argparse.ArgumentParser) -> None:
    """The recipe: environment, PPO, evaluation."""
    g = p.add_argument_group("recipe")
    g.add_argument(
        "--timesteps",
        type=INTEGER,
        default=None,
        help=f"total PPO environment steps (default {DEFAULT_TIMESTEPS}, the tier's recipe may "
        f"change it: {recipe('timesteps')}; {QUICK_TIMESTEPS} with --quick)",
    )
    g.add_argument(
        "--n-envs", type=INTEGER, default=2, help="parallel environments (default %(default)s)"
    )
    g.add_argument(
        "--vec-env",
        choices=("dummy", "subproc"),
        default="dummy",
        help="vectorised env class (default %(default)s: faster on 2 cores)",
    )
    g.add_argument(
        "--task-source",
        default=None,
        help="a task generator name (planted, paper, mixed, planted-large, ...) or a "
        "task/suite file (default: the tier's: mixed on current)",
    )
    g.add_argument(
        "--n-max",
        type=INTEGER,
        default=None,
        help="largest structure in modules (default: the tier's, 7 on current)",
    )
    g.add_argument(
        "--eval-freq",
        type=INTEGER,
        default=None,
        help="evaluate every this many total steps (default timesteps / 20)",
    )
    g.add_argument(
        "--n-eval", type=INTEGER, default=40, help="validation tasks (default %(default)s)"
    )
    g.add_argument(
        "--checkpoint-freq",
        type=INTEGER,
        default=50_000,
        help="checkpoint every this many total steps, under --tensorboard (default %(default)s)",
    )
    g.add_argument("--threads", type=INTEGER, default=1, help="torch threads (default %(default)s)")
    g.add_argument(
        "--architecture",
        choices=ARCHITECTURES,
        default="candidates",
        help="policy network: candidates (one score per candidate docking, shared weights: "
        "acts at any n_max and palette; the env's lookahead rows) or mlp (SB3's "
        "MultiInputPolicy, one grid size) (default %(default)s)",
    )
    g.add_argument(
        "--env-kwargs",
        type=json.loads,
        default={},
        help='extra env keywords as JSON, e.g. \'{"reward_weights": {"w_module": 0.2}}\'',
    )
    g.add_argument(
        "--hyperparameters",
        type=json.loads,
        default={},
        help="MaskablePPO hyperparameters overriding the recipe, as JSON, e.g. "
        f"'{{\"ent_coef\": 0.02}}'; known: {', '.join(HYPERPARAMETERS)}",
    )


def add_imitation_options(p: argparse.ArgumentParser) -> None:
    """The expert demonstrations and behaviour cloning before PPO."""
    g = p.add_argument_group("imitation")
    g.add_argument(
        "--demo-tasks",
        type=INTEGER,
        default=None,
        help="training tasks with an expert episode each for behaviour cloning (default "
        f"{IMITATION['demo_tasks']}; {recipe('demo_tasks')}; {QUICK_DEMO_TASKS} with --quick)",
    )
    g.add_argument(
        "--expert",
        choices=EXPERTS,
        default=None,
        help="what the expert docks towards: all optimal structures, or one, the first the "
        f"certified search finds (default all; {recipe('expert')})",
    )
    g.add_argument(
        "--bc-epochs",
        type=INTEGER,
        default=IMITATION["bc_epochs"],
        help="behaviour-cloning epochs before PPO; 0: PPO alone from scratch (default %(default)s)",
    )
    g.add_argument(
        "--workers",
        type=INTEGER,
        default=2,
        help="processes that collect the expert demonstrations (default %(default)s)",
    )
    g.add_argument(
        "--dagger-rounds",
        type=int,
        default=IMITATION["dagger_rounds"],
        help="rounds of the expert in the loop after cloning: the learner's own episodes on "
        "fresh tasks, every state labelled by the certified search, cloned again; 0: none "
        "(default %(default)s)",
    )
    g.add_argument(
        "--dagger-tasks",
        type=int,
        default=None,
        help="fresh training tasks per DAgger round (default a tenth of --demo-tasks)",
    )


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    p = argparse.ArgumentParser(
        prog="python train.py",
        description="Train MaskablePPO (behaviour cloning on certified expert episodes, then "
        "PPO) on a benchmark tier, save the model with its config, then write its benchmark "
        "report. With --seeds, one run per seed on Ray.",
    )
    add_run_options(p)
    add_recipe_options(p)
    add_imitation_options(p)
    args = p.parse_args(argv)
    try:
        complete(args)
    except (OutputError, ValueError) as exc:
        p.error(str(exc))
    return args


def complete(args: argparse.Namespace) -> None:
    """Fill the defaults that depend on other options; ValueError names a wrong one. Checks
    every output folder before any work: never replace a run, the model or a report unasked."""
    if args.quick and args.timesteps is None:
        args.timesteps = QUICK_TIMESTEPS
    if args.quick and args.demo_tasks is None:
        args.demo_tasks = QUICK_DEMO_TASKS
    for name in POSITIVE:
        if getattr(args, name) is not None and getattr(args, name) < 1:
            raise ValueError(f"--{name.replace('_', '-')} must be >= 1, got {getattr(args, name)}")
    for name in ("bc_epochs", "dagger_rounds"):
        if getattr(args, name) < 0:
            raise ValueError(f"--{name.replace('_', '-')} must be >= 0, got {getattr(args, name)}")
    for name in ("env_kwargs", "hyperparameters"):
        if not isinstance(getattr(args, name), dict):
            raise ValueError(f"--{name.replace('_', '-')} must be a JSON object")
    if args.seeds and len(set(args.seeds)) != len(args.seeds):
        raise ValueError(f"--seeds: a seed is given twice in {args.seeds}")
    if args.seeds and (args.publish or args.publish_run):
        raise ValueError("--publish installs one run: train the seeds, then --publish-run one")
    if args.publish_run is not None:
        config = args.publish_run / "config.json"
        if not (args.publish_run / "model.zip").is_file() or not config.is_file():
            raise ValueError(f"--publish-run: no model.zip and config.json in {args.publish_run}")
        args.tier = run_tier(config)
        check_publishable(args.publish_run, tier_env_kwargs(args.tier))
        args.out = args.publish_run
    elif args.out is None:
        prefix = "ppo-" if args.tier == "current" else f"{args.tier}-"
        name = "seeds" if args.seeds else "quick" if args.quick else f"seed{args.seed}"
        args.out = ROOT / "runs" / (name if args.quick else prefix + name)
    publishing = args.publish or args.publish_run is not None
    if args.report_dir is None:
        args.report_dir = ROOT / TIERS[args.tier].results if publishing else args.out / "report"
    if args.publish_run is None:  # every seed of --seeds runs this recipe
        config = config_of(args)
        check_environment(config)
        if args.resume is not None:
            check_model(args.resume, config.env_kwargs_full, "--resume")
        check_output_dir(args.tensorboard, what="--tensorboard")
    args.config = None if args.seeds or args.publish_run else config
    runs = [Path(args.out) / f"seed-{s}" for s in args.seeds] if args.seeds else [args.out]
    for out in runs:
        if args.publish_run is None:
            check_output_dir(out, RUN_FILES, args.force, "--out")
        if not args.no_report:
            report = out / "report" if args.seeds else args.report_dir
            check_output_dir(report, REPORT_FILES, args.force or publishing, "--report-dir")


def run_tier(config: Path) -> str:
    """The tier a run folder's ``config.json`` names (``--publish-run``)."""
    try:
        tier = json.loads(config.read_text()).get("tier", "current")
    except (OSError, ValueError, AttributeError) as exc:
        raise ValueError(f"--publish-run: {config} is not a run's config ({exc})") from None
    if tier not in TIERS:
        raise ValueError(f"--publish-run: {config} names an unknown tier {tier!r}")
    return tier


def tier_env_kwargs(tier: str) -> dict:
    """The environment a tier's shipped model plays (its recipe's training environment)."""
    return TrainConfig(out=Path("."), tier=tier).env_kwargs_full


def config_of(args: argparse.Namespace) -> TrainConfig:
    """The :class:`TrainConfig` of the parsed options."""
    return TrainConfig(
        out=args.out,
        tier=args.tier,
        seed=args.seed,
        timesteps=args.timesteps,
        n_envs=args.n_envs,
        vec_env=args.vec_env,
        task_source=args.task_source,
        n_max=args.n_max,
        demo_tasks=args.demo_tasks,
        bc_epochs=args.bc_epochs,
        expert=args.expert,
        architecture=args.architecture,
        dagger_rounds=args.dagger_rounds,
        dagger_tasks=args.dagger_tasks,
        workers=args.workers,
        resume=args.resume,
        eval_freq=args.eval_freq,
        n_eval=args.n_eval,
        checkpoint_freq=args.checkpoint_freq,
        tensorboard=args.tensorboard,
        threads=args.threads,
        progress=not args.no_progress,
        env_kwargs=args.env_kwargs,
        hyperparameters=args.hyperparameters,
    )


def shown(path: Path) -> str:
    """``path`` relative to the working folder when it lies inside it (as reports print it)."""
    path, here = Path(path).resolve(), Path.cwd().resolve()
    return str(path.relative_to(here)) if path.is_relative_to(here) else str(path)


def report(args: argparse.Namespace, model_path: Path) -> None:
    """The benchmark report of ``model_path`` on its tier's held-out suites."""
    from modquad_gym.scoring import agents as benchmark

    model, out = shown(model_path), shown(args.report_dir)
    bench_args = ["--model", model, "--out", out, "--tier", args.tier, "--force"]
    bench_args += ["--train-dir", shown(model_path.parent)]
    if args.quick:
        bench_args += ["--limit", "3", "--samples", "2"]
    if args.no_progress:
        bench_args.append("--no-progress")
    benchmark.main(bench_args)


def main(argv: list[str] | None = None) -> int:
    args = parse_args(argv)
    if args.seeds:
        from agents.seeds import train_seeds

        return train_seeds(args, list(sys.argv[1:] if argv is None else argv))
    t0 = time.perf_counter()
    model_path = args.out / "model.zip" if args.publish_run else train(args.config)
    if args.publish or args.publish_run:
        model_path = publish(args.out, TIERS[args.tier].model)
    if not args.no_report:
        report(args, model_path)
    print(f"total {time.perf_counter() - t0:.0f} s")
    return 0
