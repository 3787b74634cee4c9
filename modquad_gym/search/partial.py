"""Searching only among the structures that contain a given partial structure.

``exhaustive_search(task, start=cells)`` answers "what is the smallest structure that still
contains these modules?" (the expert's question for a docking sequence in progress: a docking
keeps a minimum completion reachable exactly when this minimum equals the task's). Structures
are equal up to translation, so a structure contains the partial one when some translate of the
partial cells (with their module types, when the partial structure gives them) lies among its
cells. :func:`contains` decides it for a whole chunk of structures in compiled code.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cache

import numpy as np

from modquad_gym.geometry.module import ModuleType
from modquad_gym.geometry.structure import Structure

ANY_TYPE = -1
"""A partial cell given without a module type: any palette type matches it."""


@dataclass(frozen=True, eq=False)
class Partial:
    """A partial structure to extend: cells (k, 2) int32 and palette indices (k,) int8
    (:data:`ANY_TYPE` where the type is free)."""

    cells: np.ndarray
    types: np.ndarray

    @property
    def size(self) -> int:
        return len(self.cells)

    def mask(self, cells: np.ndarray, types: np.ndarray | None = None) -> np.ndarray:
        """bool (L,): which structures (cells (L, n, 2), palette indices (L, n) or None)
        contain a translate of this partial structure."""
        cells = np.ascontiguousarray(cells, dtype=np.int32)
        if types is None:
            types = np.zeros(cells.shape[:2], dtype=np.int8)
            part_types = np.full(self.size, ANY_TYPE, dtype=np.int8)
        else:
            types = np.ascontiguousarray(types, dtype=np.int8)
            part_types = self.types
        out = np.zeros(len(cells), dtype=bool)
        if len(cells):
            _compiled_contains()(cells, types, self.cells, part_types, out)
        return out


def check_start(value, name: str = "start") -> Structure | tuple[tuple[int, int], ...]:
    """The check of the ``start`` option in every door (:mod:`.options`): a Structure as it is,
    else connected (x, y) cells, read once (a generator too) and returned as a tuple;
    ValueError naming ``name``. Its size against n_max and its module types against the
    searched ones follow when those are known (:func:`check_size`, :func:`make_partial`)."""
    if isinstance(value, Structure):
        return value
    try:
        return Structure([tuple(c) for c in value]).cells
    except (TypeError, ValueError) as err:
        raise ValueError(f"{name}: {err}") from None


def check_size(start: Structure | tuple, n_max: int) -> None:
    """ValueError when ``start`` (checked: :func:`check_start`) has more than ``n_max`` cells:
    every structure containing it has more."""
    n = start.n_modules if isinstance(start, Structure) else len(start)
    if n > n_max:
        raise ValueError(f"start has {n} cells, more than n_max={n_max}")


def make_partial(start, palette: tuple[ModuleType, ...], typed: bool, n_max: int) -> Partial:
    """The :class:`Partial` of ``start``: a :class:`~modquad_gym.geometry.structure.Structure`
    (its module types must be palette types; they are required of the completion in a search
    over several types or with ``modules=``) or a list of connected (x, y) cells (any types),
    of at most ``n_max`` modules (every structure containing it has more). ValueError names
    what is wrong."""
    start = check_start(start)
    fixed = isinstance(start, Structure) and (typed or len(palette) > 1)
    s = start if isinstance(start, Structure) else Structure.from_trusted(start, palette[0])
    check_size(s, n_max)
    index = {m.digest: k for k, m in enumerate(palette)}
    missing = [m.name for m in s.modules if m.digest not in index]
    if missing:
        raise ValueError(f"start: module type {missing[0]!r} is not among the searched types")
    cells = np.array(s.cells, dtype=np.int32).reshape(-1, 2)
    if fixed:
        types = np.array([index[m.digest] for m in s.modules], dtype=np.int8)
    else:
        types = np.full(len(cells), ANY_TYPE, dtype=np.int8)
    return Partial(cells - cells.min(axis=0), types)


@cache
def _compiled_contains():
    """:func:`contains` compiled by numba (on first use: a search with no ``start`` needs none)."""
    from modquad_gym.core.jit import njit

    return njit(cache=True)(contains)


def contains(cells, types, part, part_types, out):
    """out[l] = structure l (cells[l] (n, 2), palette indices types[l]) contains a translate of
    ``part`` (k, 2) with matching types (``part_types[j]`` = -1 matches any type)."""
    L, n, _ = cells.shape
    k = part.shape[0]
    for l in range(L):
        x0 = cells[l, 0, 0]
        y0 = cells[l, 0, 1]
        x1 = x0
        y1 = y0
        for i in range(n):
            x0 = min(x0, cells[l, i, 0])
            y0 = min(y0, cells[l, i, 1])
            x1 = max(x1, cells[l, i, 0])
            y1 = max(y1, cells[l, i, 1])
        w = x1 - x0 + 1
        grid = np.full(w * (y1 - y0 + 1), -1, dtype=np.int64)
        for i in range(n):
            grid[(cells[l, i, 1] - y0) * w + cells[l, i, 0] - x0] = i
        found = False
        for a in range(n):  # module a is the image of the partial structure's first cell
            dx = cells[l, a, 0] - part[0, 0]
            dy = cells[l, a, 1] - part[0, 1]
            ok = True
            for j in range(k):
                x = part[j, 0] + dx - x0
                y = part[j, 1] + dy - y0
                if x < 0 or y < 0 or x >= w or y > y1 - y0:
                    ok = False
                    break
                i = grid[y * w + x]
                if i < 0 or (part_types[j] >= 0 and types[l, i] != part_types[j]):
                    ok = False
                    break
            if ok:
                found = True
                break
        out[l] = found
