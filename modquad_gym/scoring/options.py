"""The options of ``modquad score`` (:mod:`.agents`), apart from the scoring itself so that the
command line builds its parser without importing the scorer, its report and its figures."""

from __future__ import annotations

import argparse
from pathlib import Path

from modquad_gym.core.options import (
    check_option,
    int_option,
    nonempty_option,
    path_option,
    seed_option,
)
from modquad_gym.methods import REGISTRY
from modquad_gym.policy.models import MAX_SAMPLES
from modquad_gym.scoring.tiers import TIERS
from modquad_gym.search import SEARCHES

SEARCH_METHODS = tuple(SEARCHES)
DEFAULT_METHODS = (*SEARCH_METHODS, "ppo", "ppo-k2", "ppo-k8")

SEEDED = ", ".join(
    [*(n for n, m in REGISTRY.items() if "seed" in m.options.names() and n != "ppo"),
     "ppo-kN (ppo's sampled rollouts; its deterministic passes draw nothing)",
     "an outside agent whose constructor takes seed"]
)  # fmt: skip
"""The methods ``--seed`` applies to (those of the registry that take ``seed``), in words."""

REPORT_FILES = (
    "benchmark.md",
    "benchmark.csv",
    "benchmark_bars.png",
    "learning_curve.png",
    "structures.png",
)
"""What the benchmark writes into ``--out``."""


OPTIONS = {
    "--suite": dict(type=path_option, action="append", default=None,
                    help="suite JSON (repeatable; default the held-out suites in "
                    "modquad_gym/data/suites)"),
    "--model": dict(type=path_option, default=None, help="PPO model .zip of the learned "
                    "methods (default: the tier's shipped model, modquad_gym/data/models/"
                    "ppo_default or ppo_<tier>), read without unpickling (see --trust-model); "
                    "refused when no learned method is scored"),
    "--trust-model": dict(action="store_true", help="let the learned methods load a --model "
                          "that only unpickling reads (a policy class or keywords the package "
                          "does not know): a model .zip holds pickled Python objects that run "
                          "code when loaded, so give it only for a file you trust"),
    "--train-dir": dict(type=path_option, default=None, help="training run folder with "
                        "config.json and evaluations.npz, for the report's learning curve and "
                        "model line (default: the model's folder); refused when no learned "
                        "method is scored"),
    "--tier": dict(type=nonempty_option, default=None, help="score on a benchmark tier's "
                   f"held-out suites and budget: {', '.join(TIERS)} (default: current, or the "
                   "--suite files)"),
    "--methods": dict(type=nonempty_option, nargs="+", default=None,
                      help="search names, ppo, ppo-kN, ppo-guided (settings as suffixes: "
                      "-bN budget, -wN branching, -nodive, e.g. ppo-guided-b256-w8), or "
                      "package.module:Name of an "
                      f"outside agent (default: {' '.join(DEFAULT_METHODS)}; on other tiers "
                      "the searches, and the tier's learned methods when it ships a model)"),
    "--solver": dict(type=nonempty_option, action="append", default=[], metavar="PKG.MOD:NAME",
                     help="score an outside agent (repeatable): a Solver instance or class, or a "
                     "function task -> structure, imported from PKG.MOD; it is told the tier's "
                     "n_max, and counted through the evaluator it is handed (docs: "
                     "benchmarks.md); without --methods it is scored beside the searches"),
    "--samples": dict(type=int_option(0, MAX_SAMPLES), default=None,
                      help="replace every ppo-kN of --methods (or of the default methods) by "
                      "ppo-k<samples> (0 drops them); refused when there is none to replace"),
    "--n-max": dict(type=int_option(1, 16), default=None,
                    help="module budget (default: the tier's)"),
    "--limit": dict(type=int_option(1), default=None, help="first N tasks of each suite only"),
    "--validation": dict(type=int_option(1, 10_000), default=None, metavar="N",
                         help="score on the tier's first N validation tasks (what training "
                         "selects on; optima certified here) instead of its held-out suites: "
                         "tune decoders and recipes here, never on the held-out suites"),
    "--no-progress": dict(action="store_true", help="no progress bars"),
    "--workers": dict(type=int_option(1, 256), default=1,
                      help="Ray tasks sharing the tasks (1: one process, so each solver's "
                      "seconds are timed alone; RAY_ADDRESS joins a cluster)"),
}  # fmt: skip
"""The options of ``modquad score`` besides ``--seed``, ``--out`` and ``--force``."""

COMMAND = "modquad score"
"""The command that scores agents (its usage, and the command line its report records)."""

DESCRIPTION = (
    "Score every solver (searches, learned methods, outside agents) on a tier's held-out suites "
    "against their certified optima and write benchmark.md, benchmark.csv and plots."
)


def method_label(name: str) -> str:
    """The label a report gives the method ``name``: ``ppo-kN`` with N written plainly, and
    ``ppo-k0`` (no sampled rollout) as ``ppo``, so one method is scored once under one name;
    other names as they are. ValueError for a malformed ``ppo-kN``
    (:func:`~modquad_gym.methods.method_of`)."""
    if not name.startswith("ppo-k"):
        return name
    from modquad_gym.methods import method_of

    samples = method_of(name)[1]["samples"]
    return f"ppo-k{samples}" if samples else "ppo"


def add_options(parser: argparse.ArgumentParser) -> None:
    """The options of ``modquad score``, added to ``parser``."""
    for flag, kwargs in OPTIONS.items():
        parser.add_argument(flag, **kwargs)
    parser.add_argument("--seed", type=seed_option, default=None,
                        help=f"solver seed of the methods that draw at random ({SEEDED}); "
                        "refused when none of them is scored (default 0)")  # fmt: skip
    parser.add_argument("--out", type=path_option, default=Path("results"), help="report folder")
    parser.add_argument(
        "--force", action="store_true", help="replace existing reports (default: refuse)"
    )


def score_options(**given: object) -> argparse.Namespace:
    """The options of ``modquad score`` as a caller gives them (the options' names with ``_``,
    e.g. ``train_dir``; paths as Paths), the command line's defaults for the rest, so that
    :func:`~.agents.score` is called as a function. An unknown name is a ValueError."""
    known = {flag[2:].replace("-", "_"): kwargs for flag, kwargs in OPTIONS.items()}
    values = {name: list(kw["default"]) if isinstance(kw.get("default"), list)
              else kw.get("default", kw.get("action") != "store_true" and None)
              for name, kw in known.items()}  # fmt: skip
    values.update(seed=None, out=Path("results"), force=False)
    unknown = sorted(set(given) - set(values))
    if unknown:
        raise ValueError(f"{COMMAND}: unknown options {unknown}; known: {sorted(values)}")
    kinds = {**known, "seed": {"type": seed_option}, "out": {"type": path_option}}
    for name, value in given.items():  # as the command line checks them, in its words
        kw = kinds.get(name, {})
        many = kw.get("nargs") == "+" or kw.get("action") == "append"
        check_option("--" + name.replace("_", "-"), value, kw.get("type"), many)
    return argparse.Namespace(**{**values, **given})


def command_line(**given: object) -> str:
    """The ``modquad score`` command line that gives these options (what a report records)."""
    parts = [COMMAND]
    for name, value in given.items():
        flag = "--" + name.replace("_", "-")
        if value is True:
            parts.append(flag)
        elif value is not None and value is not False:
            items = value if isinstance(value, (list, tuple)) else [value]
            parts += [flag, *map(str, items)]
    return " ".join(parts)


def check_train_dir(folder: Path) -> None:
    """``--train-dir``: a training run's folder (its ``config.json`` or ``evaluations.npz``),
    whose ``config.json`` and ``evaluations.npz`` (:func:`check_evaluations`) are read now, not
    by the report after the scoring."""
    if not folder.is_dir():
        what = "not a folder" if folder.exists() else "does not exist"
        raise ValueError(f"--train-dir {folder}: {what} (a training run's folder)")
    if not any((folder / name).is_file() for name in ("config.json", "evaluations.npz")):
        raise ValueError(
            f"--train-dir {folder}: no config.json or evaluations.npz in it (a training run's "
            "folder, as train.py writes it)"
        )
    from modquad_gym.policy.models import read_config

    read_config(folder / "model.zip")  # a config.json that is not one: now, not at the report
    check_evaluations(folder)


def check_evaluations(folder: Path) -> None:
    """A ValueError naming ``folder/evaluations.npz`` and the key when the learning curve the
    report draws from it cannot be read (:func:`~.fine_tuning.read_evaluations`); nothing when
    the folder has none (the report leaves the curve out)."""
    from modquad_gym.scoring.fine_tuning import read_evaluations

    evals = folder / "evaluations.npz"
    if evals.exists():
        read_evaluations(evals)
