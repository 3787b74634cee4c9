"""What ``python -m modquad_gym.scoring.seeds`` scores, checked before any work: the seed folders
(each with its model, trained for the tier), the learned methods and the task limit.

Each check raises one ValueError naming the folder, ``--methods`` or ``--limit`` and the
value, in :func:`~.seeds.score_runs` (Python) as on the command line.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

from modquad_gym.core.options import check_option, int_option
from modquad_gym.methods import method_of
from modquad_gym.policy.models import read_config
from modquad_gym.scoring.agents import load_solvers
from modquad_gym.scoring.options import method_label
from modquad_gym.scoring.tiers import Tier

MIN_SEEDS = 2
"""The fewest seeds a report over seeds takes: one seed has no interval (:mod:`.stats`)."""


def check_seed_count(runs: dict[str, Path]) -> None:
    """ValueError naming RUNS when ``runs`` holds fewer than :data:`MIN_SEEDS` seeds."""
    if len(runs) < MIN_SEEDS:
        held = ", ".join(str(p.parent) for p in runs.values()) or "none"
        count = f"{len(runs)} seed{'' if len(runs) == 1 else 's'}"
        raise ValueError(
            f"RUNS: {count} ({held}); a result over seeds needs at least {MIN_SEEDS} "
            "(train more: python train.py --seeds 0 1 2 3 4)"
        )


def find_runs(folders: list[Path]) -> dict[str, Path]:
    """``seed-S/model.zip`` of every folder by seed label, in seed order; ValueError if none,
    if a seed folder holds no model.zip, if two folders hold the same seed or if there are
    fewer than :data:`MIN_SEEDS` seeds."""
    runs: dict[str, Path] = {}
    for folder in folders:
        for run in sorted(p for p in Path(folder).glob("seed-*") if p.is_dir()):
            path = run / "model.zip"
            if not path.is_file():
                raise ValueError(f"RUNS: {run} holds no model.zip (a run that did not finish?)")
            label = run.name.removeprefix("seed-")
            if label in runs:
                raise ValueError(f"RUNS: seed {label} in both {runs[label].parent} and {run}")
            runs[label] = path
    if not runs:
        names = ", ".join(str(f) for f in folders)
        raise ValueError(f"RUNS: no seed-*/model.zip in {names} (train: python train.py --seeds)")
    check_seed_count(runs)
    return dict(sorted(runs.items(), key=lambda kv: (len(kv[0]), kv[0])))


def learned_methods(methods: Sequence[str] | None, tier: Tier) -> list[str]:
    """``methods`` (None: the tier's learned ones) as the scorer labels them, each once
    (``ppo-k0`` is ``ppo``, :func:`~.options.method_label`); ValueError naming ``--methods``
    for a string, an unknown or malformed name, or a method that is not learned."""
    if methods is None:
        return list(tier.learned)
    if isinstance(methods, str) or not all(isinstance(m, str) for m in methods):
        raise ValueError(f"--methods: a list of learned method names, got {methods!r}")
    for m in methods:
        try:
            entry = method_of(m)[0]
        except ValueError as exc:
            raise ValueError(f"--methods: {exc}") from None
        if entry.extra != "train":
            raise ValueError(
                f"--methods: learned methods only (ppo, ppo-kN, ppo-guided), got {list(methods)}"
            )
    return list(dict.fromkeys(method_label(m) for m in methods))


LIMIT = int_option(1)
"""The type of ``--limit``: the first N >= 1 tasks of each suite."""


def check_limit(limit: int | None) -> None:
    """``limit`` (None: every task) as ``--limit`` takes it (ValueError in its words)."""
    check_option("--limit", limit, LIMIT)


def check_runs(runs: dict[str, Path], methods: list[str], tier: Tier) -> None:
    """Every run was trained for ``tier`` (or the tier whose model it uses), as its config.json
    records (a run without one, or without a tier, is taken as it is), and its model makes every
    method's solver on the tier; else a ValueError naming the seed folder (or RUNS: fewer than
    :data:`MIN_SEEDS` runs)."""
    check_seed_count(runs)
    wanted = {tier.name, tier.model_tier or tier.name}
    for path in runs.values():
        folder = path.parent
        try:
            trained = read_config(path).get("tier")
            if trained is not None and trained not in wanted:
                raise ValueError(
                    f"trained for tier {trained!r} (its config.json), not for --tier {tier.name}"
                )
            load_solvers(methods, tier.n_max, path, tier)
        except ValueError as exc:
            reason = str(exc).removeprefix(f"--model {path}: ")
            raise ValueError(f"RUNS: {folder}: {reason}") from None
