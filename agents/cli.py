"""The command line of ``train.py``: options, the run folder, training, publishing, the report.

See ``train.py --help`` and the module docstring of ``train.py`` for the options.
"""

from __future__ import annotations

import argparse
import time
from contextlib import ExitStack
from dataclasses import MISSING, fields
from pathlib import Path

from agents.checks import check_training_seed, check_used, unused_fields
from agents.config import TrainConfig
from agents.publishing import check_publishable, publish, refuse_grid_model, run_tier
from agents.run_folders import cleared, held_folders, kept, record, undo_unwritten
from agents.seeds import SEEDS_DROP, seed_out
from agents.training import check_start, report, train
from modquad_gym.cli.given import typed_options
from modquad_gym.core.options import (
    OneLineParser,
    int_option,
    nonempty_option,
    path_option,
    seed_option,
)
from modquad_gym.core.outputs import OutputError, check_output_dir, claim_output_dir
from modquad_gym.policy.models import UNTRUSTED, check_trusted
from modquad_gym.scoring.options import REPORT_FILES
from modquad_gym.scoring.tiers import TIERS
from modquad_gym.tasks.files import parse_json

ROOT = Path(__file__).resolve().parents[1]
INTEGER = int_option(-(2**63), 2**63)
"""Integer options parse strictly (no ``1_000``); their ranges are checked with the recipe
(:mod:`agents.checks`)."""
QUICK_TIMESTEPS = 4_096
QUICK_DEMO_TASKS = 40


def recipe(name: str) -> str:
    """The tiers whose recipe sets ``name``, for the help text."""
    tiers = [f"{t.recipe[name]} on {t.name}" for t in TIERS.values() if name in t.recipe]
    return ", ".join(tiers) or "no tier changes it"


QUICK = {"timesteps": QUICK_TIMESTEPS, "demo_tasks": QUICK_DEMO_TASKS}
"""What ``--quick`` changes (a field left None takes it)."""
CLI_DEFAULTS = {"tensorboard": ROOT / "runs"}
"""Defaults the command line gives where the config's own is relative to the working folder."""


def add_config_options(p: argparse.ArgumentParser) -> None:
    """One option per :class:`TrainConfig` field, derived from the field: ``--name`` (its
    metadata's help, group and choices; its type from its annotation; its default)."""
    groups = {name: p.add_argument_group(name) for name in ("run", "recipe", "imitation")}
    for f in fields(TrainConfig):
        meta = dict(f.metadata)
        group, text = groups[meta.pop("group")], meta.pop("help")
        meta.pop("limits", None)  # checked with the config
        text = text.replace("{recipe}", recipe(f.name))
        if f.name in QUICK:
            text += f"; {QUICK[f.name]} with --quick"
        if f.type == "bool":  # on by default: the option turns it off
            group.add_argument(f"--no-{f.name}", dest=f.name, action="store_false", help=text)
            continue
        default = CLI_DEFAULTS.get(
            f.name, f.default_factory() if f.default is MISSING else f.default
        )
        kind = meta.pop("type", None) or OPTION_TYPES[f.type.split(" |")[0]]
        if default is not None and not isinstance(default, dict):
            text += " (default %(default)s)"
        group.add_argument(f"--{f.name.replace('_', '-')}", type=kind, default=default, help=text,
                           **meta)  # fmt: skip


def json_object(text: str) -> dict:
    """A JSON object option (``--env-kwargs``, ``--hyperparameters``): valid JSON, an object,
    no key twice (``json`` would keep the last silently, as task files refuse)."""
    try:
        value = parse_json(text, "")
    except ValueError as exc:
        raise argparse.ArgumentTypeError(str(exc).removeprefix(": ")) from None
    if not isinstance(value, dict):
        shown = text.strip() if len(text.strip()) <= 40 else text.strip()[:37] + "..."
        raise argparse.ArgumentTypeError(f"must be a JSON object {{...}}, got {shown}")
    return value


OPTION_TYPES = {"int": INTEGER, "str": nonempty_option, "Path": path_option, "dict": json_object}
"""The option type of each field type."""


def add_run_options(p: argparse.ArgumentParser) -> None:
    """What happens around one training run: seeds, publishing, the report."""
    g = p.add_argument_group("runs and reports")
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
        type=path_option,
        default=None,
        metavar="RUN",
        help="install the model of an earlier run folder (e.g. one seed of --seeds) "
        "as its tier's shipped model and write its report, without training",
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
    g.add_argument(
        "--trust-model",
        action="store_true",
        help=f"with --resume: continue a model .zip that is not shipped, which unpickles it "
        f"({UNTRUSTED}): only for a file you trust",
    )
    g.add_argument("--quick", action="store_true", help="a short smoke run (a few thousand steps)")
    g.add_argument("--no-report", action="store_true", help="skip the benchmark report")
    g.add_argument(
        "--report-dir",
        type=path_option,
        default=None,
        help="where the report goes (default <out>/report, results with --publish)",
    )


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    p = OneLineParser(
        prog="python train.py",
        description="Train MaskablePPO (behaviour cloning on certified expert episodes, then "
        "PPO) on a benchmark tier, save the model with its config, then write its benchmark "
        "report. With --seeds, one run per seed on Ray. An option the run would not use "
        "(--critic-warmup with --bc-epochs 0, --group-size without --advantage group, ...) is "
        "refused, naming the option that drops it.",
    )
    add_config_options(p)
    add_run_options(p)
    args = p.parse_args(argv)
    typed = typed_options(p, argv)  # the options the user typed (by destination), in order:
    given = {a.dest: a.option_strings[0] for a in p._actions if a.dest in typed}
    try:
        refuse_ignored(args, given)
        complete(args, given)
    except (OutputError, ValueError) as exc:
        p.error(str(exc))
    return args


PUBLISH_RUN_OPTIONS = ("publish_run", "publish", "tier", "force", "no_report", "report_dir",
                       "progress")  # fmt: skip
"""What ``--publish-run`` honours (it trains nothing: every other option would be dropped)."""


def refuse_ignored(args: argparse.Namespace, given: dict[str, str]) -> None:
    """A ValueError naming an option the user typed (``given``: destination -> option) that
    this command would drop: a training option with ``--publish-run``, ``--seed``,
    ``--report-dir`` or ``--workers`` with ``--seeds`` (:data:`~agents.seeds.SEEDS_DROP`),
    ``--seed-workers`` without ``--seeds``, ``--report-dir`` with ``--no-report``, a recipe
    option the run would not use (:func:`~agents.checks.check_used`: ``--critic-warmup`` with
    ``--bc-epochs 0``, ``--group-size`` without ``--advantage group``, ...)."""
    if args.publish_run is not None:
        dropped = [flag for dest, flag in given.items() if dest not in PUBLISH_RUN_OPTIONS]
        if dropped:
            raise ValueError(
                f"{', '.join(dropped)}: --publish-run trains nothing (it installs the run's "
                "model and writes its report); with it give only --tier, --force, --no-report, "
                "--report-dir, --no-progress"
            )
    if args.seeds:
        for dest, why in SEEDS_DROP.items():
            if dest in given:
                raise ValueError(f"{given[dest]} with --seeds: {why}")
    elif "seed_workers" in given:
        raise ValueError("--seed-workers: only with --seeds (the runs it trains at a time)")
    if "report_dir" in given and args.no_report:
        raise ValueError("--report-dir with --no-report: no report is written")
    if "trust_model" in given and args.resume is None:
        raise ValueError("--trust-model: only with --resume (the one option that unpickles a "
                         "model file; --init-from reads its weights alone)")  # fmt: skip
    if args.publish_run is None:  # a recipe option the run would not use (typed: any value)
        check_used(args, [f.name for f in fields(TrainConfig) if f.name in given])


def complete(args: argparse.Namespace, given: dict[str, str] | None = None) -> None:
    """Fill the defaults that depend on other options and build ``args.config`` (the recipe
    every seed runs; None with ``--publish-run``); ValueError names a wrong option. Checks every
    output folder before any work: never replace a run, the model or a report unasked (the
    tier's own report that a publish rewrites aside; one in a ``--report-dir`` the user
    typed, one of ``given``, needs ``--force``)."""
    given = given or {}
    for name, value in QUICK.items():  # not where the run would not use it (no cloning)
        if args.quick and getattr(args, name) is None and name not in unused_fields(args):
            setattr(args, name, value)
    if args.seed_workers is not None and args.seed_workers < 1:
        raise ValueError(f"--seed-workers must be >= 1, got {args.seed_workers}")
    if args.seeds and len(set(args.seeds)) != len(args.seeds):
        raise ValueError(f"--seeds: a seed is given twice in {args.seeds}")
    if args.seeds and (args.publish or args.publish_run):
        raise ValueError("--publish installs one run: train the seeds, then --publish-run one")
    if args.publish_run is not None:
        config = args.publish_run / "config.json"
        missing = [n for n in ("model.zip", "config.json") if not (args.publish_run / n).is_file()]
        if missing:
            raise ValueError(f"--publish-run: no {' and no '.join(missing)} in {args.publish_run}")
        tier = run_tier(config)
        if "tier" in given and args.tier != tier:
            raise ValueError(
                f"--tier {args.tier}: the run {args.publish_run} was trained on tier {tier} "
                "(its config.json); it is published as that tier's model"
            )
        args.tier = tier
        check_publishable(args.publish_run, args.tier)
        args.out = args.publish_run
    elif args.out is None:
        prefix = "ppo-" if args.tier == "current" else f"{args.tier}-"
        name = "seeds" if args.seeds else "quick" if args.quick else f"seed{args.seed}"
        args.out = ROOT / "runs" / (name if args.quick else prefix + name)
    publishing = args.publish or args.publish_run is not None
    if args.report_dir is None:
        args.report_dir = ROOT / TIERS[args.tier].results if publishing else args.out / "report"
    args.config = None
    if args.publish_run is None:
        args.config = TrainConfig(**{f.name: getattr(args, f.name) for f in fields(TrainConfig)})
        for seed in args.seeds or []:  # --seed is checked with the recipe (TrainConfig)
            check_training_seed(seed, args.config.n_envs, "--seeds")
        if args.publish and args.architecture == "mlp":
            refuse_grid_model(args.tier, "--publish")
        check_start(args.config)  # the environment, memory, a --resume or --init-from model
        if args.resume is not None:  # MaskablePPO.load: the whole file, its pickles too
            check_trusted(args.resume, args.trust_model, "--resume", "continuing training")
        check_output_dir(args.tensorboard, what="--tensorboard")
    runs = [seed_out(args.out, s) for s in args.seeds] if args.seeds else [args.out]
    for held in held_folders(args, run_folders(args)):  # run and log folders (run_folders.py)
        check_output_dir(held.folder, held.names, held.force, held.what)
    for out in runs:
        if not args.no_report:
            report = out / "report" if args.seeds else args.report_dir
            own = publishing and "report_dir" not in given  # the tier's report: the publish's
            check_output_dir(report, REPORT_FILES, args.force or own, "--report-dir")


def run_folders(args: argparse.Namespace) -> list[Path]:
    """The run folders this command trains into (none with ``--publish-run``, which reads
    one)."""
    if args.publish_run is not None:
        return []
    return [seed_out(args.out, s) for s in args.seeds] if args.seeds else [args.out]


def main(argv: list[str] | None = None) -> int:
    args = parse_args(argv)
    folders = held_folders(args, run_folders(args))  # each run's folder and its log folder
    with ExitStack() as stack:  # a second run into one of these folders is refused at once
        claims = [(stack.enter_context(claim_output_dir(h.folder, h.names, h.force, h.what,
                                                        keep=kept(args), clear=cleared(h))), h)
                  for h in folders]  # fmt: skip
        for claim, held in claims:  # recorded at once: an interrupted run's files are known too
            record(claim, held, walk=False)
        try:
            return run(args)
        except BaseException:  # stopped before any file: no record of files never written
            for claim, held in claims:
                undo_unwritten(claim, held)
            raise
        finally:  # what training wrote in its folders (checkpoints, logs): --force removes it
            for claim, held in claims:
                record(claim, held)


def run(args: argparse.Namespace) -> int:
    """Train (one run, or one per seed), publish, report, as the options say."""
    quick = args.quick
    if args.seeds:
        from agents.seeds import train_seeds

        return train_seeds(args.config, args.seeds, args.seed_workers, not args.no_report, quick)
    t0 = time.perf_counter()
    model_path = args.out / "model.zip" if args.publish_run else train(args.config)
    if args.publish or args.publish_run:
        model_path = publish(args.out, TIERS[args.tier].model)
    if not args.no_report:
        report(model_path, args.report_dir, args.tier, quick, args.progress)
    print(f"total {time.perf_counter() - t0:.0f} s")
    return 0
