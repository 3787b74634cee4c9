"""Structures: modules docked face to face on a square grid, and their configuration matrix.

A structure is a set of integer grid cells (x, y), one module per cell, of one module type or of
several (``modules=[...]``, one type per cell, in the order of the cells). Its frame {S} sits at
the centre of mass of the modules, each module's mass at its centre: the mass-weighted mean of
the module centres (the plain mean when every module weighs the same), with axes parallel to
every module's axes and z up. Cell (i, j) has its module centre at
((i - i_bar) * l, (j - j_bar) * l, 0). Every type in one structure has the same side l.

Structures are equal up to translation only, never up to rotation or reflection: task wrenches are
expressed in the body frame and the tilt pattern is not rotation-invariant. The translation key
of a mixed structure pairs each cell with its type.
"""

from __future__ import annotations

from collections.abc import Iterable
from functools import cached_property

import numpy as np

from modquad_gym.geometry.cells import (
    MAX_COORDINATE,
    NEIGHBOURS,
    Cell,
    Key,
    as_cell,
    check_connected,
    free_neighbours,
    is_connected,
    normalise,
    normalise_typed,
    structure_levels,
)
from modquad_gym.geometry.inertia import inertia_about_com
from modquad_gym.geometry.module import ModuleType, TModule

__all__ = [
    "MAX_COORDINATE",
    "NEIGHBOURS",
    "Cell",
    "Key",
    "Structure",
    "configuration_matrices",
    "free_neighbours",
    "is_connected",
    "mixed_configuration_matrices",
    "normalise",
    "normalise_typed",
    "structure_levels",
]

_DEFAULT_MODULE = TModule()


def _check_modules(modules: object, n: int) -> tuple[ModuleType, ...]:
    """One ModuleType per cell, all of one side; ValueError naming the problem."""
    if isinstance(modules, (str, ModuleType)):
        raise ValueError("modules must be a list of ModuleType, one per cell")
    try:
        mods = tuple(modules)  # type: ignore[arg-type]
    except TypeError:
        raise ValueError(f"modules must be a list of ModuleType, got {modules!r}") from None
    if len(mods) != n:
        raise ValueError(f"modules: got {len(mods)} types for {n} cells (one per cell)")
    for i, m in enumerate(mods):
        if not isinstance(m, ModuleType):
            raise ValueError(f"modules[{i}] must be a ModuleType, got {type(m).__name__}")
    sides = {m.side for m in mods}
    if len(sides) > 1:
        raise ValueError(f"modules: every type must have the same side, got {sorted(sides)}")
    return mods


class Structure:
    """Modules at integer grid cells, docked horizontally.

    Args:
        cells: integer (x, y) grid cells, one module each; must be non-empty, distinct and
            face-connected. Their order fixes the column order of the configuration matrix
            (module i owns columns 4i..4i+3).
        module: the module type of every cell (default: ``TModule()``, eta = pi/4).
        modules: instead of ``module``, one type per cell in the order of ``cells`` (a mixed
            structure). A list of one type repeated makes the homogeneous structure of that
            type (``module`` is then that type).

    Attributes:
        cells: the cells, in the order given.
        module: the type of every module, or None for a mixed structure.
        modules: the type of each module, in ``cells`` order.

    Raises:
        ValueError: naming the problem, for empty, duplicate, non-integer or disconnected cells,
            or for types that are not one per cell or differ in side.
    """

    __slots__ = ("cells", "module", "_mixed", "__dict__")

    def __init__(
        self,
        cells: Iterable[Cell],
        module: ModuleType | None = None,
        modules: Iterable[ModuleType] | None = None,
    ) -> None:
        if isinstance(cells, np.ndarray):
            cells = cells.tolist()
        if isinstance(cells, (str, bytes)) or not isinstance(cells, Iterable):
            raise ValueError(f"cells must be a list of (x, y) pairs, got {cells!r}")
        raw = list(cells)
        if not raw:
            raise ValueError("a structure needs at least one cell, got none")
        parsed = tuple(as_cell(c, i) for i, c in enumerate(raw, start=1))  # "cell #1": the first
        if len(set(parsed)) != len(parsed):
            dupes = sorted({c for c in parsed if parsed.count(c) > 1})
            raise ValueError(f"duplicate cells {dupes}: one module per cell")
        check_connected(parsed)
        if module is not None and not isinstance(module, ModuleType):
            raise ValueError(f"module must be a ModuleType, got {type(module).__name__}")
        mods = None
        if modules is not None:
            if module is not None:
                raise ValueError("give module= (one type) or modules= (one per cell), not both")
            mods = _check_modules(modules, len(parsed))
        self.cells: tuple[Cell, ...] = parsed
        self._set_types(module, mods)

    def _set_types(self, module: ModuleType | None, mods: tuple[ModuleType, ...] | None) -> None:
        if mods is not None and all(m is mods[0] for m in mods):
            module, mods = mods[0], None
        self.module: ModuleType | None = (
            None if mods is not None else module if module is not None else _DEFAULT_MODULE
        )
        self._mixed: tuple[ModuleType, ...] | None = mods

    @classmethod
    def from_trusted(
        cls,
        cells: tuple[Cell, ...],
        module: ModuleType | None = None,
        modules: tuple[ModuleType, ...] | None = None,
    ) -> Structure:
        """Build from cells (and types) already known to be valid (e.g. enumerated keys): no
        checks. For hot loops only; everything else should call ``Structure(cells)``."""
        self = cls.__new__(cls)
        self.cells = cells
        self._set_types(module, None if modules is None else tuple(modules))
        return self

    # --- identity -------------------------------------------------------------------------
    @property
    def n_modules(self) -> int:
        return len(self.cells)

    @property
    def is_mixed(self) -> bool:
        """True when the modules are not all of one type."""
        return self._mixed is not None

    @property
    def modules(self) -> tuple[ModuleType, ...]:
        """The type of each module, in ``cells`` order."""
        if self._mixed is not None:
            return self._mixed
        return (self.module,) * len(self.cells)  # type: ignore[return-value]

    @cached_property
    def palette(self) -> tuple[ModuleType, ...]:
        """The distinct types, in order of first appearance."""
        return tuple({id(m): m for m in self.modules}.values())

    @cached_property
    def type_indices(self) -> np.ndarray:
        """(n,) int: each module's index into :attr:`palette`."""
        index = {id(m): k for k, m in enumerate(self.palette)}
        return np.array([index[id(m)] for m in self.modules], dtype=np.int8)

    @property
    def side(self) -> float:
        """The module side l in metres (shared by every type of the structure)."""
        return (self.module or self.modules[0]).side

    @cached_property
    def masses(self) -> np.ndarray:
        """(n,) module masses in kg, in ``cells`` order."""
        return np.array([m.mass for m in self.modules])

    @property
    def mass(self) -> float:
        """Total mass of the modules in kg."""
        return float(self.masses.sum())

    @cached_property
    def inertia(self) -> np.ndarray:
        """(3, 3) inertia tensor in kg m^2 about the COM, {S} axes: each module's own inertia
        plus its parallel-axis term (:mod:`modquad_gym.geometry.inertia`). Read-only."""
        J = inertia_about_com(self.module_centres, self.masses, [m.inertia for m in self.modules])
        J.setflags(write=False)
        return J

    @cached_property
    def key(self) -> Key | tuple:
        """Translation-normalised key: the sorted cells shifted to min x = min y = 0, each
        paired with its type ``((x, y), type)`` for a mixed structure."""
        if self._mixed is None:
            return normalise(self.cells)
        return normalise_typed(self.cells, self._mixed)

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
        """Centre of mass in grid units (i_bar, j_bar): the mass-weighted mean of the cells
        (the plain mean when every module weighs the same)."""
        arr = np.asarray(self.cells, dtype=float)
        if self._mixed is None or np.all(self.masses == self.masses[0]):
            return float(arr[:, 0].mean()), float(arr[:, 1].mean())
        c = self.masses @ arr / self.masses.sum()
        return float(c[0]), float(c[1])

    @cached_property
    def module_centres(self) -> np.ndarray:
        """(n, 3) module centres in {S}, metres."""
        arr = np.asarray(self.cells, dtype=float) - np.asarray(self.com_cell)
        out = np.zeros((len(self.cells), 3))
        out[:, :2] = arr * self.side
        out.setflags(write=False)
        return out

    @cached_property
    def rotor_positions(self) -> np.ndarray:
        """(4n, 3) rotor positions p_k in {S}."""
        if self._mixed is None:
            return (self.module_centres[:, None, :] + self.module.positions[None]).reshape(-1, 3)
        return np.vstack([c + m.positions for c, m in zip(self.module_centres, self._mixed)])

    @cached_property
    def rotor_directions(self) -> np.ndarray:
        """(4n, 3) unit thrust directions R_k e3 in {S}."""
        if self._mixed is None:
            return np.tile(self.module.directions, (self.n_modules, 1))
        return np.vstack([m.directions for m in self._mixed])

    @cached_property
    def rotor_spins(self) -> np.ndarray:
        """(4n,) spin signs of the rotors."""
        return np.concatenate([m.spins for m in self.modules])

    @cached_property
    def rotor_c_tau(self) -> np.ndarray:
        """(4n,) drag-to-thrust ratio of each rotor's module, metres."""
        return np.concatenate([np.full(m.n_rotors, m.c_tau) for m in self.modules])

    def configuration_matrix(self) -> np.ndarray:
        """A, shape (6, 4n): column k is [d_k ; p_k x d_k + s_k c_tau d_k] (paper eq. 1), with
        each module's own rotor data.

        Per unit thrust: the feasible wrenches are {A u : 0 <= u <= f_max}. Torques are about the
        centre of mass (:attr:`com_cell`). The returned array is read-only and cached.
        """
        return self._A

    @cached_property
    def _A(self) -> np.ndarray:
        if self._mixed is None:
            A = configuration_matrices([self.cells], self.module)[0]
        elif len({m.n_rotors for m in self.palette}) == 1:
            cells = np.asarray(self.cells, dtype=float)[None]
            A = mixed_configuration_matrices(cells, self.type_indices[None], self.palette)[0]
        else:  # types with different rotor counts: module by module
            blocks = []
            for c, m in zip(self.module_centres, self._mixed):
                d = m.directions.T
                shift = np.stack([c[1] * d[2], -c[0] * d[2], c[0] * d[1] - c[1] * d[0]])
                blocks.append(np.vstack([d, m.columns[3:] + shift]))
            A = np.hstack(blocks)
        A.setflags(write=False)
        return A

    @cached_property
    def rank(self) -> int:
        """Rank of A = number of actuated degrees of freedom (ADOF)."""
        return int(np.linalg.matrix_rank(self._A, tol=1e-9))

    def is_torque_balanced(self, atol: float = 1e-9) -> bool:
        """True when equal thrust on every rotor gives zero torque (A . 1 has no torque)."""
        return bool(np.all(np.abs(self._A[3:].sum(axis=1)) <= atol))

    # --- growth ---------------------------------------------------------------------------
    def attachable_cells(self) -> list[Cell]:
        """Empty cells that share a face with the structure, sorted."""
        return free_neighbours(self.cells)

    def with_cells(self, *cells: Cell, module: ModuleType | None = None) -> Structure:
        """A new structure with modules added at ``cells``: of the structure's type, or of
        ``module`` (which a mixed structure needs)."""
        if module is None and self._mixed is None:
            return Structure(self.cells + tuple(cells), module=self.module)
        if module is None:
            raise ValueError("a mixed structure needs module= for the added cells")
        mods = self.modules + (module,) * len(cells)
        return Structure(self.cells + tuple(cells), modules=mods)

    def centrosymmetric_partner(self, cell: Cell) -> Cell | None:
        """The cell point-symmetric to ``cell`` about the COM, or None if off the grid."""
        x = 2 * self.com_cell[0] - cell[0]
        y = 2 * self.com_cell[1] - cell[1]
        rx, ry = round(x), round(y)
        if abs(x - rx) > 1e-9 or abs(y - ry) > 1e-9:
            return None
        return (int(rx), int(ry))

    def is_centrosymmetric(self) -> bool:
        """True when the cell set maps onto itself under point reflection about the COM (and,
        for a mixed structure, every module onto one of its own type)."""
        types = dict(zip(self.cells, map(id, self.modules)))
        for c in self.cells:
            partner = self.centrosymmetric_partner(c)
            if partner not in types or types[partner] != types[c]:
                return False
        return True

    # --- display --------------------------------------------------------------------------
    def to_text(self, mark: Cell | None = None) -> str:
        """A text drawing, y up: ``#`` a module, ``@`` the first (initial) module or ``mark``.
        A mixed structure shows each module's type as a letter (A = the first type of
        :attr:`palette`, ...; the marked module in lower case) and a legend line."""
        xs = [c[0] for c in self.cells]
        ys = [c[1] for c in self.cells]
        special = mark if mark is not None else self.cells[0]
        letters = None
        if self._mixed is not None:
            letters = {c: chr(65 + int(k)) for c, k in zip(self.cells, self.type_indices)}
        cells = set(self.cells)
        rows = []
        for y in range(max(ys), min(ys) - 1, -1):
            row = ""
            for x in range(min(xs), max(xs) + 1):
                if (x, y) not in cells:
                    row += "   "
                elif letters is not None:
                    ch = letters[(x, y)]
                    row += f"[{ch.lower() if (x, y) == special else ch}]"
                else:
                    row += "[@]" if (x, y) == special else "[#]"
            rows.append(row.rstrip())
        if letters is not None:
            rows.append(", ".join(f"{chr(65 + k)} = {m.name}" for k, m in enumerate(self.palette)))
        return "\n".join(rows)

    def __repr__(self) -> str:
        head = f"Structure(n_modules={self.n_modules}, cells={list(self.cells)}"
        if self._mixed is not None:
            return f"{head}, modules={[m.name for m in self._mixed]})"
        return head + ")"

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


def mixed_configuration_matrices(
    cells: np.ndarray, types: np.ndarray, palette: tuple[ModuleType, ...] | list[ModuleType]
) -> np.ndarray:
    """Configuration matrices of many mixed structures of equal size: (L, 6, r n), eq. (1).

    ``cells`` (L, n, 2) grid cells, ``types`` (L, n) indices into ``palette`` (types of one
    side and one rotor count; :meth:`Structure.configuration_matrix` also mixes rotor counts).
    Module i of structure l contributes its type's own columns plus c x d for its centre c,
    taken from the structure's centre of mass (each module's mass at its centre): the same as
    :func:`configuration_matrices` with one type, up to round-off."""
    cells = np.asarray(cells, dtype=float)
    types = np.asarray(types, dtype=np.intp)
    L, n, _ = cells.shape
    side = palette[0].side
    cols = np.stack([m.columns for m in palette])  # (K, 6, r)
    masses = np.array([m.mass for m in palette])[types]  # (L, n)
    com = np.einsum("ln,lnk->lk", masses, cells) / masses.sum(axis=1)[:, None]
    centres = (cells - com[:, None, :]) * side  # (L, n, 2)
    C = cols[types]  # (L, n, 6, r)
    d = C[:, :, :3, :]
    cx = centres[:, :, 0, None]
    cy = centres[:, :, 1, None]
    torque = C[:, :, 3:, :] + np.stack(
        [cy * d[:, :, 2], -cx * d[:, :, 2], cx * d[:, :, 1] - cy * d[:, :, 0]], axis=2
    )
    A = np.concatenate([d, torque], axis=2)  # (L, n, 6, r)
    return np.ascontiguousarray(A.transpose(0, 2, 1, 3).reshape(L, 6, n * cols.shape[2]))
