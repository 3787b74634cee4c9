"""Grid cells: integer (x, y) pairs, one module each, and the functions on sets of them.

The building blocks of :mod:`modquad_gym.geometry.structure` and of the searches: checking a cell,
translation-normalised keys (structures are equal up to translation only), face-connectivity,
the free cells a module can dock at, and the enumeration of every connected cell set of n cells.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Iterator
from typing import TYPE_CHECKING

import numpy as np

from modquad_gym.core.validation import check_int

if TYPE_CHECKING:
    from modquad_gym.geometry.module import ModuleType

Cell = tuple[int, int]
Key = tuple[Cell, ...]

NEIGHBOURS: tuple[Cell, ...] = ((1, 0), (-1, 0), (0, 1), (0, -1))

MAX_COORDINATE = 1_000_000
"""Largest |x| or |y| of a grid cell (cells are stored as 32-bit integers in the hot loops)."""

MAX_MODULES = 128
"""The searches' module limit (structures of up to 512 rotors): beyond the field's largest
designs (Li & Koeppl 2026: up to 90 modules). Defined here, below the tasks, so that the task
generators and the command line refuse the sizes the searches do
(:data:`modquad_gym.search.problem.MAX_MODULES` is this number)."""

EXACT_MODULES = 16
"""The exhaustive search's module limit: level 16 holds 1.0e8 structures, level 17 4.0e8 (the
limit of :func:`structure_levels` too; :data:`modquad_gym.search.problem.EXACT_MODULES`)."""


def as_cell(raw: object, index: int) -> Cell:
    """Cell #``index`` (1-based, as the rows of a task file) as an (x, y) pair of ints;
    ValueError naming it when it is not a pair of integral numbers within +-MAX_COORDINATE."""
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
        if isinstance(v, (float, np.floating)) and not (math.isfinite(v) and float(v).is_integer()):
            raise ValueError(f"cell #{index} {raw!r} must hold integers, got {v!r}")
        if abs(int(v)) > MAX_COORDINATE:
            raise ValueError(
                f"cell #{index} {raw!r}: coordinates must lie within +-{MAX_COORDINATE:,}"
            )
        out.append(int(v))
    return (out[0], out[1])


def normalise(cells: Iterable[Cell]) -> Key:
    """Translation-normalised key: cells shifted so min x = min y = 0, sorted."""
    cells = list(cells)
    x0 = min(c[0] for c in cells)
    y0 = min(c[1] for c in cells)
    return tuple(sorted((x - x0, y - y0) for x, y in cells))


def normalise_typed(cells: Iterable[Cell], modules: Iterable[ModuleType]) -> tuple:
    """Translation-normalised key of a mixed structure: ``((x, y), type)`` pairs, cells
    shifted so min x = min y = 0, sorted by cell."""
    cells = list(cells)
    x0 = min(c[0] for c in cells)
    y0 = min(c[1] for c in cells)
    pairs = (((x - x0, y - y0), m) for (x, y), m in zip(cells, modules, strict=True))
    return tuple(sorted(pairs, key=lambda p: p[0]))


def packed_key(cells: Iterable[Cell], types: Iterable[int]) -> bytes:
    """The structure of ``cells`` with palette indices ``types``, up to translation, as compact
    bytes (int16 rows (x, y, type), sorted by cell): the caches of the searches' candidates hold
    many (a 64-module structure takes 384 bytes)."""
    rows = np.column_stack([np.array(list(cells), dtype=np.int32).reshape(-1, 2),
                            np.array(list(types), dtype=np.int32)])  # fmt: skip
    rows[:, :2] -= rows[:, :2].min(axis=0)
    return rows[np.lexsort((rows[:, 1], rows[:, 0]))].astype(np.int16).tobytes()


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


def parts(cells: Iterable[Cell]) -> list[list[Cell]]:
    """The face-connected parts of ``cells``, each in the order of ``cells``; the parts in the
    order of their first cells (the first cell's part first)."""
    cells = list(cells)
    taken, label = set(cells), {}
    out: list[list[Cell]] = []
    for c in cells:
        if c in label:
            continue
        label[c], stack = len(out), [c]
        while stack:
            x, y = stack.pop()
            for dx, dy in NEIGHBOURS:
                nb = (x + dx, y + dy)
                if nb in taken and nb not in label:
                    label[nb] = len(out)
                    stack.append(nb)
        out.append([])
    for c in cells:
        out[label[c]].append(c)
    return out


def check_connected(cells: tuple[Cell, ...]) -> None:
    """A ValueError unless ``cells`` are face-connected, naming the first cell (1-based, in the
    order given) not connected to cell #1 and the sizes of the parts (short for any count)."""
    if is_connected(cells):
        return
    split = parts(cells)
    first = cells.index(split[1][0])
    sizes = ", ".join(str(len(p)) for p in split[:5]) + (", ..." if len(split) > 5 else "")
    raise ValueError(
        f"cells are not face-connected (modules dock side by side): cell #{first + 1} "
        f"{cells[first]} is not connected to cell #1 {cells[0]}; {len(split)} parts ({sizes} "
        "cells)"
    )


def free_neighbours(cells: Iterable[Cell]) -> list[Cell]:
    """Empty cells 4-adjacent to ``cells`` (where a module can dock), sorted."""
    cells = set(cells)
    return sorted({(x + dx, y + dy) for x, y in cells for dx, dy in NEIGHBOURS} - cells)


def random_cells(rng: np.random.Generator, n: int) -> list[Cell]:
    """A random connected structure of ``n`` modules grown from (0, 0): each new module docks at
    a uniformly chosen free neighbour. Cells in growth order (the first is the initial module)."""
    if n < 1:
        raise ValueError(f"a structure needs n >= 1 modules, got {n}")
    cells: list[Cell] = [(0, 0)]
    taken, frontier = {(0, 0)}, set(free_neighbours(cells))  # kept as cells grow
    while len(cells) < n:
        free = sorted(frontier)  # = free_neighbours(cells), without rebuilding it
        cell = free[int(rng.integers(len(free)))]
        cells.append(cell)
        taken.add(cell)
        frontier.discard(cell)
        frontier.update(c for c in free_neighbours([cell]) if c not in taken)
    return cells


def structure_levels(n_max: int) -> Iterator[list[Key]]:
    """Yield, for n = 1..n_max, every connected structure of n modules up to translation (the
    fixed polyominoes: 1, 2, 6, 19, 63, 216, 760, 2725, 9910, 36446, ...) as keys, in the
    canonical order of :mod:`.polyominoes`. Each level is a list: for small n only;
    the searches stream levels in chunks instead. ``n_max`` is checked at the call, as the
    exhaustive search checks it (an integer in 1..:data:`EXACT_MODULES`, else a ValueError)."""
    return _levels(check_int(n_max, "n_max", 1, EXACT_MODULES))


def _levels(n_max: int) -> Iterator[list[Key]]:
    from modquad_gym.geometry.polyominoes import PolyominoStream  # numba: imported on first use

    for n in range(1, n_max + 1):
        yield [normalise(map(tuple, c.tolist())) for b in PolyominoStream(n) for c in b]
