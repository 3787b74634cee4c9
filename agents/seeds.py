"""Training several seeds: one ``train.py`` run per seed of ``--seeds``, as parallel Ray tasks.

``python -m modquad_gym.scoring.seeds`` then reports the runs over seeds.
"""

from __future__ import annotations

import argparse
import subprocess
import sys
from pathlib import Path

TRAIN_SCRIPT = Path(__file__).resolve().parents[1] / "train.py"


def train_seeds(args: argparse.Namespace, argv: list[str]) -> int:
    """One run of this script per seed of ``--seeds``, as parallel Ray tasks, each into
    ``<out>/seed-S`` (the other options as given). Returns 0 when every run finished."""
    import os

    from modquad_gym.core.distributed import Engine, Failed

    seeds = list(dict.fromkeys(args.seeds))
    runs = [seed_argv(argv, seed, Path(args.out) / f"seed-{seed}") for seed in seeds]
    local = min(len(runs), os.cpu_count() or 1)
    with Engine(args.seed_workers, local_default=local) as engine:
        results = engine.map(
            _train_run,
            runs,
            labels=[f"seed {s}" for s in seeds],
            catch=True,
            progress=not args.no_progress,
            desc="training seeds",
        )
    for seed, result in zip(seeds, results):
        print(f"seed {seed}: {result.error if isinstance(result, Failed) else result}")
    return 1 if any(isinstance(r, Failed) for r in results) else 0


def seed_argv(argv: list[str], seed: int, out: Path) -> list[str]:
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
    return [
        *kept,
        "--seed",
        str(seed),
        "--out",
        str(out),
        "--workers",
        "1",
        "--report-dir",
        str(out / "report"),
        "--no-progress",
    ]


def _train_run(argv: list[str]) -> str:
    """One training run (in a Ray worker): ``python train.py ARGV`` in its own process, so the
    worker needs nothing of the repository but the script; the folder it wrote."""
    done = subprocess.run([sys.executable, str(TRAIN_SCRIPT), *argv], cwd=Path.cwd())
    if done.returncode != 0:
        raise RuntimeError(f"train.py {' '.join(argv)} failed (exit code {done.returncode})")
    return argv[argv.index("--out") + 1]
