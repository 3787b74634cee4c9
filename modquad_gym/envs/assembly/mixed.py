"""``ModQuadAssembly-v0`` with several module types: each action docks a module *of a type*.

``gym.make("ModQuadAssembly-v0", modules=[mA, mB, ...])`` (types, or stock names such as
``"t45,t45m,flat"``, :func:`modquad_gym.geometry.module.palette`) builds this environment; without
``modules`` the one-type environment, its spaces and its episodes are unchanged.

Spaces (G = 2 n_max - 1 grid cells a side, K types, the palette order fixed at construction):

* action ``Discrete(G * G * K)``: ``a = k * G * G + c`` docks a module of type k at grid cell
  c (c indexed as in the one-type environment: ``c = (y + n_max - 1) G + (x + n_max - 1)``);
  ``action_of(cell, k)`` and ``cell_of(a)``, ``type_of(a)`` convert. A valid action's cell is
  empty and adjacent; every type of a valid cell is valid. The masks (``action_masks()``,
  ``obs["action_mask"]``, ``info["action_mask"]``) have G * G * K entries, type-major
  (``mask.reshape(K, G * G)[k]`` is the cell mask of type k). Invalid actions never raise.
* observation: the one-type entries (``"occupancy"``, ``"task"``, ``"structure"``; the
  structure features are those of the mixed structure's own configuration matrix, normalised
  with the first type's single-module support) plus ``"types"`` (G * G * K,) in {0, 1},
  type-major one-hot: ``types.reshape(K, G * G)[k, c]`` is 1 when cell c holds a type-k module.
  With ``lookahead=True`` ``"candidates"`` has one row per (type, cell) action.

Starting state: one module at (0, 0) of type ``initial_type`` (default 0, the first type; an
int, or ``"random"`` to draw it with the env's generator at each reset; ``reset(options=
{"initial_type": k})`` for one episode). A structure is reachable from a start exactly when it
holds a module of the start's type (any connected structure can be grown from any of its cells).

Tasks of kind ``external`` are decided on the rotor wrenches ``w + M g e_z`` of the current
structure's mass M (:func:`modquad_gym.tasks.rotor_wrenches`), so heavier structures must lift
more; ``total`` tasks as in the one-type environment. ``info`` also carries ``modules`` (the
type name of each module, in ``cells`` order) and ``mass_kg``.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from modquad_gym.envs.assembly.env import ModQuadAssemblyEnv
from modquad_gym.envs.assembly.evaluator import MixedStructureEvaluator, StructureEvaluator
from modquad_gym.geometry.module import ModuleType, palette
from modquad_gym.geometry.structure import Cell, Structure, normalise_typed

__all__ = ["MixedAssemblyEnv"]


class MixedAssemblyEnv(ModQuadAssemblyEnv):
    """Assemble a structure of several module types (module docstring); every other argument
    is that of :class:`~modquad_gym.envs.assembly.env.ModQuadAssemblyEnv`.

    Args:
        modules: the palette: a list of :class:`~modquad_gym.geometry.ModuleType` (one side), or
            stock names (``"t45,t45m,flat"`` or ``["t45", "flat"]``).
        initial_type: the first module's type index, or ``"random"``.
    """

    decides_self_weight = True

    def __init__(self, *args: Any, modules: Any = None, initial_type: Any = 0, **kwargs: Any):
        if kwargs.get("module") is not None:
            raise ValueError("give module= (one type) or modules= (a palette), not both")
        types = palette(modules if modules is not None else ["t45"])
        if len({m.side for m in types}) > 1 or len({m.n_rotors for m in types}) > 1:
            raise ValueError("modules: every type must have the same side and rotor count")
        self.palette: list[ModuleType] = types
        self._masses = np.array([m.mass for m in types])
        self.initial_type = self._check_type(initial_type, "initial_type", allow_random=True)
        kwargs["module"] = types[0]
        super().__init__(*args, **kwargs)

    def _check_type(self, value: Any, what: str, allow_random: bool = False) -> int | str:
        if allow_random and value == "random":
            return "random"
        if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, np.integer)):
            raise ValueError(f"{what} must be a type index (or 'random'), got {value!r}")
        if not 0 <= int(value) < len(self.palette):
            raise ValueError(f"{what} must lie in [0, {len(self.palette)}), got {value!r}")
        return int(value)

    # --- hooks ----------------------------------------------------------------------------
    def _n_types(self) -> int:
        return len(self.palette)

    def _new_evaluator(self, f_max: float) -> StructureEvaluator:
        return MixedStructureEvaluator(
            self.palette, self.n_max, f_max, self.n_directions, self.oracle_method
        )

    def _key(self, cells: tuple[Cell, ...], types: tuple[int, ...]) -> Any:
        return normalise_typed(cells, (self.palette[t] for t in types))

    def _mass(self, types: tuple[int, ...]) -> float:
        return float(self._masses[list(types)].sum())

    def _start(self, options: dict) -> dict:
        start = options.pop("initial_type", None)
        if start is not None:
            start = self._check_type(start, "options['initial_type']")
        else:
            start = self.initial_type
        if start == "random":
            start = int(self.np_random.integers(self.n_types))
        onehot = np.zeros(self._n_actions, dtype=np.float32)
        onehot[start * self._n_cells + self._centre] = 1.0
        return {"types": (int(start),), "types_onehot": onehot}

    # --- grid <-> actions -----------------------------------------------------------------
    def action_of(self, cell: Cell, type_index: int = 0) -> int:
        """The action that docks a module of palette type ``type_index`` at ``cell``."""
        return self.grid.action_of(cell, type_index)

    def type_of(self, action: int) -> int:
        """The palette index of the type that ``action`` docks."""
        return self.grid.type_of(action)

    # --- state ----------------------------------------------------------------------------
    @property
    def structure(self) -> Structure:
        """The current structure (cells in docking order, each with its type)."""
        s = self._require("asking for the structure")
        return Structure(list(s.cells), modules=[self.palette[t] for t in s.types])

    def _info(self, invalid: bool = False, terms: dict[str, float] | None = None) -> dict:
        info = super()._info(invalid, terms)
        info["modules"] = [self.palette[t].name for t in self._state.types]
        info["mass_kg"] = self._mass(self._state.types)
        return info
