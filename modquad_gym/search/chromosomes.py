"""The genetic search's operators on candidates (connected typed cell sets, translation-
normalised: :data:`.heuristic.Candidate`): random structures, crossover and mutations.

Every operator returns a connected candidate of 1..n_max modules and draws only from the
numpy Generator it is given, so a seed fixes the whole search.
"""

from __future__ import annotations

import numpy as np

from modquad_gym.geometry.cells import NEIGHBOURS, Cell, free_neighbours
from modquad_gym.search.heuristic import Candidate, candidate
from modquad_gym.search.moves import removable


def random_structure(rng: np.random.Generator, n: int, n_types: int) -> Candidate:
    """n modules grown from (0, 0), one docking at a time at a free neighbour drawn with
    weight (occupied neighbours) ** bias, the bias uniform in [0, 4] per structure (0: any
    free cell alike, sprawling; 4: compact); random types."""
    bias = rng.uniform(0.0, 4.0)
    cells: list[Cell] = [(0, 0)]
    taken = {(0, 0)}
    while len(cells) < n:
        free = free_neighbours(cells)
        w = np.array([sum((x + dx, y + dy) in taken for dx, dy in NEIGHBOURS) for x, y in free])
        p = w.astype(float) ** bias
        cell = free[int(rng.choice(len(free), p=p / p.sum()))]
        cells.append(cell)
        taken.add(cell)
    return candidate(cells, rng.integers(n_types, size=n).tolist())


def _largest_piece(typed: dict[Cell, int]) -> dict[Cell, int]:
    """The largest face-connected piece of the cells (ties: the one with the smallest cell)."""
    left, best = set(typed), set()
    for start in sorted(typed):
        if start not in left:
            continue
        piece, stack = {start}, [start]
        left.discard(start)
        while stack:
            x, y = stack.pop()
            for dx, dy in NEIGHBOURS:
                nb = (x + dx, y + dy)
                if nb in left:
                    left.discard(nb)
                    piece.add(nb)
                    stack.append(nb)
        if len(piece) > len(best):
            best = piece
    return {c: typed[c] for c in sorted(best)}


def _centre(cand: Candidate) -> tuple[int, int]:
    xy = np.array([c for c, _ in cand], dtype=float)
    return tuple(int(v) for v in np.round(xy.mean(axis=0)))


def crossover(a: Candidate, b: Candidate, rng: np.random.Generator, n_max: int) -> Candidate:
    """The cells of ``a`` on one side of a random line through its centre and those of ``b``
    (translated so that the centres meet) on the other (``a``'s where both are), cut to their
    largest connected piece and to the ``n_max`` cells of it nearest the centre by breadth
    first search."""
    ax, ay = _centre(a)
    bx, by = _centre(b)
    theta = rng.uniform(0.0, 2.0 * np.pi)
    d = (np.cos(theta), np.sin(theta))
    typed: dict[Cell, int] = {}
    for (x, y), t in b:
        cell = (x - bx + ax, y - by + ay)
        if (cell[0] - ax) * d[0] + (cell[1] - ay) * d[1] > 0:
            typed[cell] = t
    for (x, y), t in a:
        if (x - ax) * d[0] + (y - ay) * d[1] <= 0 or (x, y) not in typed:
            typed[(x, y)] = t
    piece = _largest_piece(typed)
    cells = _nearest_connected(piece, (ax, ay), n_max)
    return candidate(cells, [piece[c] for c in cells])


def _nearest_connected(piece: dict[Cell, int], centre: Cell, n_max: int) -> list[Cell]:
    """At most n_max cells of the connected ``piece``, connected: breadth first from its cell
    nearest ``centre`` (ties: the smallest cell), neighbours in a fixed order."""
    start = min(piece, key=lambda c: ((c[0] - centre[0]) ** 2 + (c[1] - centre[1]) ** 2, c))
    out, seen = [start], {start}
    for x, y in out:
        if len(out) >= n_max:
            break
        for dx, dy in NEIGHBOURS:
            nb = (x + dx, y + dy)
            if nb in piece and nb not in seen and len(out) < n_max:
                seen.add(nb)
                out.append(nb)
    return out


def mutate(cand: Candidate, rng: np.random.Generator, n_types: int, n_max: int) -> Candidate:
    """One mutation, drawn uniformly among those that apply: dock a module (random type) at a
    random free cell, remove a module whose removal keeps the rest connected, move such a
    module to a random free cell of the rest, or change one module's type."""
    cells = [c for c, _ in cand]
    types = [t for _, t in cand]
    kinds = ["add"] if len(cells) < n_max else []
    if len(cells) > 1:
        kinds += ["remove", "move"]
    if n_types > 1:
        kinds.append("type")
    if not kinds:
        return cand
    kind = kinds[int(rng.integers(len(kinds)))]
    if kind == "type":
        i = int(rng.integers(len(cells)))
        types[i] = (types[i] + 1 + int(rng.integers(n_types - 1))) % n_types
        return candidate(cells, types)
    if kind in ("remove", "move"):
        i = int(rng.choice(removable(cells)))
        t = types[i]
        del cells[i], types[i]
        if kind == "remove":
            return candidate(cells, types)
    else:
        t = int(rng.integers(n_types))
    free = free_neighbours(cells)
    cells.append(free[int(rng.integers(len(free)))])
    types.append(t)
    return candidate(cells, types)
