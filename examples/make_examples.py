"""Regenerate the example task files (deterministic: fixed seeds). They live in the package,
``modquad_gym/data/examples`` (so they travel with the wheel); this folder links to them.

Run from the repository root:  python examples/make_examples.py
Each task's exhaustive optimum (smallest module count, n <= 7) is computed with the exact oracle
and stored in the task's ``meta`` as ``optimum`` (null when no structure of <= 7 modules works).
"""

from __future__ import annotations

import numpy as np

from modquad_gym import Structure, feasible, structure_levels
from modquad_gym.tasks import PaperTasks, PlantedTasks, ScrewdriverTask, TaskRequirement, save_suite
from modquad_gym.tasks.examples import EXAMPLES_DIR as HERE

N_MAX = 7


def optimum(task: TaskRequirement) -> tuple[int | None, list[list[int]] | None]:
    """Smallest module count (and the first structure found) whose zonotope holds the task."""
    for n, level in enumerate(structure_levels(N_MAX), 1):
        for key in level:
            A = Structure(key).configuration_matrix()
            if feasible(A, task.wrenches, f_max=task.f_max).all():
                return n, [list(c) for c in key]
    return None, None


def with_optimum(task: TaskRequirement) -> TaskRequirement:
    n, cells = optimum(task)
    meta = {**task.meta, "optimum": n, "optimum_cells": cells, "n_max": N_MAX}
    return TaskRequirement(task.wrenches, name=task.name, f_max=task.f_max, meta=meta)


def main() -> None:
    screwdriver = with_optimum(ScrewdriverTask()(np.random.default_rng(0)))
    paper = PaperTasks()(np.random.default_rng(0))
    paper = with_optimum(
        TaskRequirement(paper.wrenches, name="paper_seed0", f_max=paper.f_max, meta=paper.meta)
    )
    planted = PlantedTasks()(np.random.default_rng(1))
    planted = with_optimum(
        TaskRequirement(
            planted.wrenches,
            name="planted_seed1",
            f_max=planted.f_max,
            meta={**planted.meta, "planted_name": planted.name},
        )
    )
    # the script rewrites its own files: force
    screwdriver.save(HERE / "screwdriver.json", force=True)
    paper.save(HERE / "paper_seed0.json", force=True)
    paper.save(HERE / "paper_seed0.csv", force=True)
    planted.save(HERE / "planted_seed1.json", force=True)
    save_suite(
        [screwdriver, paper, planted], HERE / "suite_small.json", name="suite_small", force=True
    )
    for task in (screwdriver, paper, planted):
        print(
            f"{task.name}: {task.n_wrenches} wrenches, optimum {task.meta['optimum']} modules, "
            f"e.g. cells {task.meta['optimum_cells']}"
        )


if __name__ == "__main__":
    main()
