"""Training several seeds: one run of a :class:`~agents.config.TrainConfig` per seed of
``--seeds``, as parallel Ray tasks, each into ``<out>/seed-S`` with its report.

``python -m modquad_gym.scoring.seeds`` then reports the runs over seeds.
"""

from __future__ import annotations

import dataclasses
import os
from pathlib import Path

from agents.checks import unused_fields
from agents.config import TrainConfig
from agents.training import report, train

SEEDS_DROP = {"seed": "each run takes its seed from --seeds",
              "report_dir": "each seed's report goes to <out>/seed-S/report",
              "workers": "each seed collects its demonstrations in one process (the seeds "
                         "run in parallel: --seed-workers)"}  # fmt: skip
"""What ``--seeds`` cannot honour, and why."""


def seed_out(out: Path, seed: int) -> Path:
    """The run folder of ``seed`` under the seeds' folder ``out``."""
    return Path(out) / f"seed-{seed}"


def seed_config(config: TrainConfig, seed: int) -> TrainConfig:
    """``config`` for one seed: its own run folder, one demonstration process (where it
    collects demonstrations), no progress; a ValueError for a ``workers`` asked for
    (:data:`SEEDS_DROP`)."""
    if "workers" in config.asked() and "workers" not in unused_fields(config):
        raise ValueError(f"--workers {config.workers} with --seeds: {SEEDS_DROP['workers']}")
    workers = config.workers if "workers" in unused_fields(config) else 1
    return dataclasses.replace(
        config, seed=seed, out=seed_out(config.out, seed), workers=workers, progress=False
    )


def train_seeds(
    config: TrainConfig,
    seeds: list[int],
    seed_workers: int | None = None,
    with_report: bool = True,
    quick: bool = False,
) -> int:
    """Train ``config`` once per seed, as parallel Ray tasks (``seed_workers`` at a time,
    default one per seed up to the local cores), each with its report in ``<run>/report``
    unless ``with_report`` is False. Returns 0 when every run finished."""
    from modquad_gym.core.distributed import Engine, Failed, ray_installed

    seeds = list(dict.fromkeys(seeds))
    runs = [(seed_config(config, seed), with_report, quick) for seed in seeds]
    if ray_installed():  # workers need not find agents/ on their path: its code travels
        from ray import cloudpickle

        import agents

        cloudpickle.register_pickle_by_value(agents)
    local = min(len(runs), os.cpu_count() or 1)
    with Engine(seed_workers, local_default=local, option="--seed-workers") as engine:
        results = engine.map(
            train_and_report,
            runs,
            labels=[f"seed {s}" for s in seeds],
            catch=True,
            progress=config.progress,
            desc="training seeds",
        )
    for seed, result in zip(seeds, results):
        print(f"seed {seed}: {result.error if isinstance(result, Failed) else result}")
    return 1 if any(isinstance(r, Failed) for r in results) else 0


def train_and_report(run: tuple[TrainConfig, bool, bool]) -> str:
    """One seed's run (in a Ray worker): train, then its report; the run folder."""
    config, with_report, quick = run
    model = train(config)
    if with_report:
        report(model, Path(config.out) / "report", config.tier, quick, progress=False)
    return str(config.out)
