"""The ``"hrep"`` method: the exact H-representation by hyperplane shifting.

One facet normal per independent (r-1)-subset of generators (generalised cross products, all
subsets at once by a Laplace recursion of minors, chunked); gamma = max over facets
|n . r| / sum_j |n . g_j|. Decisions first try the cheap exact support-function rejection (no
H-representation needed when it decides every wrench); margins and the undecided rest use the
H-representation, built once per zonotope. For large batches against one structure.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Iterator
from typing import TYPE_CHECKING

import numpy as np

from benchmarks.reference_oracle import cache
from benchmarks.reference_oracle.certified import reject_by_support
from modquad_gym.oracle.tolerance import decide_from_gamma

if TYPE_CHECKING:
    from modquad_gym.oracle.zonotope import Zonotope


def zonotope_hrep(z: Zonotope, chunk: int = 1 << 16) -> tuple[np.ndarray, np.ndarray]:
    """(N, h): unit facet normals (k, r) of z's centred zonotope with |n . r| <= h on W, built
    once per zonotope (``cache(z)["hrep"]``).

    Hyperplane shifting: each independent (r-1)-subset of generators spans a hyperplane whose
    normal is their generalised cross product; its offset is the support sum_j |n . g_j|.
    Normals are produced and deduplicated ``chunk`` at a time, so memory stays bounded.
    """
    if "hrep" not in cache(z):
        cache(z)["hrep"] = hyperplane_shifting(z.G, chunk)
    return cache(z)["hrep"]


def gamma_hrep(z: Zonotope, R: np.ndarray, rows: int = 1 << 20) -> np.ndarray:
    """Exact gamma for each row of R (centred reduced wrenches in range(A)) by the facets."""
    N, h = zonotope_hrep(z)
    if not len(N):  # rank <= 1: the zonotope is a segment (or a point)
        return np.abs(R).sum(axis=1) / max(np.abs(z.G).sum(), 1e-300)
    step = max(1, rows // len(N))  # bounded (rows x facets) products
    out = np.empty(len(R))
    for a in range(0, len(R), step):
        out[a : a + step] = (np.abs(R[a : a + step] @ N.T) / h).max(axis=1)
    return out


def decide_hrep(z: Zonotope, R: np.ndarray) -> np.ndarray:
    """Decisions for rows of R in range(A): the cheap exact support-function rejection
    first, then the H-representation (built only if some row is left)."""
    out = np.zeros(len(R), dtype=bool)
    rest = np.flatnonzero(~reject_by_support(z, R))
    if len(rest):
        out[rest] = decide_from_gamma(gamma_hrep(z, R[rest]))
    return out


# --------------------------------------------------------------------------------------------
# hyperplane shifting: all generalised cross products at once
# --------------------------------------------------------------------------------------------
_LAPLACE: dict[tuple[int, int], tuple] = {}
_SIGN_DIRECTION = np.random.default_rng(7).standard_normal(6)
_HASH = np.random.default_rng(8).standard_normal((6, 2))


def _laplace_table(r: int, k: int) -> tuple:
    """Laplace expansion of every k x k minor along its last column, as a scatter table.

    For the k-row subsets R of range(r) (lexicographic) and the (k-1)-row subsets:
    ``det M[R, :k] = sum sign * M[row, k-1] * det M[sub, :k-1]`` over the entries
    (sub, dst = index of R, row, sign). Returns (sub, dst, row, sign, n_sub, n_dst).
    """
    key = (r, k)
    if key not in _LAPLACE:
        prev = {s: i for i, s in enumerate(itertools.combinations(range(r), k - 1))}
        sets = list(itertools.combinations(range(r), k))
        entries = [
            (prev[s[:t] + s[t + 1 :]], q, s[t], (-1.0) ** (t + k - 1))
            for q, s in enumerate(sets)
            for t in range(k)
        ]
        sub, dst, row, sign = (np.array(col) for col in zip(*entries))
        _LAPLACE[key] = (sub.astype(np.intp), dst.astype(np.intp), row, sign, len(prev), len(sets))
    return _LAPLACE[key]


def _extend_minors(
    G: np.ndarray, last: np.ndarray, minors: np.ndarray, k: int
) -> Iterator[tuple[int, int, np.ndarray]]:
    """Minors of the k-subsets of columns, from those of the (k-1)-subsets.

    ``minors`` (p, C(r, k-1)) holds every (k-1)-row minor of each (k-1)-subset of columns, whose
    last columns ``last`` are sorted. A k-subset is a (k-1)-subset plus a later column s, so for
    each s the parents are a prefix (``cnt`` rows) and their children's minors are one matrix
    product, ``minors[:cnt] @ T`` with T (C(r, k-1), C(r, k)) built from column s. Yields
    (s, cnt, T); the children come out ordered by their last column.
    """
    sub, dst, row, sign, n_sub, n_dst = _laplace_table(G.shape[0], k)
    T = np.zeros((n_sub, n_dst))
    for s in range(G.shape[1]):
        cnt = int(np.searchsorted(last, s))
        if cnt:
            T[sub, dst] = sign * G[row, s]
            yield s, cnt, T


def hyperplane_shifting(G: np.ndarray, chunk: int = 1 << 16) -> tuple[np.ndarray, np.ndarray]:
    """Facet normals of the zonotope with generators G (r, m), and their supports.

    Every facet is spanned by r - 1 independent generators; its normal is their generalised
    cross product, n_i = (-1)^i det(M without row i) for M = G[:, subset] (r, r-1). All of them
    come from a Laplace recursion: the (k x k)-minors of every k-subset of columns are matrix
    products of the (k-1)-minors (:func:`_extend_minors`), level by level up to r - 2; the last
    level maps straight to the normals in blocks of at most ``chunk``. Zero normals (dependent
    subsets) are dropped, the rest normalised to a canonical sign and deduplicated by hashing
    (verified by a second hash, exact fallback), a chunk at a time: memory stays bounded.
    """
    r, m = G.shape
    if r <= 1:
        return np.zeros((0, r)), np.zeros(0)
    tol = 1e-9 * float(np.abs(G).max()) ** (r - 1)
    dedupe = _Deduplicator(r, tol, chunk)
    if r == 2:
        dedupe.add(np.stack([-G[1], G[0]], axis=1))
    else:
        last, minors = np.arange(m), np.ascontiguousarray(G.T)
        for k in range(2, r - 1):
            n_dst = math.comb(r, k)
            out = np.empty((math.comb(m, k), n_dst))
            new_last = np.empty(len(out), dtype=np.intp)
            at = 0
            for s, cnt, T in _extend_minors(G, last, minors, k):
                np.matmul(minors[:cnt], T, out=out[at : at + cnt])
                new_last[at : at + cnt] = s
                at += cnt
            last, minors = new_last, out
        # (r-1)-row subsets in lexicographic order miss row r-1, r-2, ..., 0
        perm = np.arange(r)[::-1]
        sgn = (-1.0) ** np.arange(r)
        for _, cnt, T in _extend_minors(G, last, minors, r - 1):
            Tn = T[:, perm] * sgn
            for a in range(0, cnt, chunk):
                dedupe.add(minors[a : min(cnt, a + chunk)] @ Tn)
    N = dedupe.result()
    h = np.empty(len(N))
    for a in range(0, len(N), chunk):  # supports, a chunk of facets at a time
        h[a : a + chunk] = np.abs(N[a : a + chunk] @ G).sum(axis=1)
    return N, h


class _Deduplicator:
    """Collects normals (rows), drops zero ones, normalises them to unit length and a canonical
    sign, and keeps one per direction (rounded to 1e-9). Memory: the unique rows plus one chunk."""

    def __init__(self, r: int, tol: float, chunk: int) -> None:
        self.r, self.tol, self.chunk = r, tol, chunk
        self.buf: list[np.ndarray] = []
        self.size = 0
        self.kept = np.zeros((0, r))

    def add(self, N: np.ndarray) -> None:
        self.buf.append(N)
        self.size += len(N)
        if self.size >= self.chunk:
            self._flush()

    def _flush(self) -> None:
        if not self.buf:
            return
        N = np.vstack(self.buf) if len(self.buf) > 1 else self.buf[0]
        self.buf, self.size = [], 0
        norm = np.sqrt(np.einsum("ij,ij->i", N, N))
        live = norm > self.tol
        if not live.all():
            N, norm = N[live], norm[live]
        N /= np.where(N @ _SIGN_DIRECTION[: self.r] < 0.0, -norm, norm)[:, None]
        if len(self.kept):
            N = np.vstack([self.kept, N])
        self.kept = N[_unique_rows(N)]

    def result(self) -> np.ndarray:
        self._flush()
        return self.kept


def _unique_rows(N: np.ndarray) -> np.ndarray:
    """Sorted indices of one row per distinct row of N after rounding to 1e-9.

    Rows are grouped by a hash (a random projection of the rounded row, whose low bits carry the
    row index so that one plain sort does it) and every group is verified by a second,
    independent projection; if any disagrees, rows are compared exactly instead."""
    n, r = N.shape
    K = N * 1e9
    np.rint(K, out=K)
    h = K @ _HASH[:r]  # (n, 2)
    bits = max(1, int(n - 1).bit_length())
    low = np.uint64((1 << bits) - 1)
    packed = np.ascontiguousarray(h[:, 0]).view(np.uint64) & ~low
    packed |= np.arange(n, dtype=np.uint64)
    packed.sort()
    idx = (packed & low).astype(np.intp)
    group = packed >> np.uint64(bits)
    start = np.ones(n, dtype=bool)
    np.not_equal(group[1:], group[:-1], out=start[1:])
    first = idx[np.maximum.accumulate(np.where(start, np.arange(n), 0))]
    if not np.array_equal(h[first, 1], h[idx, 1]):  # a collision of the first hash
        rows = np.ascontiguousarray(K).view(np.dtype((np.void, 8 * r))).ravel()
        return np.sort(np.unique(rows, return_index=True)[1])
    return np.sort(idx[start])
