"""The scale families: tasks of 16 to 128 modules drawn reproducibly, for the held-out scale
suites (``modquad_gym/data/suites/scale_N.json``, written by ``python -m benchmarks.scale_suites``)
and for training at scale (:mod:`agents.expert_iteration` draws from the same families with
seeds of its own).

Seeds: task ``i`` of family ``f`` (index in :data:`FAMILIES`) in band ``n`` is drawn from
``default_rng(SCALE_SEED0 + 10_000 f + 100 n + i)``; validation tasks (where settings are tuned)
from ``SCALE_VALIDATION_SEED0`` in the same layout. Training never uses either range.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from modquad_gym.geometry.module import GRAVITY, palette
from modquad_gym.geometry.structure import Structure
from modquad_gym.search.bounds import force_lower_bound
from modquad_gym.tasks import PlantedMixedTasks, PlantedTasks, TaskRequirement, random_cells


def low_force_task(
    hidden: Structure,
    t: int,
    rng: np.random.Generator,
    fz: tuple[float, float] = (0.5, 2.5),
) -> np.ndarray:
    """``t`` wrenches that ``hidden`` produces, with small forces and torques near its limit.

    Each wrench is the vertex A u (u in {0, 1}^4n) of the hidden structure's zonotope that is
    extreme in a direction d = (small f_x, f_y weights, -beta, unit torque direction), i.e.
    it maximises the torque along a random direction while penalising f_z. The wrench is then
    scaled by alpha <= 1 (thrusts alpha u stay in [0, 1]) to a random f_z in ``fz``, and further
    until its force lies in the force set of ONE module. So the exact force bound skips no
    level, while the torque-to-thrust ratios need the hidden structure's lever arms."""
    A = hidden.configuration_matrix()
    W: list[np.ndarray] = []
    while len(W) < t:
        tau = rng.normal(size=3)
        d = np.concatenate([0.1 * rng.normal(size=2), [-rng.uniform(0.5, 3.0)], tau])
        w = A @ (A.T @ d > 0).astype(float)
        if w[2] < 1e-6:  # no rotor on: the zero wrench
            continue
        alpha = min(1.0, rng.uniform(*fz) / w[2])
        while force_lower_bound(alpha * w[None], hidden.module) > 1:
            alpha *= 0.9
        W.append(alpha * w)
    return np.array(W)


BANDS = (16, 24, 32, 48, 64, 96, 128)
"""The size bands of the scale suites (planted module counts)."""

SCALE_SEED0 = 5_000_000
SCALE_VALIDATION_SEED0 = 6_000_000
MIXED_PALETTE = "t45,t45m,flat"
PAYLOAD_F_MAX = 2.0
"""Rotor limit (N) of the payload family: a 0.3 kg module lifts itself with 2.9 of its 5.7 N."""


def payload_task(n: int, rng: np.random.Generator, t: int = 24) -> TaskRequirement:
    """Carry a heavy payload: ``t`` rotor wrenches ``A u`` of a hidden n-module structure with
    every rotor at 70-100 % of f_max, minus the structure's weight (kind ``external``): the
    wrenches it applies to the payload. The hidden structure satisfies it exactly."""
    cells = random_cells(rng, n)
    hidden = Structure(cells)
    A = hidden.configuration_matrix()
    U = rng.uniform(0.7, 1.0, size=(t, A.shape[1])) * PAYLOAD_F_MAX
    W = U @ A.T
    W[:, 2] -= hidden.mass * GRAVITY
    meta = {"planted_cells": [list(c) for c in cells], "optimum_upper_bound": n}
    return TaskRequirement(W, name="payload", f_max=PAYLOAD_F_MAX, kind="external", meta=meta)


def torque_task(n: int, rng: np.random.Generator, t: int = 16) -> TaskRequirement:
    """Low force, high torque: ``t`` wrenches of a hidden n-module structure
    (:func:`low_force_task`)."""
    hidden = Structure(random_cells(rng, n))
    W = low_force_task(hidden, t, rng)
    meta = {"planted_cells": [list(c) for c in hidden.cells], "optimum_upper_bound": n}
    return TaskRequirement(W, name="torque", meta=meta)


FAMILIES: dict[str, tuple[Callable[[int, np.random.Generator], TaskRequirement], str | None]] = {
    "planted": (lambda n, rng: PlantedTasks(n_modules=n, n_wrenches=40)(rng), None),
    "mixed": (lambda n, rng: PlantedMixedTasks(n_modules=n)(rng), MIXED_PALETTE),
    "payload": (payload_task, None),
    "torque": (torque_task, None),
}
"""Family name -> (draw(n, rng), palette of stock names or None for the T-module)."""


def task_seed(family: str, band: int, i: int, validation: bool = False) -> int:
    """The seed of task ``i`` of ``family`` in ``band`` (module docstring)."""
    if not 0 <= i < 100:
        raise ValueError(f"at most 100 tasks per family and band, got index {i}")
    seed0 = SCALE_VALIDATION_SEED0 if validation else SCALE_SEED0
    return seed0 + 10_000 * list(FAMILIES).index(family) + 100 * band + i


def draw(family: str, band: int, i: int, validation: bool = False) -> TaskRequirement:
    """Task ``i`` of ``family`` in ``band`` with its seed, family, band, palette and planted size
    in ``meta`` (no bounds yet: :func:`with_bounds`)."""
    make, names = FAMILIES[family]
    seed = task_seed(family, band, i, validation)
    task = make(band, np.random.default_rng(seed))
    prefix = "val-" if validation else ""
    meta = {**task.meta, "seed": seed, "family": family, "band": band, "palette": names,
            "planted": band}  # fmt: skip
    return TaskRequirement(task.wrenches, name=f"{prefix}{family}-{band}-{i}", f_max=task.f_max,
                           kind=task.kind, meta=meta)  # fmt: skip


def task_palette(task: TaskRequirement) -> list | None:
    """The module types a scale task is searched with (None: the T-module alone)."""
    names = task.meta.get("palette")
    return palette(names) if names else None
