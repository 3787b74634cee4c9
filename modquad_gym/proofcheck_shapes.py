"""The structures of a level for :mod:`modquad_gym.proofcheck`, in the certificate format's
canonical order (``docs/certificates.md``): every fixed polyomino of n cells with every
assignment of the module types to its cells (numpy and the standard library only; the
checker's third file: copy all three).

Fixed polyominoes grow cell by cell from the one cell (every connected n-cell set keeps a
connected (n-1)-cell subset: drop a leaf of a spanning tree; so growing every (n-1)-polyomino by
every free neighbour reaches every n-polyomino), deduplicated up to translation by a key. Their
numbers are also known (OEIS A001168, :data:`FIXED_POLYOMINOES`): a level's structure count is
read there without enumerating, and every enumeration is checked against it.
"""

from __future__ import annotations

from functools import cache

import numpy as np

MAX_ENUMERATED = 14  # shape keys fit in 63 bits up to 14 cells
KEY_SHIFT = 56  # key = width << KEY_SHIFT | sum of 2^(x + y width) over the cells
BLOCK_COLUMNS = 1 << 19  # rotor columns (structures times their rotors) checked at once
STEPS = np.array([[1, 0], [-1, 0], [0, 1], [0, -1]])
FIXED_POLYOMINOES = (1, 2, 6, 19, 63, 216, 760, 2725, 9910, 36446, 135268, 505861, 1903890,
                     7204874)  # fmt: skip
"""Fixed polyominoes of 1 to 14 cells (OEIS A001168)."""


def keys_of(cells: np.ndarray) -> np.ndarray:
    """int64 keys (L,) of cell sets (L, n, 2), equal exactly for translates."""
    c = cells - cells.min(axis=1, keepdims=True)
    width = c[:, :, 0].max(axis=1) + 1
    bits = np.left_shift(np.int64(1), c[:, :, 0] + c[:, :, 1] * width[:, None])
    return np.bitwise_or.reduce(bits, axis=1) | (width << KEY_SHIFT)


def cells_of(keys: np.ndarray, n: int) -> np.ndarray:
    """(L, n, 2) cells of keys, translated to x, y >= 0, in order of x + y width."""
    width = (keys >> KEY_SHIFT)[:, None]
    bits = (keys[:, None] >> np.arange(KEY_SHIFT)) & 1
    index = np.nonzero(bits)[1].reshape(len(keys), n)
    return np.stack([index % width, index // width], axis=2)


@cache
def shape_keys(n: int) -> np.ndarray:
    """Sorted keys of every fixed polyomino of n cells (1 <= n <= :data:`MAX_ENUMERATED`),
    their number checked against :data:`FIXED_POLYOMINOES`."""
    if not 1 <= n <= MAX_ENUMERATED:
        raise ValueError(f"only shapes of 1 to {MAX_ENUMERATED} cells are enumerated, not {n}")
    if n == 1:
        return np.array([(1 << KEY_SHIFT) | 1], dtype=np.int64)
    found, parents = [], shape_keys(n - 1)
    for s in range(0, len(parents), 4096):
        cells = cells_of(parents[s : s + 4096], n - 1)  # (L, m, 2)
        grown = (cells[:, :, None, :] + STEPS).reshape(len(cells), -1, 2)  # (L, 4m, 2)
        free = ~(grown[:, :, None, :] == cells[:, None, :, :]).all(axis=3).any(axis=2)
        rows, new = np.nonzero(free)
        found.append(np.unique(keys_of(np.concatenate([cells[rows], grown[rows, new, None]], 1))))
    keys = np.unique(np.concatenate(found))
    if len(keys) != FIXED_POLYOMINOES[n - 1]:  # never: the growth argument above
        raise RuntimeError(f"{len(keys)} shapes of {n} cells enumerated, not {FIXED_POLYOMINOES}")
    return keys


def count(n: int, n_types: int) -> int:
    """Structures of n modules of ``n_types`` types up to translation (none enumerated)."""
    return FIXED_POLYOMINOES[n - 1] * n_types**n


def structures(n: int, n_types: int, rotors: int):
    """(start, cells (B, n, 2), types (B, n)) in blocks of at most :data:`BLOCK_COLUMNS`
    rotors (at least one structure), in canonical order: shapes by key, then type assignments
    (a type index per cell, cells in key order) in lexicographic order."""
    keys = shape_keys(n)
    per, total = n_types**n, count(n, n_types)
    block = max(1, BLOCK_COLUMNS // (n * rotors))
    for start in range(0, total, block):
        shape, assign = np.divmod(np.arange(start, min(start + block, total)), per)
        types = np.stack(np.unravel_index(assign, (n_types,) * n), axis=1)
        yield start, cells_of(keys[shape], n), types
