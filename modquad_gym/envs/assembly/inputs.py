"""Input cleaning of the assembly environment: constructor arguments, actions and tasks.

Bad input is a ValueError naming the argument; an action that is not an integer of the action
space is not an error but an invalid action (:func:`parse_action` returns None).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np

from modquad_gym.core.validation import check_f_max, check_int, check_real
from modquad_gym.dynamics import DynamicTask
from modquad_gym.envs.assembly.types import Rules
from modquad_gym.envs.assembly.viewer import AssemblyViewer
from modquad_gym.oracle import METHODS as ORACLE_METHODS
from modquad_gym.tasks import TaskRequirement, as_task

INVALID_ACTION_MODES = ("penalise", "terminate")


def one_task(task: Any, tasks: Any, default_tasks: Any) -> Any:
    """The task source of a constructor given ``task=`` (one task) or ``tasks=`` (a source).

    ``task`` is one task: a TaskRequirement, a DynamicTask, a task file or ``"example:NAME"``;
    it replaces ``tasks``. Giving both, or naming a family of random tasks or a suite with
    ``task=``, is a ValueError that names ``tasks=``."""
    if task is None:
        return tasks
    if not (isinstance(tasks, str) and tasks == default_tasks):
        raise ValueError(
            f"give task= (one task) or tasks= (a task source), not both; got task={task!r} "
            f"and tasks={tasks!r} (an id such as ModQuadAssemblyPaper-v0 sets tasks= itself: "
            "make ModQuadAssembly-v0 with task=)"
        )
    single_task(task, "task=", named=True)
    return task


def task_source(tasks: Any, n_max: int) -> Any:
    """The task generator of ``tasks=`` (:func:`~modquad_gym.tasks.make_generator`); its
    ValueError names ``tasks`` (the constructor takes many arguments)."""
    from modquad_gym.tasks import make_generator

    try:
        return make_generator(tasks, n_max)
    except ValueError as exc:
        raise ValueError(f"tasks: {exc}") from None


def single_task(task: Any, what: str, named: bool = False) -> TaskRequirement | DynamicTask:
    """The one task that ``task`` is or names (a TaskRequirement, a DynamicTask, a task file
    or ``"example:NAME"``), read once; a ValueError naming ``what`` for a family of random
    tasks, a suite or anything else (what ``task=`` and ``reset(options={"task": ...})``
    take); with ``named``, a file's errors too (``what: FILE: ...``)."""
    from modquad_gym.tasks import NAMED_GENERATORS, FixedTasks, make_generator

    if isinstance(task, str) and task in NAMED_GENERATORS:
        raise ValueError(
            f"{what.rstrip('=')}={task!r} names a family of random tasks: pass it as "
            f"tasks={task!r} "
            f"({what} takes one task: a task file, 'example:NAME' or a TaskRequirement)"
        )
    if isinstance(task, (TaskRequirement, DynamicTask, str)) or hasattr(task, "__fspath__"):
        try:
            gen = make_generator(task)
        except ValueError as exc:
            if not named:
                raise
            raise ValueError(f"{what.rstrip('=')}: {exc}") from None
        if isinstance(gen, FixedTasks) and len(gen.tasks) == 1:
            return gen.tasks[0]
    raise ValueError(
        f"{what} takes one task (a task file, 'example:NAME', a TaskRequirement or a "
        f"DynamicTask), got {task!r}; for a suite, a list or a generator use tasks="
    )


def reset_options(options: Any, module_set: Any, f_max: float | None) -> dict:
    """``reset(options=...)`` checked, as a new dict: a dict or None (Gymnasium's convention) of
    the known keys (``task``, and the module set's: a palette's ``initial_type``), else a
    ValueError naming the option; ``"task"`` is the given task, checked (:func:`given_task`),
    or None."""
    if options is None:
        options = {}
    if not isinstance(options, dict):
        raise ValueError(f"options must be a dict or None, got {options!r:.60}")
    known = ["task", *module_set.reset_options]
    unknown = sorted(set(options) - set(known), key=repr)
    if unknown:
        raise ValueError(f"unknown reset options {unknown}; known: {known}")
    options = module_set.check_options(dict(options))
    options["task"] = given_task(options.get("task"), module_set, f_max)
    return options


def make_viewer(
    viewer: Any, radius: int, n_max: int, size: tuple[int, int], palette: Any
) -> AssemblyViewer:
    """The env's viewer: a new one of ``size``, or ``viewer`` itself when it is an
    :class:`~.viewer.AssemblyViewer` whose grid reaches ``radius`` (render() draws with it); a
    ValueError naming ``viewer`` otherwise, or when ``size`` (not the default) differs from
    the viewer's frames."""
    if viewer is None:
        return AssemblyViewer(radius, n_max, size, palette)
    if not isinstance(viewer, AssemblyViewer):
        raise ValueError(f"viewer must be an AssemblyViewer or None, got {viewer!r:.60}")
    if viewer.radius < radius:
        raise ValueError(
            f"viewer: its grid reaches {viewer.radius} cells from the centre, this env's "
            f"{radius} (make it with AssemblyViewer(radius={radius}, ...))"
        )
    if tuple(size) not in (DEFAULT_RENDER_SIZE, tuple(viewer.size)):
        raise ValueError(
            f"render_size {tuple(size)} and the viewer's frames {tuple(viewer.size)} differ; "
            "give one of them"
        )
    return viewer


DEFAULT_RENDER_SIZE = (256, 256)
"""(height, width) of ``rgb_array`` frames unless ``render_size`` says otherwise."""


def make_rules(
    n_max: Any, max_steps: Any, invalid_action: Any, lookahead: Any, n_max_limit: int,
    top_k: Any = None,
) -> Rules:  # fmt: skip
    """The episode :class:`~.types.Rules`; ValueError naming a bad argument. ``max_steps``
    None means 4 * n_max; it lies in [n_max - 1, 4 * n_max_limit]. ``top_k`` (the exact
    lookahead's shortlist) is None or an integer >= 1, with ``lookahead="exact"`` only."""
    invalid_action = check_invalid_action(invalid_action)
    lookahead = check_lookahead(lookahead)
    n_max = check_int(n_max, "n_max", 2, n_max_limit)
    if max_steps is None:
        max_steps = 4 * n_max
    max_steps = check_int(max_steps, "max_steps", n_max - 1, 4 * n_max_limit)
    return Rules(n_max, max_steps, invalid_action, lookahead, check_top_k(top_k, lookahead))


def check_invalid_action(value: Any) -> str:
    """``invalid_action``: one of :data:`INVALID_ACTION_MODES`; else a ValueError naming it."""
    if not isinstance(value, str) or value not in INVALID_ACTION_MODES:
        raise ValueError(f"invalid_action must be one of {INVALID_ACTION_MODES}, got {value!r}")
    return value


def check_lookahead(value: Any) -> bool | str:
    """``lookahead``: False, True or ``"exact"``; else a ValueError naming it."""
    exact = isinstance(value, str) and value == "exact"
    if not exact and not isinstance(value, (bool, np.bool_)):
        raise ValueError(f"lookahead must be False, True or 'exact', got {value!r}")
    return "exact" if exact else bool(value)


def check_top_k(top_k: Any, lookahead: Any) -> int | None:
    """``lookahead_top_k`` (the exact lookahead's shortlist): None, or an integer >= 1 with
    ``lookahead="exact"`` only; else a ValueError naming it."""
    if top_k is None:
        return None
    top_k = check_int(top_k, "lookahead_top_k", 1)
    if lookahead != "exact":
        raise ValueError(
            f"lookahead_top_k={top_k} shortlists the exact lookahead: it needs "
            f"lookahead='exact', got lookahead={lookahead!r}"
        )
    return top_k


def make_encoding(actions: Any, encodings: dict) -> Any:
    """The action encoding class named ``actions``; ValueError naming the known ones."""
    if not isinstance(actions, str) or actions not in encodings:
        raise ValueError(f"actions must be one of {sorted(encodings)}, got {actions!r}")
    return encodings[actions]


def check_render_mode(render_mode: Any, metadata: dict) -> None:
    """ValueError for a render mode the env does not have."""
    if render_mode is not None and (
        not isinstance(render_mode, str) or render_mode not in metadata["render_modes"]
    ):
        raise ValueError(
            f"render_mode must be None or one of {metadata['render_modes']}, got {render_mode!r}"
        )


MIN_F_MAX = 1e-9
"""The smallest thrust limit the environment takes (every door's range,
:data:`~modquad_gym.core.validation.F_MAX_RANGE`, starts at 1e-300): its float32 features are
ratios of wrenches to f_max, which below it overflow."""


def check_env_f_max(f_max: object) -> float:
    """The env's f_max: the one check of every f_max (up to 1e12 N,
    :func:`~modquad_gym.core.validation.check_f_max`), and at least :data:`MIN_F_MAX`."""
    return check_real(check_f_max(f_max), "f_max", low=MIN_F_MAX)


def check_render_size(size: object) -> tuple[int, int]:
    """(height, width) of rendered frames: two integers in 16..4096."""
    try:
        h, w = size  # type: ignore[misc]
    except (TypeError, ValueError):
        raise ValueError(f"render_size must be (height, width), got {size!r}") from None
    return check_int(h, "render_size height", 16, 4096), check_int(w, "render_size width", 16, 4096)


def check_oracle_method(method: object) -> str:
    if not isinstance(method, str) or method not in ORACLE_METHODS:
        raise ValueError(
            f"oracle_method must be one of {', '.join(ORACLE_METHODS)}, got {method!r}"
        )
    return method  # type: ignore[return-value]


def parse_action(action: Any, n: int) -> int | None:
    """The integer action in [0, n), or None for anything else (an invalid action): never
    raises. A whole-number float counts as that integer; a boolean never does, nor a masked
    array with a masked element (that element holds no value)."""
    if type(action) is int or isinstance(action, np.integer):  # the fast, common case
        return int(action) if 0 <= action < n else None
    if isinstance(action, (bool, np.bool_)):
        return None
    if isinstance(action, np.ma.MaskedArray) and np.ma.is_masked(action):
        return None
    try:
        arr = np.asarray(action)
        if arr.size != 1 or arr.dtype.kind not in "iuf":
            return None
        value = arr.reshape(-1)[0]
        if arr.dtype.kind == "f" and not (np.isfinite(value) and value == np.floor(value)):
            return None
        a = int(value)
    except Exception:  # whatever it is, it is not an action
        return None
    return a if 0 <= a < n else None


def given_task(given: Any, module_set: Any, f_max: float | None) -> Any:
    """The task of ``reset(options={"task": given})`` (None when not given), checked as
    :func:`draw_task` checks a drawn one; its f_max in range when the env has none of its own."""
    if given is None:
        return None
    if isinstance(given, str) or hasattr(given, "__fspath__"):
        task = single_task(given, "options['task']", named=True)
    else:
        task = as_task(given, "options['task']")
    if f_max is None:
        check_env_f_max(task.f_max)
    return check_self_weight(task, module_set.self_weight)


def draw_task(
    generator: Callable[[np.random.Generator], Any], rng: np.random.Generator, module_set: Any
) -> TaskRequirement | DynamicTask:
    """The episode's task drawn from ``generator`` with ``rng``; tasks of kind ``external``
    only when the module set decides self-weight (:func:`check_self_weight`)."""
    name = str(getattr(generator, "name", type(generator).__name__))
    task = as_task(generator(rng), f"task generator {name!r} returned a bad task", name)
    return check_self_weight(task, module_set.self_weight)


def check_self_weight(task: Any, self_weight: bool) -> TaskRequirement | DynamicTask:
    """``task``, when the env can decide it: a task of kind ``external`` only when the env
    decides ``self_weight``; a :class:`~modquad_gym.dynamics.DynamicTask` always (each
    structure's own mass and inertia decide it, :mod:`.dynamic`)."""
    shared_weight = task.wrench_model.uses_mass and not task.per_structure
    if shared_weight and not self_weight:  # the palette's masses add the weight
        raise ValueError(
            f"task {task.name!r} is of kind {task.kind!r}: make the env with modules=[...] "
            "(e.g. modules=[module]), which decides self-weight"
        )
    return task
