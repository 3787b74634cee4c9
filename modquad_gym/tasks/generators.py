"""Seeded task generators behind one interface, :class:`TaskGenerator` (``name`` and
``__call__(rng) -> TaskRequirement``): :class:`PaperTasks` (paper Sec. VI, errata 2),
:class:`PlantedTasks` (wrenches inside a hidden structure's zonotope, so the optimum is bounded),
:class:`PlantedMixedTasks` (the same in a mixed structure), :class:`ScrewdriverTask` (paper
Fig. 1), :class:`FixedTasks` and :class:`MixedTasks`.

A generator checks its arguments when it is made (a ValueError naming the argument), against
the limits ``modquad task generate`` and the searches apply: at most
:data:`~modquad_gym.geometry.cells.MAX_MODULES` modules and
:data:`~modquad_gym.tasks.wrenches.MAX_WRENCHES` wrenches, an f_max in 1e-300..1e12 and
wrenches the searches take (:func:`~modquad_gym.oracle.scale.check_scale_bound`); a planted
task's scale is known once drawn, and checked then. A call takes a ``numpy.random.Generator``."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Protocol, runtime_checkable

import numpy as np

from modquad_gym.core.validation import check_f_max, check_int, check_name, check_real, check_rng
from modquad_gym.dynamics import DynamicTask
from modquad_gym.geometry.cells import MAX_MODULES, random_cells
from modquad_gym.geometry.module import GRAVITY, ModuleType, check_module, palette
from modquad_gym.geometry.structure import Structure
from modquad_gym.oracle.scale import check_scale_bound, check_task_scale
from modquad_gym.tasks.requirement import TaskRequirement
from modquad_gym.tasks.wrenches import MAX_WRENCHES, check_kind


@runtime_checkable
class TaskGenerator(Protocol):
    """Anything with a ``name`` that draws a task from a numpy Generator (deterministic under
    the generator's seed)."""

    name: str

    def __call__(self, rng: np.random.Generator) -> TaskRequirement: ...


Count = int | tuple[int, int]


def _check_count(value: object, what: str, low: int = 1, high: int | None = None) -> None:
    """A ValueError naming ``what`` unless ``value`` is an int, or an inclusive (lo, hi) pair of
    ints, within [low, high] (:func:`~modquad_gym.core.validation.check_int`)."""
    if isinstance(value, (tuple, list)) and len(value) == 2:
        lo, hi = (check_int(v, what, low, high) for v in value)
        if lo > hi:
            raise ValueError(f"{what} must satisfy {low} <= lo <= hi, got {value!r}")
    elif isinstance(value, (int, np.integer)) and not isinstance(value, bool):
        check_int(value, what, low, high)
    else:
        raise ValueError(f"{what} must be an int or an inclusive (lo, hi) pair, got {value!r}")


def _draw_count(rng: np.random.Generator, value: Count) -> int:
    if isinstance(value, (int, np.integer)):
        return int(value)
    lo, hi = value
    return int(rng.integers(lo, hi + 1))


def _in_scale(W: np.ndarray, f_max: float) -> np.ndarray:
    """W, or a ValueError naming f_max when the searches would refuse the drawn wrenches
    (:func:`~modquad_gym.oracle.scale.check_task_scale`, the rule ``task generate`` applies)."""
    try:
        return check_task_scale(W, f_max)
    except ValueError as exc:
        raise ValueError(f"f_max = {f_max:g}: {exc}") from None


FZ_READINGS = ("abs", "shift", "literal")


EXTERNAL_F_MAX = 2.0
"""Rotor thrust limit (N) of the named ``external`` generators (``paper-external``,
``planted-external``, ...; ``modquad task generate --task-kind external``): a task in SI units
the modules must also lift themselves in, and with 0.3 kg modules a flat module lifts 8 N
against its 2.94 N weight, a T-module 5.66 N (at the classes' default of 1 N a T-module, 2.83
N, cannot lift itself)."""


@dataclass(frozen=True)
class PaperTasks:
    """Random tasks as in the paper's Sec. VI, with errata 2 resolved.

    The paper draws every component from U(-0.5, 0.5) and multiplies f_z by 30. Read literally
    half the wrenches have f_z < 0, which upward rotors never produce. Each component here is
    u ~ U(-scale, scale); f_x, f_y and the torques are u, and f_z is, by ``fz_reading``:

    ``"abs"`` (default)
        f_z = fz_offset + fz_gain * |u|, uniform on [fz_offset, fz_offset + fz_gain * scale].
    ``"shift"``
        f_z = fz_offset + fz_gain * (u + scale), uniform on [fz_offset, fz_offset + 2 fz_gain
        scale].
    ``"literal"``
        f_z = fz_offset + fz_gain * u (as written; mostly infeasible, for completeness).

    Why the defaults are not the paper's numbers (fz_offset=0, fz_gain=30): a wrench with small
    f_z cannot carry the lateral force and torque the other components ask for. For a T-module
    (eta = pi/4) every rotor's horizontal thrust is at most its vertical thrust / sqrt(2), so
    |f_x|, |f_y| <= f_z / sqrt(2) for *every* structure. With f_z = 30 |u| about 2.4 % of
    wrenches violate this, so a task of 80 wrenches is infeasible for every structure with
    probability about 98 %; the f_z = 15 wrenches alone also need >= 6 modules of lift
    (4 n cos(pi/4) = 2.83 n). The defaults ``fz_offset=3, fz_gain=12`` keep the paper's spirit
    (a gravity offset plus uniform noise, f_z on [3, 9]) and give exhaustive optima of 4-5
    modules (the paper reports 4). ``PaperTasks(fz_offset=0, fz_gain=30)`` is the literal paper.

    ``kind="external"`` labels the same wrenches as external (the rotors add the structure's
    weight; SI units, so choose ``f_max`` in newtons: the named ``paper-external`` has
    :data:`EXTERNAL_F_MAX`).
    """

    n_wrenches: Count = 80
    scale: float = 0.5
    fz_gain: float = 12.0
    fz_reading: str = "abs"
    fz_offset: float = 3.0
    f_max: float = 1.0
    name: str = "paper"
    kind: str = "total"

    def __post_init__(self) -> None:
        _check_count(self.n_wrenches, "n_wrenches", high=MAX_WRENCHES)
        scale = check_real(self.scale, "scale", positive=True)
        gain = check_real(self.fz_gain, "fz_gain", positive=True)
        offset = check_real(self.fz_offset, "fz_offset", low=0.0)
        if not isinstance(self.fz_reading, str) or self.fz_reading not in FZ_READINGS:
            raise ValueError(
                f"fz_reading must be one of {', '.join(FZ_READINGS)}, got {self.fz_reading!r}"
            )
        largest = max(scale, offset + gain * scale * (2 if self.fz_reading == "shift" else 1))
        check_scale_bound(largest, self.f_max, "scale, fz_gain, fz_offset")
        check_name(self.name)
        check_kind(self.kind)

    def __call__(self, rng: np.random.Generator) -> TaskRequirement:
        t = _draw_count(check_rng(rng), self.n_wrenches)
        W = rng.uniform(-self.scale, self.scale, size=(t, 6))
        u = W[:, 2]
        if self.fz_reading == "abs":
            W[:, 2] = self.fz_offset + self.fz_gain * np.abs(u)
        elif self.fz_reading == "shift":
            W[:, 2] = self.fz_offset + self.fz_gain * (u + self.scale)
        else:
            W[:, 2] = self.fz_offset + self.fz_gain * u
        meta = {"generator": "paper", "fz_reading": self.fz_reading}
        return TaskRequirement(
            W, name=f"{self.name}-{self.fz_reading}", f_max=self.f_max, meta=meta, kind=self.kind
        )


@dataclass(frozen=True)
class PlantedTasks:
    """Tasks with a known feasible structure: wrenches drawn inside a hidden structure's zonotope.

    A random connected structure of n modules (n uniform in ``n_modules``, grown by
    :func:`random_cells`) is drawn; each wrench is ``A u``. Interior wrenches use
    u ~ U(0, f_max)^m. A ``boundary_fraction`` of them start from the support point of a random
    direction d (u_j = f_max where d . a_j > 0, else 0: the vertex of W that maximises d . w) and
    keep each entry with probability ``p_extreme`` (else redraw it uniformly), which lands on or
    near vertices and faces of W. (A random 0/f_max input would not do: with 4n > 6 rotors most
    such inputs map to interior wrenches.)
    Every entry is then clipped to [slack, 1 - slack] * f_max, so the hidden structure's margin
    (:func:`modquad_gym.oracle.margin`) is >= 2 * slack: feasible beyond any solver tolerance.
    Hence the optimum is <= n. The task's name is the generator's ``name`` alone (``"planted"``):
    it says nothing of the answer. ``meta`` holds ``planted_cells`` (growth order) and
    ``optimum_upper_bound``: hidden, for benchmarks (a solver must not read them; the
    environment shows neither); see :func:`planted_structure`.

    With ``kind="external"`` the hidden structure's weight is subtracted (w = A u - m g e_z), so
    it still produces exactly the rotor wrenches A u and the optimum stays <= n.
    """

    n_modules: Count = (2, 6)
    n_wrenches: Count = (8, 80)
    boundary_fraction: float = 0.5
    module: ModuleType | None = None
    f_max: float = 1.0
    p_extreme: float = 0.8
    slack: float = 1e-3
    name: str = "planted"
    kind: str = "total"

    def __post_init__(self) -> None:
        _check_count(self.n_modules, "n_modules", high=MAX_MODULES)
        _check_count(self.n_wrenches, "n_wrenches", high=MAX_WRENCHES)
        check_real(self.boundary_fraction, "boundary_fraction", low=0.0, high=1.0)
        check_real(self.p_extreme, "p_extreme", low=0.0, high=1.0)
        if not 0.0 <= check_real(self.slack, "slack") < 0.5:
            raise ValueError(f"slack must lie in [0, 0.5), got {self.slack!r}")
        check_module(self.module, optional=True)
        check_f_max(self.f_max)
        check_name(self.name)
        check_kind(self.kind)

    def __call__(self, rng: np.random.Generator) -> TaskRequirement:
        n = _draw_count(check_rng(rng), self.n_modules)
        t = _draw_count(rng, self.n_wrenches)
        cells = random_cells(rng, n)
        hidden = Structure(cells, module=self.module)
        A = hidden.configuration_matrix()
        m = A.shape[1]
        U = rng.uniform(0.0, 1.0, size=(t, m))
        boundary = rng.random(t) < self.boundary_fraction
        # support points: u_j = 1 where d . a_j > 0 maximises d . w over W, a vertex of W
        D = rng.normal(size=(t, 6))
        vertex = (D @ A > 0).astype(float)
        extreme = boundary[:, None] & (rng.random((t, m)) < self.p_extreme)
        U = np.where(extreme, vertex, U)
        U = np.clip(U, self.slack, 1.0 - self.slack) * self.f_max
        W = U @ A.T
        if self.kind == "external":
            W[:, 2] -= hidden.mass * GRAVITY
        meta = {
            "generator": "planted",
            "planted_cells": [list(c) for c in cells],
            "optimum_upper_bound": n,
            "n_boundary": int(boundary.sum()),
        }
        W = _in_scale(W, self.f_max)
        return TaskRequirement(W, name=self.name, f_max=self.f_max, meta=meta, kind=self.kind)


def planted_structure(task: TaskRequirement, module: ModuleType | None = None) -> Structure | None:
    """The hidden structure of a planted task (from ``meta["planted_cells"]``), else None."""
    cells = task.meta.get("planted_cells")
    return None if cells is None else Structure([tuple(c) for c in cells], module=module)


@dataclass(frozen=True)
class ScrewdriverTask:
    """The paper's Fig. 1 task: hold a screwdriver, align it, then drive a screw about z.

    Two wrenches (normalised units, f_max = 1 per rotor, newtons and newton-metres):

    * w1, translation and alignment: ``[push, 0, lift, 0, align, 0]`` - a forward force that
      moves the tool tip onto the screw head, the hover lift, and a small pitch torque that
      keeps the shaft aligned against the tool's offset weight;
    * w2, driving: ``[0, 0, lift + press, 0, 0, torque]`` - the driving torque about the
      vertical screw axis, while pressing the bit onto the screw with ``press`` extra lift.

    Defaults (lift 3.0 = hover of a small structure and tool, push 0.8, align 0.1, torque 0.5,
    press 0.5) are feasible for a few modules and for no single module; the optimum, by
    exhaustive search, is small (see ``examples/README.md``). ``__call__`` ignores the rng.
    ``kind="external"`` labels the wrenches as applied to the tool (SI units; the rotors add the
    structure's weight), with ``lift`` then the tool's weight and the press.
    """

    push: float = 0.8
    torque: float = 0.5
    lift: float = 3.0
    align: float = 0.1
    press: float = 0.5
    f_max: float = 1.0
    name: str = "screwdriver"
    kind: str = "total"

    def __post_init__(self) -> None:
        for what in ("push", "torque", "lift", "align", "press"):
            check_real(getattr(self, what), what)
        if self.lift <= 0 or self.lift + self.press <= 0:
            raise ValueError(f"lift must be positive (rotors push up), got {self.lift!r}")
        values = (self.push, self.torque, self.lift, self.align, self.lift + self.press)
        largest = max(abs(float(v)) for v in values)
        check_scale_bound(largest, self.f_max, "push, torque, lift, align, press")
        check_name(self.name)
        check_kind(self.kind)

    def task(self) -> TaskRequirement:
        W = np.array(
            [
                [self.push, 0.0, self.lift, 0.0, self.align, 0.0],
                [0.0, 0.0, self.lift + self.press, 0.0, 0.0, self.torque],
            ]
        )
        return TaskRequirement(
            W, name=self.name, f_max=self.f_max, meta={"generator": "screwdriver"}, kind=self.kind
        )

    def __call__(self, rng: np.random.Generator) -> TaskRequirement:
        check_rng(rng)  # drawn from nothing, but the same door as every generator
        return self.task()


@dataclass(frozen=True)
class FixedTasks:
    """Given tasks, one drawn uniformly at random per call (deterministic under the seed):
    static (:class:`TaskRequirement`) or dynamic (:class:`~modquad_gym.dynamics.DynamicTask`,
    whose wrenches depend on the structure)."""

    tasks: tuple[TaskRequirement | DynamicTask, ...]
    name: str = "fixed"

    def __post_init__(self) -> None:
        object.__setattr__(self, "tasks", tuple(self.tasks))
        if not self.tasks or not all(
            isinstance(t, (TaskRequirement, DynamicTask)) for t in self.tasks
        ):
            raise ValueError(
                "FixedTasks needs a non-empty sequence of tasks (TaskRequirement, DynamicTask)"
            )
        check_name(self.name)

    def __call__(self, rng: np.random.Generator) -> TaskRequirement | DynamicTask:
        check_rng(rng)
        if len(self.tasks) == 1:
            return self.tasks[0]
        return self.tasks[int(rng.integers(len(self.tasks)))]


@dataclass(frozen=True)
class MixedTasks:
    """Draws a generator (by ``weights``, uniform by default), then a task from it."""

    generators: tuple[TaskGenerator, ...]
    weights: tuple[float, ...] | None = None
    name: str = "mixed"

    def __post_init__(self) -> None:
        gens = tuple(self.generators)
        object.__setattr__(self, "generators", gens)
        if not gens or not all(isinstance(g, TaskGenerator) for g in gens):
            raise ValueError("MixedTasks needs a non-empty sequence of task generators")
        if self.weights is not None:
            w = tuple(float(x) for x in self.weights)
            if len(w) != len(gens):
                raise ValueError(f"got {len(w)} weights for {len(gens)} generators")
            if not all(x >= 0 and math.isfinite(x) for x in w) or sum(w) <= 0:
                raise ValueError(f"weights must be >= 0, finite and not all zero, got {w}")
            object.__setattr__(self, "weights", w)
        check_name(self.name)

    def __call__(self, rng: np.random.Generator) -> TaskRequirement:
        check_rng(rng)
        if self.weights is None:
            k = int(rng.integers(len(self.generators)))
        else:
            p = np.asarray(self.weights) / sum(self.weights)
            k = int(rng.choice(len(self.generators), p=p))
        return self.generators[k](rng)


@dataclass(frozen=True)
class PlantedMixedTasks:
    """Tasks planted in a random mixed structure: ``n_modules`` cells (uniform in the range),
    each of a module type drawn uniformly from ``modules`` (stock names, comma-separated); 40
    wrenches ``A u`` with half the entries of u near 0 or f_max (vertex-like) and the rest
    uniform in [0.02, 0.98] f_max. An ``external`` task has the hidden structure's weight
    subtracted from f_z, so that structure still satisfies it: the palette's optimum is at most
    the hidden size."""

    modules: str = "t45,t45m,flat"
    n_modules: Count = (3, 6)
    n_wrenches: int = 40
    kind: str = "total"
    f_max: float = 1.0
    name: str = "planted-mixed"

    def __post_init__(self) -> None:
        _check_count(self.n_modules, "n_modules", high=MAX_MODULES)
        check_int(self.n_wrenches, "n_wrenches", low=1, high=MAX_WRENCHES)
        palette(self.modules)  # a ValueError naming modules
        check_kind(self.kind)
        check_f_max(self.f_max)
        check_name(self.name)

    def __call__(self, rng: np.random.Generator) -> TaskRequirement:
        check_rng(rng)
        types = palette(self.modules)
        lo, hi = (
            (self.n_modules, self.n_modules) if isinstance(self.n_modules, int) else self.n_modules
        )
        n = int(rng.integers(lo, hi + 1))
        cells = random_cells(rng, n)
        hidden = Structure(cells, modules=[types[int(rng.integers(len(types)))] for _ in cells])
        A = hidden.configuration_matrix()
        U = rng.uniform(0.02, 0.98, size=(self.n_wrenches, A.shape[1]))
        vertex = rng.random(U.shape) < 0.5
        U[vertex] = np.where(rng.random(int(vertex.sum())) < 0.5, 0.02, 0.98)
        W = (U * self.f_max) @ A.T
        if self.kind == "external":
            W[:, 2] -= hidden.mass * GRAVITY
        meta = {
            "hidden_cells": [list(c) for c in cells],
            "hidden_modules": [m.name for m in hidden.modules],
            "optimum_upper_bound": n,
        }
        W = _in_scale(W, self.f_max)
        return TaskRequirement(W, name=self.name, f_max=self.f_max, kind=self.kind, meta=meta)
