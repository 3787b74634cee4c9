"""Held-out task suites for the agent benchmark and the validation tasks used while training.

Every task is drawn from a fresh ``numpy.random.default_rng(seed)`` with a seed from a range that
training never uses, so suites are reproducible and disjoint from training:

* training: each environment's generator stream is seeded by ``reset(seed=train_seed + i)``
  (train.py, default train_seed 0, i the env index) and then continues that one stream;
* validation (MaskableEvalCallback while training): seeds ``VALIDATION_SEED0 + i``;
* held-out planted suite: seeds ``PLANTED_SEED0 + i``; held-out paper suite: ``PAPER_SEED0 + i``.

Both ranges are reserved (:mod:`modquad_gym.tasks.reserved`: validation 500,000-999,999, held-out
1,000,000-8,999,999, every tier's suite included): an environment reset with such a seed warns.

The tasks are continuous random draws, so a collision with a training task has probability
zero; :func:`check_disjoint` also checks every suite task against the task files shipped in
``examples/`` and ``modquad_gym/data`` and against the first tasks drawn by the training
streams. Each held-out task stores ``meta["seed"]`` and ``meta["optimum"]``: the certified
minimum module count from :func:`~modquad_gym.search.exhaustive_search` (None when no structure
of up to ``n_max`` modules works).

``python -m modquad_gym.scoring.suites`` rewrites ``modquad_gym/data/suites/heldout_*.json``
(deterministic).
"""

from __future__ import annotations

import time
from collections.abc import Iterable, Sequence
from pathlib import Path

import numpy as np

from modquad_gym.core.options import OneLineParser
from modquad_gym.core.outputs import hold_output_dir
from modquad_gym.search import exhaustive_search
from modquad_gym.tasks import (
    PaperTasks,
    PlantedTasks,
    TaskGenerator,
    TaskRequirement,
    load_suite,
    make_generator,
    save_suite,
)
from modquad_gym.tasks.planted_meta import fault_meta
from modquad_gym.tasks.reserved import HELDOUT_SEEDS, VALIDATION_SEEDS

VALIDATION_SEED0 = VALIDATION_SEEDS.start  # 500,000 (modquad_gym.tasks.reserved)
PLANTED_SEED0 = HELDOUT_SEEDS.start  # 1,000,000
PAPER_SEED0 = 2_000_000
SUITES_DIR = Path(__file__).resolve().parents[1] / "data" / "suites"
HELDOUT = {"heldout_planted": 60, "heldout_paper": 40}
"""Default held-out suites and their sizes."""


def draw_task(generator: TaskGenerator, seed: int, name: str | None = None):
    """The task ``generator`` draws from ``default_rng(seed)``, with ``meta["seed"]`` set."""
    task = generator(np.random.default_rng(seed))
    return relabelled(task, name or task.name, {**task.meta, "seed": int(seed)})


def relabelled(task, name: str, meta: dict):
    """``task`` (static or dynamic) under another name and meta."""
    return task.relabelled(name, meta)


def with_optimum(task, n_max: int = 7, modules=None, fault: str | None = None):
    """``task`` (static or dynamic) with its certified optimum in ``meta`` (exhaustive search up
    to ``n_max``, over the ``modules`` palette if given; with a ``fault``, the smallest structure
    that survives any single failure of that kind, and ``optimum_fault``; a planted answer's
    keys then read ``intact_*``, :func:`~modquad_gym.tasks.planted_meta.fault_meta`):
    ``optimum`` (None beyond n_max), ``optimum_n_max``, ``optimum_cells``, ``optimum_modules``
    (with a palette), and the search's ``exhaustive_evaluated`` and ``exhaustive_seconds``."""
    task = fault_meta(task, fault)  # the planted count bounds no tolerant optimum
    t0 = time.perf_counter()
    options = {"modules": modules} if modules else {}
    r = exhaustive_search(task, n_max=n_max, **options, **({"fault": fault} if fault else {}))
    s = r.structure
    meta = {**task.meta, "optimum": r.n_modules, "optimum_n_max": n_max,
            "optimum_cells": [list(c) for c in s.cells] if s is not None else None,
            "optimum_modules": [m.name for m in s.modules] if s is not None and modules else None,
            "exhaustive_evaluated": r.evaluated,
            "exhaustive_seconds": round(time.perf_counter() - t0, 3)}  # fmt: skip
    if fault:
        meta["optimum_fault"] = fault
    return relabelled(task, task.name, meta)


def build_suite(kind: str, n: int, n_max: int = 7) -> list[TaskRequirement]:
    """``n`` held-out tasks of ``kind`` ("planted" or "paper") with their optimum."""
    if kind == "planted":
        gen, seed0 = PlantedTasks(), PLANTED_SEED0
    elif kind == "paper":
        gen, seed0 = PaperTasks(), PAPER_SEED0
    else:
        raise ValueError(f"unknown suite kind {kind!r}; choose 'planted' or 'paper'")
    return [
        with_optimum(draw_task(gen, seed0 + i, name=f"{kind}-{seed0 + i}"), n_max) for i in range(n)
    ]


def optimum_counts(tasks: Sequence[TaskRequirement]) -> dict:
    """How many tasks have each certified optimum (None: no structure up to n_max), sorted."""
    optima = [t.meta.get("optimum") for t in tasks]
    return {k: optima.count(k) for k in sorted(set(optima), key=lambda v: (v is None, v or 0))}


def check_optima(tasks: Sequence, where: str, modules=None, fault: str | None = None) -> None:
    """ValueError naming ``where`` (the suite), the 1-based task and its ``meta.optimum`` when
    that is not a module count (a positive integer, or null: no structure up to its n_max) or
    when the exact bounds (:func:`~modquad_gym.search.bounds.bound_levels`, for the module
    types ``modules`` and the ``fault`` scored) prove that no structure of that many modules
    exists: every method would be scored against it, so it is checked before any work."""
    from numbers import Integral

    from modquad_gym.search.bounds import bound_levels
    from modquad_gym.search.problem import SearchProblem

    for i, task in enumerate(tasks, 1):
        claim = task.meta.get("optimum")
        label = f"{where}: task {i} ({task.name!r}): meta.optimum"
        if claim is None:
            continue
        if isinstance(claim, bool) or not isinstance(claim, Integral) or claim < 1:
            raise ValueError(
                f"{label} = {claim!r} is not a module count (a positive integer, or null where "
                "no structure of up to its n_max modules does the task)"
            )
        if bound_levels(SearchProblem(task, int(claim), modules=modules, fault=fault)) > claim:
            raise ValueError(
                f"{label} = {claim} is below the proved lower bound: no structure of {claim} "
                f"module{'s' if claim > 1 else ''} or fewer can do this task (modquad solve "
                "--method exhaustive certifies its optimum)"
            )


class CyclingTasks:
    """A task generator that returns the given tasks in order, round and round (ignores the
    rng): an evaluation over ``len(tasks)`` episodes sees every task exactly once."""

    def __init__(self, tasks: Sequence[TaskRequirement], name: str = "cycle") -> None:
        if not tasks:
            raise ValueError("CyclingTasks needs at least one task")
        self.tasks = list(tasks)
        self.name = name
        self._i = 0

    def __call__(self, rng: np.random.Generator) -> TaskRequirement:
        task = self.tasks[self._i % len(self.tasks)]
        self._i += 1
        return task


def validation_tasks(n: int = 40, source: str = "mixed") -> list[TaskRequirement]:
    """Validation tasks for training (seeds ``VALIDATION_SEED0 + i``), never in a held-out
    suite; ``source`` as in :func:`modquad_gym.tasks.make_generator` (a generator name)."""
    if n > len(VALIDATION_SEEDS):
        raise ValueError(f"n: at most {len(VALIDATION_SEEDS):,} validation tasks, got {n}")
    gen = make_generator(source)
    return [draw_task(gen, VALIDATION_SEED0 + i, name=f"val-{i}") for i in range(n)]


def _shipped_tasks(root: Path) -> list[TaskRequirement]:
    out: list[TaskRequirement] = []
    for folder in (root / "examples", root / "modquad_gym" / "data"):
        for path in sorted(folder.glob("*.json")) if folder.is_dir() else []:
            try:
                out.extend(load_suite(path))
            except ValueError:
                out.append(TaskRequirement.load(path))
    return out


def training_sample(source: str = "mixed", seeds: Iterable[int] = (0, 1), n: int = 2000):
    """The first ``n`` tasks each training stream draws (env seeds ``seeds``)."""
    gen = make_generator(source)
    for seed in seeds:
        rng = np.random.default_rng(seed)
        for _ in range(n):
            yield gen(rng)


def check_disjoint(suite: Sequence[TaskRequirement], root: Path | None = None) -> None:
    """ValueError if a suite task has the wrenches of a shipped task file or of a task the
    training streams draw first (see the module docstring)."""
    root = root or Path(__file__).resolve().parents[2]
    seen = {t.wrenches.tobytes() for t in _shipped_tasks(root)}
    seen |= {t.wrenches.tobytes() for t in training_sample()}
    for task in suite:
        if task.wrenches.tobytes() in seen:
            raise ValueError(f"suite task {task.name!r} also appears in training or example data")


def main(argv: list[str] | None = None) -> int:
    parser = OneLineParser(
        prog="python -m modquad_gym.scoring.suites",
        description="Write the held-out benchmark suites (deterministic seeds, optimum by the "
        "exhaustive search).",
    )
    parser.add_argument("--out", type=Path, default=SUITES_DIR, help="folder (default %(default)s)")
    parser.add_argument("--n-planted", type=int, default=HELDOUT["heldout_planted"])
    parser.add_argument("--n-paper", type=int, default=HELDOUT["heldout_paper"])
    parser.add_argument("--n-max", type=int, default=7)
    parser.add_argument("--force", action="store_true", help="replace existing suite files")
    args = parser.parse_args(argv)
    kinds = (("planted", args.n_planted), ("paper", args.n_paper))
    names = tuple(f"heldout_{kind}.json" for kind, _ in kinds)
    with hold_output_dir(args.out, names, args.force):  # before the certified searches
        for kind, n in kinds:
            suite = build_suite(kind, n, n_max=args.n_max)
            check_disjoint(suite)
            path = save_suite(suite, args.out / f"heldout_{kind}.json", force=args.force)
            print(f"{path}: {n} tasks, optimum counts {optimum_counts(suite)}")
    return 0


if __name__ == "__main__":
    from modquad_gym.core.interrupts import run_command

    raise SystemExit(run_command(main, "python -m modquad_gym.scoring.suites"))
