"""A dynamic task: fly a trajectory, optionally carrying a payload and exerting wrenches on the
environment. Its rotor wrenches depend on the structure that flies it (mass and inertia).

JSON task file (only ``trajectory.t`` and ``trajectory.position`` are required)::

    {"trajectory": {"t": [...], "position": [[x, y, z], ...], "quaternion": [[w, x, y, z], ...],
                    "velocity": ..., "acceleration": ..., "angular_velocity": ...,
                    "angular_acceleration": ...},
     "payload": {"mass": kg, "offset": [x, y, z]},
     "exerted": [[fx, fy, fz, tx, ty, tz], ...],
     "f_max": N, "name": "...", "kind": "dynamic", "meta": {...}}

``exerted`` holds one wrench per sample that the structure applies to the environment (e.g. a
contact force when pushing), in {S} about the COM; the rotors produce it on top of the motion's
wrench (as for tasks of kind ``external``). ``f_max`` is the rotor thrust limit in newtons
(default 1, as for every task file; a ModQuad-size 0.3 kg module needs more than 1.04 N per
rotor to hover, see :func:`check_liftable`). Unknown keys are refused, at every level.

The rotor wrenches of a structure S: ``required_wrenches(S, trajectory, payload) + exerted``,
linear in S's mass and inertia (:class:`~modquad_gym.dynamics.wrenches.LinearWrenches`,
:attr:`DynamicTask.wrench_model`).
"""

from __future__ import annotations

from collections.abc import Sequence
from functools import cached_property
from typing import Any

import numpy as np

from modquad_gym.core.validation import (
    check_f_max,
    check_task_name,
    float_array,
    refuse_non_numbers,
)
from modquad_gym.dynamics.samples import row_problem
from modquad_gym.dynamics.trajectory import Trajectory
from modquad_gym.dynamics.wrenches import LinearWrenches, Payload
from modquad_gym.geometry.module import ModuleType
from modquad_gym.geometry.structure import Structure

KEYS = ("trajectory", "payload", "exerted", "f_max", "name", "kind", "meta")
"""The keys of a dynamic task's JSON object."""

KIND = "dynamic"
"""The ``kind`` of every dynamic task (static tasks are ``total`` or ``external``)."""

MAX_LIFT_MODULES = 128
"""A payload that needs more modules than this to lift is refused as too heavy
(:func:`check_liftable`)."""


def is_dynamic_data(data: object) -> bool:
    """Whether the JSON object ``data`` is a dynamic task's: it has a ``trajectory``, or says
    ``"kind": "dynamic"`` (then :meth:`DynamicTask.from_dict` names a missing trajectory)."""
    return isinstance(data, dict) and ("trajectory" in data or data.get("kind") == KIND)


def _exerted(value: object, k: int) -> np.ndarray:
    refuse_non_numbers(value, "exerted")
    what = "a list of [fx, fy, fz, tx, ty, tz] rows"
    try:
        arr = float_array(value, "exerted", what)
    except ValueError:
        problem = row_problem(value, "exerted", 6)
        if problem is None:
            raise
        raise ValueError(problem) from None
    if arr.shape != (k, 6):
        raise ValueError(
            row_problem(value, "exerted", 6)
            or f"exerted must have shape ({k}, 6), one wrench per sample, got {arr.shape}"
        )
    bad = ~np.isfinite(arr)
    if bad.any():
        row, col = np.argwhere(bad)[0]
        raise ValueError(f"exerted: sample {row + 1} holds {arr[row, col]} (must be finite)")
    arr.setflags(write=False)
    return arr


class DynamicTask:
    """A trajectory to fly, an optional payload and optional exerted wrenches.

    Args:
        trajectory: the motion of the structure's COM (:class:`Trajectory`).
        payload: a :class:`Payload` (point mass at an offset from the COM), or None.
        exerted: (k, 6) wrenches applied to the environment, one per trajectory sample, in {S}
            about the COM, or None.
        f_max: rotor thrust limit in newtons.
        name: a label for reports and file names.
        meta: free-form JSON-ready extras (generator parameters...).
    """

    kind = KIND
    per_structure = True
    """Each structure's rotor wrenches are its own (its mass and inertia): the interface of
    every task (False for a :class:`~modquad_gym.tasks.TaskRequirement`)."""
    policy_tier = KIND
    """The benchmark tier whose shipped model the learned solvers use on the task."""
    normalised_units = False
    """SI units always (newtons, newton-metres)."""

    def __init__(
        self,
        trajectory: Trajectory,
        payload: Payload | None = None,
        exerted: object = None,
        f_max: float = 1.0,
        name: str = "dynamic",
        meta: dict | None = None,
    ) -> None:
        if not isinstance(trajectory, Trajectory):
            raise ValueError(f"trajectory must be a Trajectory, got {type(trajectory).__name__}")
        if payload is not None and not isinstance(payload, Payload):
            raise ValueError(f"payload must be a Payload or None, got {type(payload).__name__}")
        check_task_name(name)
        if meta is not None and not isinstance(meta, dict):
            raise ValueError(f"meta must be an object, got {meta!r}")
        self.trajectory = trajectory
        self.payload = payload if payload is not None and payload.mass > 0 else None
        self.exerted = None if exerted is None else _exerted(exerted, trajectory.n_samples)
        self.f_max = check_f_max(f_max)
        self.name = name
        self.meta = dict(meta or {})
        check_scale(self)

    @cached_property
    def wrench_model(self) -> LinearWrenches:
        """The rotor wrenches as a linear function of a structure's mass and inertia."""
        with np.errstate(over="ignore", invalid="ignore"):  # check_scale names what overflows
            return LinearWrenches.of(self.trajectory, self.payload, self.exerted)

    @property
    def decision_model(self) -> LinearWrenches:
        """The wrench model a search decides: :attr:`wrench_model` with repeated samples (e.g.
        the hover holds) kept once (every decision is a max or an all() over the samples)."""
        return self.wrench_model.compact()

    def describe(self) -> str:
        """``"<k> wrenches (dynamic)"``: one per trajectory sample."""
        return f"{self.n_wrenches} wrenches ({KIND})"

    def relabelled(self, name: str, meta: dict) -> DynamicTask:
        """The same task under another name and meta."""
        return DynamicTask(self.trajectory, self.payload, self.exerted, self.f_max, name, meta)

    def with_kind(self, kind: str | None) -> DynamicTask:
        """This task (None or ``"dynamic"``); ValueError for another kind."""
        if kind is not None and kind != KIND:
            raise ValueError(f"kind: a task with a trajectory is {KIND!r}, got {kind!r}")
        return self

    def with_f_max(self, f_max: float | None) -> DynamicTask:
        """The same task with another thrust limit (None or the same: this task)."""
        if f_max is None or check_f_max(f_max) == self.f_max:
            return self
        return DynamicTask(self.trajectory, self.payload, self.exerted, f_max, self.name, self.meta)

    def check_liftable(self, modules: Sequence[ModuleType]) -> int:
        """:func:`check_liftable` of this task."""
        return check_liftable(self, modules)

    def flight_seconds(self, hover_seconds: float) -> float:
        """How long one flight of the task lasts: its trajectory's duration."""
        return float(self.trajectory.duration)

    @property
    def n_wrenches(self) -> int:
        """One wrench per trajectory sample."""
        return self.trajectory.n_samples

    def __len__(self) -> int:
        return self.n_wrenches

    def rotor_wrenches(self, structure: Structure) -> np.ndarray:
        """(k, 6) what the rotors of ``structure`` must produce along the trajectory."""
        return self.wrench_model.for_structure(structure)

    def static_wrenches(self) -> np.ndarray:
        """(k, 6) the wrenches without the structure's own dynamics (payload and exerted
        wrenches only): what a design that ignores the structure's mass would be given."""
        return np.array(self.wrench_model.base)

    # --- dicts and files ----------------------------------------------------------------------
    def to_dict(self) -> dict[str, Any]:
        out: dict[str, Any] = {"name": self.name, "kind": KIND, "f_max": self.f_max}
        out["trajectory"] = self.trajectory.to_dict()
        if self.payload is not None:
            out["payload"] = self.payload.to_dict()
        if self.exerted is not None:
            out["exerted"] = self.exerted.tolist()
        if self.meta:
            from modquad_gym.tasks.files import jsonable

            out["meta"] = jsonable(self.meta)
        return out

    @classmethod
    def from_dict(cls, data: object, default_name: str = "dynamic") -> DynamicTask:
        """From a JSON object (module docstring); ValueError naming the key for anything wrong
        (checked in order: keys, trajectory, payload, exerted, f_max)."""
        if not isinstance(data, dict):
            raise ValueError(f"a dynamic task must be a JSON object, got {data!r}")
        unknown = sorted(set(data) - set(KEYS))
        if unknown:
            raise ValueError(
                f"{unknown[0]}: unknown key in a dynamic task; known: {', '.join(KEYS)}"
            )
        if "trajectory" not in data:
            raise ValueError("trajectory: missing (a dynamic task needs one)")
        if data.get("kind", KIND) != KIND:
            raise ValueError(
                f"kind must be {KIND!r} for a task with a trajectory, got {data['kind']!r}"
            )
        trajectory = Trajectory.from_dict(data["trajectory"])
        payload = Payload.from_dict(data["payload"]) if "payload" in data else None
        exerted = data.get("exerted")
        if "exerted" in data:  # null included, as for a static task's keys: leave a key out
            if exerted is None:
                raise ValueError(
                    "exerted must be a list of [fx, fy, fz, tx, ty, tz] rows, got None"
                )
            exerted = _exerted(exerted, trajectory.n_samples)
        f_max = check_f_max(data.get("f_max", 1.0))
        name = check_task_name(data.get("name", default_name), "'name'")
        from modquad_gym.tasks.files import check_meta

        meta = check_meta(data.get("meta", {}))
        return cls(trajectory, payload, exerted, f_max, name, meta)

    def save(self, path, force: bool = False, *, what: str = "path") -> Any:
        """Write the task as JSON (every derivative written: reading it back recomputes
        nothing). An existing file is replaced only with ``force=True`` (as every saver of the
        package; ``what`` as for :meth:`~modquad_gym.tasks.TaskRequirement.save`); a folder, a
        device or an unwritable place is refused. Returns the path."""
        import json
        from pathlib import Path

        from modquad_gym.core.outputs import check_output_file, write_text
        from modquad_gym.core.validation import check_flag, check_path

        check_path(path)
        force = check_flag(force, "force")
        if Path(path).suffix.lower() != ".json":
            raise ValueError(f"{path}: a dynamic task is saved as .json")
        text = json.dumps(self.to_dict()) + "\n"
        path = check_output_file(path, force=force, what=what)
        write_text(path, text)
        return path

    def __repr__(self) -> str:
        extra = f", payload={self.payload.mass:g} kg" if self.payload else ""
        extra += ", exerted" if self.exerted is not None else ""
        return (
            f"DynamicTask(name={self.name!r}, samples={self.n_wrenches}, "
            f"duration={self.trajectory.duration:g} s, f_max={self.f_max:g} N{extra})"
        )


def as_dynamic(task: object) -> DynamicTask:
    """``task`` when it is a :class:`DynamicTask` (what a flight along a trajectory needs),
    else a ValueError naming its type."""
    if not isinstance(task, DynamicTask):
        raise ValueError(f"task must be a DynamicTask, got {type(task).__name__}")
    return task


def check_scale(task: DynamicTask) -> None:
    """A ValueError naming the field whose numbers are beyond what a search handles (``f_max``
    is checked when the task is made, :func:`~modquad_gym.core.validation.check_f_max`): a
    part of the rotor wrenches (the motion's per kilogram and per unit of inertia, what the
    payload and the exerted wrenches add) not finite or beyond
    :data:`~modquad_gym.oracle.scale.MAX_TASK_VALUE`, in newtons or in units of f_max (the
    static tasks' bound, :func:`~modquad_gym.oracle.scale.check_task_scale`); a part within the
    bound in newtons and beyond it only in units of f_max names ``f_max`` (too small for the
    task). Checked when the task is made, so that a task file's error names the file."""
    from modquad_gym.oracle.scale import MAX_TASK_VALUE

    model = task.wrench_model
    parts = (
        ("exerted", task.exerted if task.exerted is not None else np.zeros((1, 6))),
        # the payload's part, once the exerted part passed: its force grows with the mass, its
        # torque with the offset too (a huge torque beside a sane force is the offset's)
        ("payload.mass", model.base[:, :3]),
        ("payload.offset", model.base[:, 3:]),
        ("trajectory (its accelerations)", model.per_mass),
        ("trajectory (its angular velocities and accelerations)", model.per_inertia),
    )
    for field, values in parts:
        with np.errstate(over="ignore", invalid="ignore"):
            newtons = np.abs(values).reshape(len(values), -1).max(axis=1, initial=0.0)
            size = np.maximum(newtons, newtons / task.f_max)
        bad = ~(size <= MAX_TASK_VALUE)
        if not bad.any():
            continue
        i = int(np.argmax(bad))
        if newtons[i] <= MAX_TASK_VALUE:  # a sane wrench, large only in units of a tiny f_max
            raise ValueError(
                f"f_max: {task.f_max:g} N is too small for this task: at sample {i + 1} the "
                f"rotor wrench from {field} is {newtons[i]:.3g} N, {size[i]:.3g} units of "
                f"f_max, beyond {MAX_TASK_VALUE:g} (check the units)"
            )
        raise ValueError(
            f"{field}: the rotor wrench at sample {i + 1} is {size[i]:.3g} (newtons, or "
            f"units of f_max = {task.f_max:g} N), beyond {MAX_TASK_VALUE:g}: far beyond "
            "what any structure can exert (check the units)"
        )


def lift_capacity(
    task: DynamicTask, modules: Sequence[ModuleType]
) -> tuple[np.ndarray, np.ndarray]:
    """(capacity (k,), demand (k,)) in newtons, per trajectory sample, along the specific force
    u = R^T (a + g e3) / |.|: a module of the best of ``modules`` adds at most ``capacity`` to
    the rotors' force along u beyond what its own mass needs (the support of its force zonotope
    along u minus m |R^T (a + g e3)|), while the payload and the exerted wrenches ask ``demand``
    along u. Whatever its shape, a structure of N modules flies the task only if
    ``N capacity >= demand`` at every sample (a necessary condition)."""
    model = task.wrench_model
    s = model.per_mass[:, :3]
    norm = np.linalg.norm(s, axis=1)
    u = s / np.where(norm > 0, norm, 1.0)[:, None]
    net = [
        np.maximum(u @ m.directions.T, 0.0).sum(axis=1) * task.f_max - m.mass * norm
        for m in modules
    ]
    return np.max(net, axis=0), np.einsum("ij,ij->i", u, model.base[:, :3])


def check_liftable(
    task: DynamicTask, modules: Sequence[ModuleType], limit: int = MAX_LIFT_MODULES
) -> int:
    """The fewest modules that can carry the task's weight along its trajectory by
    :func:`lift_capacity` (a lower bound, >= 1), or a ValueError naming ``f_max`` (the modules
    cannot carry themselves) or ``payload.mass`` (``exerted``) when no structure of at most
    ``limit`` modules of the given types can."""
    c, d = lift_capacity(task, modules)
    slack = 1e-9 * (1.0 + np.abs(d))
    pos = c > 0
    low = np.ceil(d[pos] / c[pos] - slack[pos]).max(initial=1.0)
    neg = c < 0
    high = np.floor(d[neg] / c[neg] + slack[neg]).min(initial=np.inf)
    stuck = bool(np.any(~pos & (d > slack)))
    if not stuck and low <= min(high, limit):
        return int(low)
    names = ", ".join(m.name for m in modules)
    if high < 1 or (stuck and not np.any(d > slack)):
        raise ValueError(
            f"f_max: {task.f_max:g} N per rotor cannot fly a module of type {names} along "
            f"{task.name!r}: its rotors cannot carry its own weight there"
        )
    field = "payload.mass" if task.payload is not None else "exerted"
    what = "the exerted wrenches are"
    if task.payload is not None:
        what = f"{task.payload.mass:g} kg is"
    raise ValueError(
        f"{field}: {what} more than any structure of up to {limit} modules of type {names} "
        f"can carry along {task.name!r} with f_max = {task.f_max:g} N"
    )
