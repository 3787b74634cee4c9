"""The grid action encoding of the assembly environment: cells <-> actions and the mask.

A grid of G x G cells (G = 2 n_max - 1) centred on the initial module at (0, 0); cell (x, y) has
index ``(y + n_max - 1) * G + (x + n_max - 1)``, and with K module types the action of type k at
cell c is ``k * G * G + c`` (type-major). A cell is a valid action when it is empty and
4-adjacent to the structure. (:mod:`.faces` is the other encoding: the free faces only.)
"""

from __future__ import annotations

import numpy as np

from modquad_gym.envs.assembly.features import (
    AssemblyFeatures,
    ObservationBlock,
    observation_blocks,
)
from modquad_gym.envs.assembly.lookahead import candidate_rows
from modquad_gym.envs.assembly.types import AssemblyState, Episode
from modquad_gym.geometry.structure import Cell

STEPS = ((1, 0), (-1, 0), (0, 1), (0, -1))
"""The four grid neighbours."""


class Grid:
    """Cell indices, neighbours and masks of a grid for ``n_max`` modules and ``n_types`` types.

    Attributes:
        radius: n_max - 1, the largest |x| or |y|.
        side: G.
        n_cells: G * G.
        n_actions: G * G * n_types.
        centre: the index of cell (0, 0).
        initial_mask: int8 (n_actions,), the valid actions of the one-module start.
        block: actions per type (n_cells): action a docks type ``a // block``.
    """

    name = "grid"

    def __init__(self, n_max: int, n_types: int = 1) -> None:
        self.n_max = n_max
        self.radius = r = n_max - 1
        self.side = G = 2 * n_max - 1
        self.n_cells = G * G
        self.n_actions = G * G * n_types
        self.centre = self.n_cells // 2
        self.block = self.n_cells
        self._cells = [self.cell_of(c) for c in range(G * G)]  # index -> (x, y)
        self._neighbours = [  # index -> indices of its grid neighbours
            [self.action_of((x + dx, y + dy)) for dx, dy in STEPS
             if max(abs(x + dx), abs(y + dy)) <= r]
            for x, y in self._cells
        ]  # fmt: skip
        self.initial_mask = np.zeros(self.n_actions, dtype=np.int8)
        for b in self._neighbours[self.centre]:
            self.initial_mask[b :: self.n_cells] = 1

    def action_of(self, cell: Cell, type_index: int = 0) -> int:
        """The action that docks a module of type ``type_index`` at ``cell`` (x, y): type-major,
        ``type_index * n_cells`` plus the cell index; ValueError off the grid."""
        x, y = int(cell[0]), int(cell[1])
        if max(abs(x), abs(y)) > self.radius:
            raise ValueError(f"cell {cell} lies outside the grid [-{self.radius}, {self.radius}]^2")
        return int(type_index) * self.n_cells + (y + self.radius) * self.side + (x + self.radius)

    def type_of(self, action: int) -> int:
        """The type index of ``action``."""
        return int(action) // self.n_cells

    def cell_of(self, action: int) -> Cell:
        """The grid cell (x, y) of ``action`` (of any type)."""
        y, x = divmod(int(action) % self.n_cells, self.side)
        return (x - self.radius, y - self.radius)

    def cell(self, index: int) -> Cell:
        """The cell (x, y) of a cell index (a table look-up: the hot path)."""
        return self._cells[index]

    def initial_occupancy(self) -> np.ndarray:
        """int8 (n_cells,): the one-module start."""
        occ = np.zeros(self.n_cells, dtype=np.int8)
        occ[self.centre] = 1
        return occ

    def dock(self, occupancy: np.ndarray, mask: np.ndarray, c: int) -> tuple[np.ndarray, ...]:
        """(occupancy, mask) after a module docks at cell index ``c``: new arrays."""
        G2 = self.n_cells
        occ = occupancy.copy()
        occ[c] = 1
        mask = mask.copy()
        mask[c::G2] = 0
        for b in self._neighbours[c]:
            if not occ[b]:
                mask[b::G2] = 1
        return occ, mask

    # --- the encoding's part in the transitions (see :mod:`.transitions`) ---------------------
    def initial_fields(self, types: tuple[int, ...]) -> dict:
        """The state fields of the one-module start (of type ``types[0]`` with a palette)."""
        onehot = None
        if types:
            onehot = np.zeros(self.n_actions, dtype=np.int8)
            onehot[types[0] * self.n_cells + self.centre] = 1
        return {"occupancy": self.initial_occupancy(), "mask": self.initial_mask.copy(),
                "types_onehot": onehot}  # fmt: skip

    def decode(self, state: AssemblyState, a: int) -> tuple[Cell, int]:
        """(cell, type index) of action ``a``."""
        return self._cells[a % self.n_cells], a // self.n_cells

    def docked_fields(self, state: AssemblyState, a: int) -> dict:
        """The state fields that action ``a`` (valid) changes in the encoding."""
        mask = state.mask if state.free is None else state.free  # not the lookahead's shortlist
        occ, mask = self.dock(state.occupancy, mask, a % self.n_cells)
        onehot = state.types_onehot
        if onehot is not None:
            onehot = onehot.copy()
            onehot[a] = 1
        return {"occupancy": occ, "mask": mask, "types_onehot": onehot}

    def candidates(
        self, ep: Episode, state: AssemblyState, bounds: dict | None = None
    ) -> np.ndarray | None:
        """The lookahead rows of the valid actions, in action order (``lookahead`` on), else
        None: every other row is zero, and a state kept by a planner should not hold G * G of
        them (the observation fills them in, :func:`~.features.observation_blocks`).
        ``bounds``: see :func:`~.lookahead.candidate_rows`."""
        if not ep.rules.lookahead:
            return None
        return candidate_rows(ep, state, bounds)[state.mask.view(bool)]  # mask: 0 or 1

    def valid_cells(self, state: AssemblyState) -> set[Cell]:
        """The cells where a module may dock now (any type)."""
        cell_mask = state.mask.reshape(-1, self.n_cells).any(axis=0)
        return {self._cells[c] for c in np.flatnonzero(cell_mask)}

    def blocks(
        self, features: AssemblyFeatures, n_types: int, lookahead: bool | str
    ) -> list[ObservationBlock]:
        """The observation's blocks (:func:`~.features.observation_blocks`)."""
        return observation_blocks(self.n_cells, n_types, features, lookahead)

    def state_action_of(self, state: AssemblyState | None, cell: Cell, type_index: int) -> int:
        """The action docking ``type_index`` at ``cell`` (the same in every state)."""
        return self.action_of(cell, type_index)

    def state_cell_of(self, state: AssemblyState | None, action: int) -> Cell:
        """The cell of ``action`` (the same in every state)."""
        return self.cell_of(action)
