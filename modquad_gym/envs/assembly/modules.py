"""The module set of an assembly environment: one module type, or a palette of several.

The env takes it as a part (``modules=``, as Jumanji takes a generator): it says how structures
of its types are keyed, weighed, decided and named, and which type the first module has.

* :class:`OneType` (``modules=None``, the default): every module is ``module``; actions are grid
  cells; tasks of kind ``total`` only (the mass is never needed).
* :class:`Palette` (``modules=[mA, mB, ...]`` or stock names ``"t45,t45m,flat"``,
  :func:`modquad_gym.geometry.module.palette`): each action docks a module *of a type* (see
  :mod:`.grid` for the type-major action layout); the observation adds ``"types"`` (several
  types); tasks of kind ``external`` are decided on the rotor wrenches ``w + M g e_z`` of the
  current structure's mass M, so heavier structures must lift more; ``info`` adds ``modules``
  (each module's type name, in ``cells`` order) and ``mass_kg``. The first module's type is
  ``initial_type`` (default 0; ``"random"`` draws it with the env's generator at each reset;
  ``reset(options={"initial_type": k})``, k an index or ``"random"``, for one episode). A
  structure is reachable from a start exactly when it holds a module of the start's type.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from modquad_gym.envs.assembly.evaluator import MixedStructureEvaluator, StructureEvaluator
from modquad_gym.geometry.module import ModuleType, check_module, palette
from modquad_gym.geometry.structure import Cell, Structure, normalise_typed

__all__ = ["OneType", "Palette", "make_module_set"]


class OneType:
    """Every module of one type.

    Attributes:
        module: the type.
        n_types: 1.
        palette: None (no type choice in actions or observations).
        self_weight: False: tasks of kind ``external`` are refused.
    """

    n_types = 1
    palette = None
    self_weight = False
    reset_options: tuple[str, ...] = ()  # the reset options of the module set: none

    def __init__(self, module: ModuleType | None = None) -> None:
        module = check_module(module, optional=True)
        self.module = module if module is not None else Structure([(0, 0)]).module

    def key(self, cells: tuple[Cell, ...], types: tuple[int, ...]) -> Any:
        """The evaluator's key of the structure: translation-normalised cells, the same tuple
        as :func:`~modquad_gym.geometry.cells.normalise` (in fewer steps: the hot path)."""
        xs, ys = zip(*cells)
        x0, y0 = min(xs), min(ys)
        return tuple(sorted(zip([x - x0 for x in xs], [y - y0 for y in ys])))

    def mass(self, types: tuple[int, ...]) -> float:
        """0: one type decides ``total`` tasks only, where the mass is not needed."""
        return 0.0

    def child_mass(self, mass: float, type_index: int) -> float:
        """The mass after docking a module of ``type_index`` to a structure of ``mass``."""
        return mass

    def evaluator(
        self, n_max: int, f_max: float, n_directions: int, method: str
    ) -> StructureEvaluator:
        """A new evaluator for structures of these types."""
        return StructureEvaluator(self.module, n_max, f_max, n_directions, method)

    def check_options(self, options: dict) -> dict:
        """The reset ``options`` (no key of its own to check)."""
        return options

    def start(self, options: dict, rng: np.random.Generator) -> tuple[int, ...]:
        """The first module's types field: () for one type."""
        return ()

    def structure(self, cells: tuple[Cell, ...], types: tuple[int, ...]) -> Structure:
        """The :class:`~modquad_gym.geometry.structure.Structure` of (cells, types)."""
        return Structure(list(cells), module=self.module)

    def info(self, types: tuple[int, ...]) -> dict:
        """The extra ``info`` entries of a structure of these types: none."""
        return {}


class Palette:
    """Several module types of one side and rotor count; the type of each module is chosen.

    Args:
        modules: :class:`~modquad_gym.geometry.module.ModuleType` objects or stock names
            (``"t45,t45m,flat"`` or ``["t45", "flat"]``); None: ``["t45"]``.
        initial_type: the first module's type index, or ``"random"``.

    Attributes:
        palette: the types, in the order of the actions.
        n_types: their number K.
        module: the first type (its single-module support normalises the features).
        self_weight: True: tasks of kind ``external`` add the structure's weight.
    """

    self_weight = True
    reset_options = ("initial_type",)  # reset(options={"initial_type": k}): one episode's start

    def __init__(self, modules: Any = None, initial_type: Any = 0) -> None:
        types = palette(modules if modules is not None else ["t45"])
        if len({m.side for m in types}) > 1 or len({m.n_rotors for m in types}) > 1:
            raise ValueError("modules: every type must have the same side and rotor count")
        self.palette: list[ModuleType] = types
        self.n_types = len(types)
        self.module = types[0]
        self.masses = np.array([m.mass for m in types])
        self.initial_type = self.check_type(initial_type, "initial_type", allow_random=True)

    def check_type(self, value: Any, what: str, allow_random: bool = False) -> int | str:
        """``value`` as a type index (or ``"random"``); ValueError naming ``what`` otherwise."""
        if allow_random and value == "random":
            return "random"
        if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, np.integer)):
            raise ValueError(f"{what} must be a type index (or 'random'), got {value!r}")
        if not 0 <= int(value) < self.n_types:
            raise ValueError(f"{what} must lie in [0, {self.n_types}), got {value!r}")
        return int(value)

    def key(self, cells: tuple[Cell, ...], types: tuple[int, ...]) -> Any:
        """The evaluator's key: translation-normalised cells, each with its type."""
        return normalise_typed(cells, (self.palette[t] for t in types))

    def mass(self, types: tuple[int, ...]) -> float:
        """The total mass (kg) of modules of ``types``."""
        return float(self.masses[list(types)].sum())

    def child_mass(self, mass: float, type_index: int) -> float:
        """The mass after docking a module of ``type_index`` to a structure of ``mass``."""
        return mass + self.masses[type_index]

    def evaluator(
        self, n_max: int, f_max: float, n_directions: int, method: str
    ) -> StructureEvaluator:
        """A new evaluator for typed structures of this palette."""
        return MixedStructureEvaluator(self.palette, n_max, f_max, n_directions, method)

    def check_options(self, options: dict) -> dict:
        """The reset ``options`` with ``initial_type`` checked (a type index, ``"random"`` as
        the constructor takes it, or None: the env's); ValueError naming it otherwise."""
        if options.get("initial_type") is not None:
            options["initial_type"] = self.check_type(
                options["initial_type"], "options['initial_type']", allow_random=True
            )
        return options

    def start(self, options: dict, rng: np.random.Generator) -> tuple[int, ...]:
        """The first module's type, as a one-element types field: the checked reset option
        ``initial_type`` or the env's (drawn with ``rng`` when ``"random"``)."""
        start = options.get("initial_type")
        if start is None:
            start = self.initial_type
        if start == "random":
            start = int(rng.integers(self.n_types))
        return (int(start),)

    def structure(self, cells: tuple[Cell, ...], types: tuple[int, ...]) -> Structure:
        """The typed :class:`~modquad_gym.geometry.structure.Structure` of (cells, types)."""
        return Structure(list(cells), modules=[self.palette[t] for t in types])

    def info(self, types: tuple[int, ...]) -> dict:
        """``modules`` (type names in cells order) and ``mass_kg``."""
        return {"modules": [self.palette[t].name for t in types], "mass_kg": self.mass(types)}


def make_module_set(module: Any, modules: Any, initial_type: Any) -> OneType | Palette:
    """The env's module set from its ``module``, ``modules`` and ``initial_type`` arguments:
    ``modules`` may also be a ready :class:`OneType` or :class:`Palette`."""
    if isinstance(modules, (OneType, Palette)):
        if module is not None or initial_type is not None:
            raise ValueError("a module set given as modules= carries its own types and start")
        return modules
    if modules is None:
        if initial_type is not None:
            raise ValueError("initial_type needs a palette: give modules=[...] too")
        return OneType(module)
    if module is not None:
        raise ValueError("give module= (one type) or modules= (a palette), not both")
    return Palette(modules, 0 if initial_type is None else initial_type)
