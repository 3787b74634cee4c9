"""Task sources by name (:data:`NAMED_GENERATORS`) and :func:`make_generator`, which turns any
task spec (a name, a task or suite file, a task, a generator, a callable, a list) into a
generator."""

from __future__ import annotations

import dataclasses
import os
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from modquad_gym.core.options import MAX_SEED
from modquad_gym.core.validation import check_int
from modquad_gym.dynamics import DynamicTask
from modquad_gym.dynamics.random_motions import MotionTasks
from modquad_gym.geometry.cells import MAX_MODULES
from modquad_gym.tasks.examples import resolve_task_path
from modquad_gym.tasks.files import SUFFIXES, json_keys
from modquad_gym.tasks.generators import (
    EXTERNAL_F_MAX,
    FixedTasks,
    MixedTasks,
    PaperTasks,
    PlantedMixedTasks,
    PlantedTasks,
    ScrewdriverTask,
    TaskGenerator,
)
from modquad_gym.tasks.loading import load_task
from modquad_gym.tasks.requirement import TaskRequirement
from modquad_gym.tasks.suites import load_suite

NAMED_GENERATORS: dict[str, Callable[[], TaskGenerator]] = {
    "paper": PaperTasks,
    "planted": PlantedTasks,
    "screwdriver": ScrewdriverTask,
    "mixed": lambda: MixedTasks((PlantedTasks(), PaperTasks())),
    "planted-large": lambda: PlantedTasks(n_modules=(6, 12), name="planted-large"),
    "planted-16-64": lambda: PlantedTasks(n_modules=(16, 64), name="planted-16-64"),
    "paper-external": lambda: PaperTasks(n_wrenches=40, kind="external", f_max=EXTERNAL_F_MAX,
                                         fz_offset=1.0, fz_gain=8.0, name="paper-external"),
    "planted-external": lambda: PlantedTasks(kind="external", f_max=EXTERNAL_F_MAX,
                                             name="planted-external"),
    "screwdriver-external": lambda: ScrewdriverTask(kind="external", f_max=EXTERNAL_F_MAX,
                                                    name="screwdriver-external"),
    "planted-mixed-external": lambda: PlantedMixedTasks(kind="external", f_max=EXTERNAL_F_MAX,
                                                        name="planted-mixed-external"),
    "motions": MotionTasks,
}  # fmt: skip
"""The task sources by name (each call makes a fresh generator)."""
GENERATORS = tuple(NAMED_GENERATORS)
"""Names understood by :func:`make_generator`."""


def make_generator(spec: Any, n_max: int | None = None) -> TaskGenerator:
    """A task generator from a spec:

    * ``"paper"``, ``"planted"``, ``"screwdriver"``, ``"mixed"`` (planted and paper, equal odds);
      ``"planted-large"`` (planted in 6-12 modules: the large tier), ``"planted-16-64"`` (the
      scale id's), ``"paper-external"``
      (paper-like wrenches on the environment, kind ``external``, f_max
      :data:`~.generators.EXTERNAL_F_MAX` = 2 N: 40 wrenches, f_z in [1, 5]),
      ``"planted-external"`` and ``"screwdriver-external"`` (the same generators as
      ``planted`` and ``screwdriver``, kind ``external``, f_max 2 N) and
      ``"planted-mixed-external"`` (:class:`PlantedMixedTasks`, external, f_max 2 N: the mixed
      tier); ``"motions"`` (:class:`~modquad_gym.dynamics.random_motions.MotionTasks`: random
      dynamic tasks, the dynamic tier);
    * a path to a task file (``.json``/``.csv``/``.npy``, a dynamic task's JSON too) or a suite
      JSON: those fixed tasks; ``example:NAME`` reads the shipped example (as the CLI does);
    * a :class:`TaskRequirement` or a :class:`~modquad_gym.dynamics.DynamicTask`: always that
      task; a :class:`TaskGenerator` (``name`` and ``__call__(rng)``): itself;
    * any other callable ``gen(rng)`` (a function, a lambda, a bound method): wrapped as a
      generator named after it; each result must be a :class:`TaskRequirement`, a
      :class:`~modquad_gym.dynamics.DynamicTask` or a (t, 6) wrench array (made a
      TaskRequirement), anything else raises ValueError when drawn. The wrapper pickles when
      ``gen`` does;
    * a list or tuple of any of these: tasks are pooled into one :class:`FixedTasks` (uniform
      over tasks); if any element is a random generator, a :class:`MixedTasks` (uniform over
      elements).

    With ``n_max`` (the environment's; an integer in 1..:data:`MAX_MODULES`), a named source
    draws its planted sizes within n_max (``sizes_within``), so a planted task always has a
    solution within n_max; a source whose sizes already fit (every registered id's at its
    default n_max) is left as it is.

    Raises ValueError naming the spec or ``n_max`` (TaskFileError for a bad file).
    """
    if n_max is not None:
        n_max = check_int(n_max, "n_max", 1, MAX_MODULES)
    if isinstance(spec, (TaskRequirement, DynamicTask)):
        return FixedTasks((spec,), name=spec.name)
    if isinstance(spec, (list, tuple)):
        if not spec:
            raise ValueError("an empty list is not a task spec")
        gens = [make_generator(s, n_max) for s in spec]
        if all(isinstance(g, FixedTasks) for g in gens):
            pooled = tuple(t for g in gens for t in g.tasks)  # type: ignore[attr-defined]
            return FixedTasks(pooled, name="+".join(g.name for g in gens))
        return MixedTasks(tuple(gens), name="+".join(g.name for g in gens))
    if isinstance(spec, (str, os.PathLike)):
        key = os.fspath(spec)
        if key in NAMED_GENERATORS:
            gen = NAMED_GENERATORS[key]()
            return gen if n_max is None else sizes_within(gen, n_max)
        path = resolve_task_path(key)  # example:NAME -> the shipped file (else ValueError)
        if _is_file(path):
            if path.suffix.lower() == ".json" and "tasks" in json_keys(path):
                return FixedTasks(tuple(load_suite(path)), name=path.stem)
            return FixedTasks((load_task(path),), name=path.stem)
        raise ValueError(
            f"unknown task spec {key!r:.80}: not one of {', '.join(GENERATORS)} and not an "
            f"existing task file ({', '.join(SUFFIXES)})"
        )
    if isinstance(spec, type):  # before the protocol check: a class has name and __call__
        raise ValueError(
            f"cannot make a task generator from the class {spec.__name__}; pass an instance "
            f"(e.g. {spec.__name__}()) or a function gen(rng) -> TaskRequirement"
        )
    if isinstance(spec, TaskGenerator):
        return spec
    if callable(spec):
        return CallableTasks(spec)
    raise ValueError(
        f"cannot make a task generator from {type(spec).__name__} {spec!r}; give a name "
        f"({', '.join(GENERATORS)}), a task file, a TaskRequirement, a DynamicTask, a "
        f"generator (any callable gen(rng) -> TaskRequirement) or a list"
    )


def _is_file(path: os.PathLike) -> bool:
    """Whether ``path`` is a file; False where the system cannot even look (a name longer than
    it takes: OSError), so such a spec is refused as an unknown one, naming it."""
    try:
        return Path(path).is_file()
    except OSError:
        return False


GENERATE_KINDS = ("paper", "planted", "screwdriver")
"""The generators ``modquad task generate --kind`` names (with ``--task-kind external``, their
``-external`` spec)."""


def generated_task(kind: str, seed: int = 0, task_kind: str = "total", f_max: float | None = None,
                   n_modules: int | None = None) -> TaskRequirement:  # fmt: skip
    """The task ``modquad task generate --kind KIND --seed SEED --task-kind TASK_KIND`` writes
    (the same file content from either door): the named generator ``KIND`` (``KIND-external``
    for an external task: :data:`NAMED_GENERATORS`, as the tiers and environments use them),
    with ``f_max`` and ``n_modules`` (planted only) replaced where given, drawn from
    ``default_rng(seed)`` and named ``NAME-seedSEED`` (the screwdriver, drawn from nothing,
    keeps its name). ValueError naming what is wrong."""
    if not isinstance(kind, str) or kind not in GENERATE_KINDS:
        raise ValueError(f"kind must be one of {', '.join(GENERATE_KINDS)}, got {kind!r}")
    if not isinstance(task_kind, str) or task_kind not in ("total", "external"):
        raise ValueError(f"task_kind must be total or external, got {task_kind!r}")
    seed = check_int(seed, "seed", 0, MAX_SEED)  # the command line's --seed: no [] or True
    gen = make_generator(kind if task_kind == "total" else f"{kind}-external")
    if n_modules is not None and not isinstance(gen, PlantedTasks):
        raise ValueError("n_modules applies to planted tasks only")
    given = {"f_max": f_max, "n_modules": n_modules}
    gen = dataclasses.replace(gen, **{k: v for k, v in given.items() if v is not None})
    task = gen(np.random.default_rng(seed))
    if isinstance(gen, ScrewdriverTask):
        return task
    return dataclasses.replace(task, name=f"{task.name}-seed{seed}")


def sizes_within(gen: TaskGenerator, n_max: int) -> TaskGenerator:
    """``gen`` with its planted sizes drawn within [min(lo, n_max), min(hi, n_max)] (a
    :class:`PlantedTasks` or :class:`PlantedMixedTasks`, also inside a :class:`MixedTasks`), so
    the hidden structure, a solution, has at most n_max modules; ``gen`` itself when its sizes
    already fit (the same draws, the same tasks)."""
    if isinstance(gen, MixedTasks):
        parts = tuple(sizes_within(g, n_max) for g in gen.generators)
        same = all(a is b for a, b in zip(parts, gen.generators))
        return gen if same else dataclasses.replace(gen, generators=parts)
    if isinstance(gen, (PlantedTasks, PlantedMixedTasks)):
        count = gen.n_modules
        lo, hi = (count, count) if isinstance(count, (int, np.integer)) else count
        if hi > n_max:
            return dataclasses.replace(gen, n_modules=(min(lo, n_max), n_max))
    return gen


class CallableTasks:
    """A callable ``gen(rng)`` as a TaskGenerator; its results are checked."""

    def __init__(self, fn: Any) -> None:
        self.fn = fn
        self.name = str(getattr(fn, "__name__", None) or type(fn).__name__)

    def __call__(self, rng: np.random.Generator) -> TaskRequirement | DynamicTask:
        task = self.fn(rng)
        if isinstance(task, (TaskRequirement, DynamicTask)):
            return task
        what = f"task generator {self.name!r} returned"
        if not isinstance(task, (np.ndarray, list, tuple)):
            raise ValueError(
                f"{what} {type(task).__name__}; it must return a TaskRequirement, a "
                f"DynamicTask or a (t, 6) wrench array"
            )
        try:
            return TaskRequirement(task, name=self.name)
        except ValueError as exc:
            raise ValueError(f"{what} a bad wrench array: {exc}") from None

    def __reduce__(self) -> tuple:  # pickles as make_generator(fn)
        return (make_generator, (self.fn,))

    def __repr__(self) -> str:
        return f"make_generator({self.fn!r})"
