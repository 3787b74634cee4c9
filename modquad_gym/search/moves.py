"""Structures to start from and local moves between structures, for the anytime search.

* :func:`compact_shapes`: n-cell shapes that spread lift and lever arms evenly (lattice
  ellipses of several aspect ratios, filled rectangles): a quick first incumbent at any size.
* :func:`removable`: the modules whose removal leaves the structure connected (the
  non-articulation cells of its adjacency graph).
* :func:`relocations`: moving one removable module to another free cell of the rest.

Cells are (x, y) tuples, in any order; every shape and move keeps the cells face-connected.
"""

from __future__ import annotations

import math
from collections.abc import Iterator, Sequence

from modquad_gym.geometry.cells import NEIGHBOURS, Cell, free_neighbours, is_connected, normalise

ASPECTS = (1.0, 1.5, 2.0, 3.0, 4.0)
"""Aspect ratios (long side / short side) of the compact shapes, both ways round."""


def _ellipse(n: int, ax: float, ay: float) -> tuple[Cell, ...]:
    """The n lattice cells nearest the origin in the metric (x/ax)^2 + (y/ay)^2 (ties by
    angle, then cell)."""
    r = int(math.ceil(math.sqrt(n / math.pi) * max(ax, ay) / math.sqrt(ax * ay))) + 2
    cells = [(x, y) for x in range(-r, r + 1) for y in range(-r, r + 1)]
    cells.sort(key=lambda c: ((c[0] / ax) ** 2 + (c[1] / ay) ** 2, math.atan2(c[1], c[0]), c))
    return tuple(cells[:n])


def _rectangle(n: int, width: int) -> tuple[Cell, ...]:
    """n cells filling rows of ``width`` cells (the last row partly, from its middle)."""
    rows, rest = divmod(n, width)
    cells = [(x, y) for y in range(rows) for x in range(width)]
    start = (width - rest) // 2
    cells += [(start + x, rows) for x in range(rest)]
    return tuple(cells)


def compact_shapes(n: int) -> list[tuple[Cell, ...]]:
    """Distinct connected n-cell shapes (up to translation): lattice ellipses and rectangles of
    the aspect ratios :data:`ASPECTS`, each lying along x and along y."""
    out: dict[tuple, tuple[Cell, ...]] = {}
    for a in ASPECTS:
        for ax, ay in ((a, 1.0), (1.0, a)):
            shape = _ellipse(n, ax, ay)
            if is_connected(shape):
                out.setdefault(normalise(shape), shape)
        width = max(1, round(math.sqrt(n * a)))
        for shape in (_rectangle(n, width), tuple((y, x) for x, y in _rectangle(n, width))):
            out.setdefault(normalise(shape), shape)
    return list(out.values())


def removable(cells: Sequence[Cell]) -> list[int]:
    """Indices of the cells whose removal leaves the others connected (every cell of a
    one-cell structure is not removable: a structure keeps at least one module)."""
    n = len(cells)
    if n <= 1:
        return []
    index = {c: i for i, c in enumerate(cells)}
    adj = [[index[(x + dx, y + dy)] for dx, dy in NEIGHBOURS if (x + dx, y + dy) in index]
           for x, y in cells]  # fmt: skip
    cut = _articulation_points(adj)  # once: not once per cell
    return [i for i in range(n) if i not in cut]


def _articulation_points(adj: list[list[int]]) -> set[int]:
    """The cut vertices of a connected graph (iterative Tarjan: depth and low-link)."""
    n = len(adj)
    depth = [-1] * n
    low = [0] * n
    parent = [-1] * n
    cut: set[int] = set()
    depth[0] = 0
    stack = [(0, iter(adj[0]))]
    root_children = 0
    while stack:
        v, it = stack[-1]
        w = next(it, None)
        if w is None:
            stack.pop()
            if stack:
                u = stack[-1][0]
                low[u] = min(low[u], low[v])
                if parent[u] != -1 and low[v] >= depth[u]:
                    cut.add(u)
            continue
        if depth[w] == -1:
            parent[w] = v
            depth[w] = low[w] = depth[v] + 1
            if v == 0:
                root_children += 1
            stack.append((w, iter(adj[w])))
        elif w != parent[v]:
            low[v] = min(low[v], depth[w])
    if root_children > 1:
        cut.add(0)
    return cut


def relocations(cells: Sequence[Cell]) -> Iterator[tuple[int, Cell]]:
    """(i, c): module i moves to the free cell c, the structure staying connected (i is
    removable and c touches the other modules)."""
    for i in removable(cells):
        rest = [c for j, c in enumerate(cells) if j != i]
        for c in free_neighbours(rest):
            if c != cells[i]:
                yield i, c
