"""The free-faces action encoding: dock at one of the structure's free faces, in a fixed order.

The free faces of a structure are the empty cells 4-adjacent to it: at most 2 n + 2 for n
modules. They are listed in the grid's row-major order (by y, then x, relative to the initial
module at (0, 0)), and action ``a = k * F + i`` docks a module of palette type k at the i-th free
face (``a = i`` for one type), with F = 2 n_max + 2 slots, so every structure's faces fit. Slots
beyond the current faces are invalid (masked). The action count grows linearly with n_max (130
slots at n_max 64, against 16,129 cells of the grid encoding), and each action's row of
``"candidates"`` (flat, ``obs["candidates"].reshape(n_actions, k)``; k is
``env.encoding.width(env.lookahead)``) describes its docking, so a policy can score the
candidates with shared weights at any size (rows of empty slots are zero).

Candidate rows (float32, ``FACE_FEATURES`` per action, each in [-1, 1]):

0. and 1. the face's offset from the structure's centre of cells, x and y, divided by R + 1
   (R the largest |x| or |y| offset of a module from that centre, so a face lies within +-1);
2. the fraction of its four neighbours that hold a module (1/4 to 1);
3. to 10. whether each of its eight neighbours holds a module (east, north-east, north,
   north-west, west, south-west, south, south-east);

then, with K > 1 types, the one-hot of the action's type (K entries), and with ``lookahead``
the child structure's lookahead row as in the grid encoding (:mod:`.lookahead`: five support
features, one support evaluation per candidate; eight with ``lookahead="exact"``).
"""

from __future__ import annotations

from operator import attrgetter

import numpy as np

from modquad_gym.core.jit import njit
from modquad_gym.envs.assembly.features import (
    AssemblyFeatures,
    ObservationBlock,
    lookahead_width,
)
from modquad_gym.envs.assembly.grid import Grid
from modquad_gym.envs.assembly.lookahead import candidate_rows
from modquad_gym.envs.assembly.types import AssemblyState, Episode
from modquad_gym.geometry.structure import Cell

FACE_FEATURES = 11
"""Geometric entries per candidate row (the module docstring lists them)."""
RING = ((1, 0), (1, 1), (0, 1), (-1, 1), (-1, 0), (-1, -1), (0, -1), (1, -1))
"""The eight neighbours of a face, in the order of the candidate rows."""


class Faces:
    """The free-faces encoding for ``n_max`` modules and ``n_types`` types.

    Attributes:
        slots: F = 2 n_max + 2, the candidate slots per type.
        n_actions: F * n_types.
        block: actions per type (F): action a docks type ``a // block``.
        grid: the grid the faces are indexed on (radius n_max + 1: every face and its ring).
        initial_mask: int8 (n_actions,), the valid actions of the one-module start.
    """

    name = "faces"

    def __init__(self, n_max: int, n_types: int = 1) -> None:
        self.n_max = n_max
        self.n_types = n_types
        self.slots = self.block = 2 * n_max + 2
        self.n_actions = self.slots * n_types
        self.grid = Grid(n_max + 2)  # radius n_max + 1
        g = self.grid
        self.xy = np.array([g.cell(c) for c in range(g.n_cells)], dtype=np.float64)
        self.ring = np.array([dy * g.side + dx for dx, dy in RING])
        self.initial_mask = self._mask(4)
        self.initial_faces = np.flatnonzero(self.grid.initial_mask)  # sorted grid indices

    def _mask(self, n_faces: int) -> np.ndarray:
        mask = np.zeros((self.n_types, self.slots), dtype=np.int8)
        mask[:, :n_faces] = 1
        return mask.reshape(-1)

    # --- the encoding's part in the transitions (see :mod:`.transitions`) ---------------------
    def initial_fields(self, types: tuple[int, ...]) -> dict:
        """The state fields of the one-module start."""
        occ = np.zeros(self.grid.n_cells, dtype=np.int8)
        occ[self.grid.centre] = 1
        sites = np.array([self.grid.centre])
        return {"occupancy": occ, "faces": self.initial_faces.copy(), "sites": sites,
                "mask": self.initial_mask.copy()}  # fmt: skip

    def decode(self, state: AssemblyState, a: int) -> tuple[Cell, int]:
        """(cell, type index) of action ``a`` (a valid one) in ``state``."""
        k, i = divmod(a, self.slots)
        return self.grid.cell(int(state.faces[i])), k

    def docked_fields(self, state: AssemblyState, a: int) -> dict:
        """The state fields that action ``a`` (valid) changes: the faces are updated around
        the docked cell (no scan of the grid: the hot path)."""
        c = int(state.faces[a % self.slots])
        occ, faces = _dock(state.occupancy, state.faces, c, self.grid.side)
        sites = np.append(state.sites, c)
        return {"occupancy": occ, "faces": faces, "sites": sites, "mask": self._mask(len(faces))}

    def candidates(
        self, ep: Episode, state: AssemblyState, bounds: dict | None = None
    ) -> np.ndarray:
        """The candidate rows (n_actions, k) of ``state`` (module docstring); ``bounds``: see
        :func:`~.lookahead.candidate_rows`."""
        geo = self._geometry(state)
        rows = np.zeros((self.n_types, self.slots, self.width(ep.rules.lookahead)), np.float32)
        rows[:, : len(geo), :FACE_FEATURES] = geo
        if self.n_types > 1:
            for k in range(self.n_types):
                rows[k, : len(geo), FACE_FEATURES + k] = 1.0
        rows = rows.reshape(self.n_actions, -1)
        if ep.rules.lookahead:
            rows[:, -lookahead_width(ep.rules.lookahead) :] = candidate_rows(ep, state, bounds)
        return rows

    def _geometry(self, state: AssemblyState) -> np.ndarray:
        """(faces, FACE_FEATURES): the geometric entries of the current faces."""
        return _geometry(state.sites, state.faces, state.occupancy, self.xy, self.ring)

    def width(self, lookahead: bool | str) -> int:
        """Entries per candidate row."""
        types = self.n_types if self.n_types > 1 else 0
        return FACE_FEATURES + types + lookahead_width(lookahead)

    def valid_cells(self, state: AssemblyState) -> set[Cell]:
        """The cells where a module may dock now."""
        return {self.grid.cell(int(c)) for c in state.faces}

    def blocks(
        self, features: AssemblyFeatures, n_types: int, lookahead: bool | str
    ) -> list[ObservationBlock]:
        """``"action_mask"``, ``"candidates"`` (n_actions * k, flat as SB3 expects: reshape to
        (n_actions, k)), ``"task"``, ``"structure"``."""
        return [
            ObservationBlock("action_mask", self.n_actions, attrgetter("mask"), 0, 1, np.int8),
            ObservationBlock("candidates", self.n_actions * self.width(lookahead), _rows),
            ObservationBlock("task", features.task_size, attrgetter("task.vec")),
            ObservationBlock("structure", features.structure_size, attrgetter("structure_vec")),
        ]

    # --- cells <-> actions in a state ---------------------------------------------------------
    def state_action_of(self, state: AssemblyState | None, cell: Cell, type_index: int) -> int:
        """The action docking ``type_index`` at ``cell`` in ``state`` (None: the one-module
        start); ValueError when ``cell`` is not a free face there."""
        g, faces = self.grid, self._faces(state)
        if max(abs(int(cell[0])), abs(int(cell[1]))) <= g.radius:
            hit = np.flatnonzero(faces == g.action_of(cell))
            if len(hit):
                return int(type_index) * self.slots + int(hit[0])
        raise ValueError(f"cell {tuple(cell)} is not a free face of the structure")

    def state_cell_of(self, state: AssemblyState | None, action: int) -> Cell:
        """The cell of ``action`` in ``state`` (None: the one-module start); ValueError for a
        slot beyond the faces."""
        faces, i = self._faces(state), int(action) % self.slots
        if i >= len(faces):
            raise ValueError(f"action {action}: slot {i} holds no face (there are {len(faces)})")
        return self.grid.cell(int(faces[i]))

    def _faces(self, state: AssemblyState | None) -> np.ndarray:
        return self.initial_faces if state is None else state.faces

    def type_of(self, action: int) -> int:
        """The palette index of the type that ``action`` docks."""
        return int(action) // self.slots


def _rows(state: AssemblyState) -> np.ndarray:
    return state.candidates.reshape(-1)


@njit(cache=True)
def _dock(occupancy, faces, c, side):  # pragma: no cover - compiled
    """(occupancy, faces) after a module docks at grid cell ``c``, one of the sorted ``faces``:
    ``c`` leaves them, each empty neighbour of ``c`` that touched no module before joins them.
    Cells lie at most n_max - 1 from the centre of a grid of radius n_max + 1, so every index
    looked at is on the grid."""
    occ = occupancy.copy()
    occ[c] = 1
    steps = np.array([1, -1, side, -side])
    new = np.empty(4, faces.dtype)
    m = 0
    for s in steps:
        b = c + s
        if occ[b]:
            continue
        touches = False
        for t in steps:
            if b + t != c and occ[b + t]:
                touches = True
        if not touches:
            new[m] = b
            m += 1
    new = np.sort(new[:m])
    out = np.empty(len(faces) - 1 + m, faces.dtype)
    i = j = n = 0
    while i < len(faces) or j < m:
        if i < len(faces) and faces[i] == c:
            i += 1
        elif j == m or (i < len(faces) and faces[i] < new[j]):
            out[n] = faces[i]
            i += 1
            n += 1
        else:
            out[n] = new[j]
            j += 1
            n += 1
    return occ, out


@njit(cache=True)
def _geometry(sites, faces, occ, xy, ring):  # pragma: no cover - compiled
    """The geometric candidate rows (module docstring) of ``faces`` for modules at ``sites``
    (grid indices), ``xy`` the cells' coordinates, ``ring`` the index offsets of the 8
    neighbours."""
    n = len(sites)
    cx = cy = 0.0
    for s in sites:
        cx += xy[s, 0]
        cy += xy[s, 1]
    cx /= n
    cy /= n
    reach = 0.0
    for s in sites:
        reach = max(reach, abs(xy[s, 0] - cx), abs(xy[s, 1] - cy))
    reach += 1.0
    out = np.empty((len(faces), FACE_FEATURES), dtype=np.float32)
    for j in range(len(faces)):
        f = faces[j]
        out[j, 0] = (xy[f, 0] - cx) / reach
        out[j, 1] = (xy[f, 1] - cy) / reach
        count = 0.0
        for r in range(8):
            v = float(occ[f + ring[r]])
            out[j, 3 + r] = v
            if r % 2 == 0:
                count += v
        out[j, 2] = count / 4.0
    return out
