"""Structures: modules docked face to face on a square grid, and their configuration matrix.

A structure is a set of integer grid cells (x, y), one module per cell, all of one module type.
Its frame {S} sits at the centre of mass of the module centres (all modules weigh the same), with
axes parallel to every module's axes and z up. Cell (i, j) has its module centre at
((i - i_bar) * l, (j - j_bar) * l, 0).

Structures are equal up to translation only, never up to rotation or reflection: task wrenches are
expressed in the body frame and the tilt pattern is not rotation-invariant.
"""

from __future__ import annotations

from collections.abc import Iterable, Iterator
from functools import cached_property

import numpy as np

from .module import ModuleType, TModule

Cell = tuple[int, int]
Key = tuple[Cell, ...]

NEIGHBOURS: tuple[Cell, ...] = ((1, 0), (-1, 0), (0, 1), (0, -1))

_DEFAULT_MODULE = TModule()


def _as_cell(raw: object, index: int) -> Cell:
    try:
        x, y = raw  # type: ignore[misc]
    except (TypeError, ValueError):
        raise ValueError(f"cell #{index} {raw!r} is not a pair (x, y)") from None
    out = []
    for v in (x, y):
        if isinstance(v, (bool, np.bool_)) or not isinstance(
            v, (int, np.integer, float, np.floating)
        ):
            raise ValueError(f"cell #{index} {raw!r} must hold integers, got {type(v).__name__}")
        if float(v) != int(v):
            raise ValueError(f"cell #{index} {raw!r} must hold integers, got {v!r}")
        out.append(int(v))
    return (out[0], out[1])


def normalise(cells: Iterable[Cell]) -> Key:
    """Translation-normalised key: cells shifted so min x = min y = 0, sorted."""
    cells = list(cells)
    x0 = min(c[0] for c in cells)
    y0 = min(c[1] for c in cells)
    return tuple(sorted((x - x0, y - y0) for x, y in cells))


def is_connected(cells: Iterable[Cell]) -> bool:
    """True when the cells form one face-connected group."""
    cells = set(cells)
    if not cells:
        return False
    start = next(iter(cells))
    seen, stack = {start}, [start]
    while stack:
        x, y = stack.pop()
        for dx, dy in NEIGHBOURS:
            nb = (x + dx, y + dy)
            if nb in cells and nb not in seen:
                seen.add(nb)
                stack.append(nb)
    return len(seen) == len(cells)


def free_neighbours(cells: Iterable[Cell]) -> list[Cell]:
    """Empty cells 4-adjacent to ``cells`` (where a module can dock), sorted."""
    cells = set(cells)
    return sorted({(x + dx, y + dy) for x, y in cells for dx, dy in NEIGHBOURS} - cells)


class Structure:
    """Modules of one type at integer grid cells, docked horizontally.

    Args:
        cells: integer (x, y) grid cells, one module each; must be non-empty, distinct and
            face-connected. Their order fixes the column order of the configuration matrix
            (module i owns columns 4i..4i+3).
        module: the module type of every cell (default: ``TModule()``, eta = pi/4).

    Raises:
        ValueError: naming the problem, for empty, duplicate, non-integer or disconnected cells.
    """

    __slots__ = ("cells", "module", "__dict__")

    def __init__(self, cells: Iterable[Cell], module: ModuleType | None = None) -> None:
        if isinstance(cells, np.ndarray):
            cells = cells.tolist()
        raw = list(cells)
        if not raw:
            raise ValueError("a structure needs at least one cell, got none")
        parsed = tuple(_as_cell(c, i) for i, c in enumerate(raw))
        if len(set(parsed)) != len(parsed):
            dupes = sorted({c for c in parsed if parsed.count(c) > 1})
            raise ValueError(f"duplicate cells {dupes}: one module per cell")
        if not is_connected(parsed):
            raise ValueError(
                f"cells {list(parsed)} are not face-connected: modules dock side by side"
            )
        self.cells: tuple[Cell, ...] = parsed
        self.module: ModuleType = module if module is not None else _DEFAULT_MODULE

    @classmethod
    def from_trusted(cls, cells: tuple[Cell, ...], module: ModuleType | None = None) -> Structure:
        """Build from cells already known to be valid (e.g. enumerated keys): no checks.
        For hot loops only; everything else should call ``Structure(cells)``."""
        self = cls.__new__(cls)
        self.cells = cells
        self.module = module if module is not None else _DEFAULT_MODULE
        return self

    # --- identity -------------------------------------------------------------------------
    @property
    def n_modules(self) -> int:
        return len(self.cells)

    @cached_property
    def key(self) -> Key:
        """Translation-normalised key (sorted cells shifted to min x = min y = 0)."""
        return normalise(self.cells)

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, Structure):
            return NotImplemented
        return self.key == other.key and self.module is other.module

    def __hash__(self) -> int:
        return hash((self.key, id(self.module)))

    def __len__(self) -> int:
        return len(self.cells)

    # --- geometry -------------------------------------------------------------------------
    @cached_property
    def com_cell(self) -> tuple[float, float]:
        """Centre of mass in grid units (i_bar, j_bar)."""
        arr = np.asarray(self.cells, dtype=float)
        return float(arr[:, 0].mean()), float(arr[:, 1].mean())

    @cached_property
    def module_centres(self) -> np.ndarray:
        """(n, 3) module centres in {S}, metres."""
        arr = np.asarray(self.cells, dtype=float) - np.asarray(self.com_cell)
        out = np.zeros((len(self.cells), 3))
        out[:, :2] = arr * self.module.side
        out.setflags(write=False)
        return out

    @cached_property
    def rotor_positions(self) -> np.ndarray:
        """(4n, 3) rotor positions p_k in {S}."""
        return (self.module_centres[:, None, :] + self.module.positions[None]).reshape(-1, 3)

    @cached_property
    def rotor_directions(self) -> np.ndarray:
        """(4n, 3) unit thrust directions R_k e3 in {S}."""
        return np.tile(self.module.directions, (self.n_modules, 1))

    def configuration_matrix(self) -> np.ndarray:
        """A, shape (6, 4n): column k is [d_k ; p_k x d_k + s_k c_tau d_k] (paper eq. 1).

        Per unit thrust: the feasible wrenches are {A u : 0 <= u <= f_max}. Torques are about the
        COM of the module centres. The returned array is read-only and cached.
        """
        return self._A

    @cached_property
    def _A(self) -> np.ndarray:
        A = configuration_matrices([self.cells], self.module)[0]
        A.setflags(write=False)
        return A

    @cached_property
    def rank(self) -> int:
        """Rank of A = number of actuated degrees of freedom (ADOF)."""
        return int(np.linalg.matrix_rank(self._A, tol=1e-9))

    @property
    def actuated_dof(self) -> int:
        return self.rank

    def is_torque_balanced(self, atol: float = 1e-9) -> bool:
        """True when equal thrust on every rotor gives zero torque (A . 1 has no torque)."""
        return bool(np.all(np.abs(self._A[3:].sum(axis=1)) <= atol))

    # --- growth ---------------------------------------------------------------------------
    def attachable_cells(self) -> list[Cell]:
        """Empty cells that share a face with the structure, sorted."""
        return free_neighbours(self.cells)

    def with_cells(self, *cells: Cell) -> Structure:
        """A new structure with modules added at ``cells`` (same module type)."""
        return Structure(self.cells + tuple(cells), module=self.module)

    def centrosymmetric_partner(self, cell: Cell) -> Cell | None:
        """The cell point-symmetric to ``cell`` about the COM, or None if off the grid."""
        x = 2 * self.com_cell[0] - cell[0]
        y = 2 * self.com_cell[1] - cell[1]
        rx, ry = round(x), round(y)
        if abs(x - rx) > 1e-9 or abs(y - ry) > 1e-9:
            return None
        return (int(rx), int(ry))

    def is_centrosymmetric(self) -> bool:
        """True when the cell set maps onto itself under point reflection about the COM."""
        cells = set(self.cells)
        return all(self.centrosymmetric_partner(c) in cells for c in self.cells)

    # --- display --------------------------------------------------------------------------
    def to_text(self, mark: Cell | None = None) -> str:
        """A text drawing, y up: ``#`` a module, ``@`` the first (initial) module or ``mark``."""
        xs = [c[0] for c in self.cells]
        ys = [c[1] for c in self.cells]
        special = mark if mark is not None else self.cells[0]
        cells = set(self.cells)
        rows = []
        for y in range(max(ys), min(ys) - 1, -1):
            row = ""
            for x in range(min(xs), max(xs) + 1):
                row += "[@]" if (x, y) == special else "[#]" if (x, y) in cells else "   "
            rows.append(row.rstrip())
        return "\n".join(rows)

    def __repr__(self) -> str:
        return f"Structure(n_modules={self.n_modules}, cells={list(self.cells)})"

    def __str__(self) -> str:
        return f"{self!r}\n{self.to_text()}"


def configuration_matrices(keys: list[Key], module: ModuleType | None = None) -> np.ndarray:
    """Configuration matrices of many structures of equal size at once: (L, 6, 4n), eq. (1).

    Column k of structure l is [d_k ; p_k x d_k + s_k c_tau d_k] with p_k the rotor position
    relative to the COM of the module centres: the module's own columns plus c x d for its
    centre c (c_z = 0). ``Structure.configuration_matrix()`` is this function on one structure;
    batches are the exhaustive search's hot loop."""
    module = module if module is not None else _DEFAULT_MODULE
    cells = np.asarray(keys, dtype=float)  # (L, n, 2)
    L, n, _ = cells.shape
    centres = (cells - cells.mean(axis=1, keepdims=True)) * module.side  # (L, n, 2)
    d = module.directions  # (r, 3)
    r = d.shape[0]
    cx = centres[:, :, None, 0]
    cy = centres[:, :, None, 1]
    # c x d with c_z = 0: (c_y d_z, -c_x d_z, c_x d_y - c_y d_x)
    shift = np.stack([cy * d[:, 2], -cx * d[:, 2], cx * d[:, 1] - cy * d[:, 0]], axis=-1)
    A = np.empty((L, 6, n * r))
    A[:, :3, :] = np.tile(module.columns[:3], n)
    A[:, 3:, :] = np.tile(module.columns[3:], n) + shift.reshape(L, n * r, 3).transpose(0, 2, 1)
    return A


def structure_levels(n_max: int) -> Iterator[list[Key]]:
    """Yield, for n = 1..n_max, every connected structure of n modules up to translation (the
    fixed polyominoes: 1, 2, 6, 19, 63, 216, 760, 2725, 9910, 36446, ...) as keys, in the
    canonical order of :mod:`modquad_gym.polyominoes`. Each level is a list: for small n only;
    the searches stream levels in chunks instead."""
    from .polyominoes import PolyominoStream

    for n in range(1, n_max + 1):
        yield [normalise(map(tuple, c.tolist())) for b in PolyominoStream(n) for c in b]
