"""The shared certificate's arrays for one structure (:class:`~.faults.FaultTolerance`).

For each failure S, the least-norm correction of the other rotors per unit of 1 + x_S,
C_S = H_{:,S} (I - H_SS)^-1 with S's block set to -I (H = V^T V, the projection on the row space
of G; Woodbury), its round-off ``max |G C_S|``, and the largest rise and fall of each of its rows
off S; for pairs also what the test through a single failure needs (:func:`pair_lift`). A
failure whose removal lowers the rank (an eigenvalue of I - H_SS below :data:`SINGULAR`: a single
module, a line) gets no correction (its round-off inf): it is decided on A_{-S} itself. Pairs
are made by compiled loops (every rotor2 structure of a search pays this), other failures by
numpy, a size at a time.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from modquad_gym.core.jit import njit
from modquad_gym.oracle.zonotope import Zonotope

SINGULAR = 1e-6
"""Smallest eigenvalue of I - H_SS below which failure S has no correction."""


def corrections(z: Zonotope, failures: Sequence[np.ndarray]) -> tuple:
    """(C, the rotors of its rows, each failure's first row, round-off per failure, rise and
    fall per row, the pairs' single-failure arrays (empty unless every failure is a pair), H)
    for :func:`~.fault_kernels.certify_rows`."""
    H = np.ascontiguousarray(z.V.T @ z.V)
    if len(failures) and z.rank and all(len(S) == 2 for S in failures):
        pairs = np.array(failures, dtype=np.int64).reshape(-1, 2)
        C, errors, up, down = pair_corrections(H, z.G, pairs, SINGULAR)
        starts = np.arange(0, 2 * len(pairs) + 1, 2, dtype=np.int64)
        return C, pairs.ravel(), starts, errors, up, down, pair_lift(H, SINGULAR), H
    sizes = np.array([len(S) for S in failures], dtype=np.int64)
    starts = np.concatenate([[0], np.cumsum(sizes)]).astype(np.int64)
    C = np.zeros((int(starts[-1]), z.m))
    errors = np.full(len(failures), np.inf)
    off = np.zeros_like(C)  # C off each row's failed rotors
    for s in np.unique(sizes) if z.rank else []:  # failures of one size at a time
        group = np.flatnonzero(sizes == s)
        S = np.array([failures[i] for i in group])  # (F, s)
        M = np.eye(s) - H[S[:, :, None], S[:, None, :]]  # (F, s, s)
        low = M[:, 0, 0] if s == 1 else np.linalg.eigvalsh(M).min(axis=1)
        idx = np.flatnonzero(low >= SINGULAR)
        if not len(idx):
            continue
        # (F', s, m): H_{S,:} = H_{:,S}^T
        CS = H[S[idx]] / M[idx, :, :1] if s == 1 else np.linalg.solve(M[idx], H[S[idx]])
        F = np.arange(len(idx))[:, None, None]
        CS[F, np.arange(s)[None, :, None], S[idx][:, None, :]] = 0.0
        rows = starts[group[idx]][:, None] + np.arange(s)  # (F', s)
        off[rows] = CS
        CS[F, np.arange(s)[None, :, None], S[idx][:, None, :]] = -np.eye(s)
        C[rows] = CS
        GC = CS.reshape(-1, z.m) @ z.G.T  # (F' s, rank): G C_S, one failure per s rows
        errors[group[idx]] = np.abs(GC).reshape(len(idx), -1).max(axis=1)
    empty = np.zeros((0, 0))
    return (np.ascontiguousarray(C), np.concatenate(failures).astype(np.int64), starts, errors,
            np.maximum(off.max(axis=1), 0.0), np.maximum(-off.min(axis=1), 0.0),
            (empty, empty, empty), H)  # fmt: skip


@njit(cache=True)
def pair_corrections(H, G, pairs, singular):  # pragma: no cover - compiled
    """The certificate's arrays for failures that are pairs (rows of ``pairs``): C (2F, m),
    the rows of each pair's correction C_S = H_{:,S} (I - H_SS)^-1 with S's block -I;
    ``max |G C_S|`` per pair (inf where the smallest eigenvalue of I - H_SS is below
    ``singular``: the rank would drop, C_S left zero); the largest rise and fall of each row
    off S. The 2x2 inverse in closed form."""
    m = H.shape[0]
    F = pairs.shape[0]
    C = np.zeros((2 * F, m))
    errors = np.full(F, np.inf)
    up = np.zeros(2 * F)
    down = np.zeros(2 * F)
    for f in range(F):
        i, j = pairs[f, 0], pairs[f, 1]
        p, q, u = 1.0 - H[i, i], -H[i, j], 1.0 - H[j, j]
        if 0.5 * (p + u) - np.hypot(0.5 * (p - u), q) < singular:
            continue
        det = p * u - q * q
        for k in range(m):
            C[2 * f, k] = (u * H[i, k] - q * H[j, k]) / det
            C[2 * f + 1, k] = (p * H[j, k] - q * H[i, k]) / det
        for r in range(2 * f, 2 * f + 2):
            C[r, i] = 0.0
            C[r, j] = 0.0
            hi = 0.0
            lo = 0.0
            for k in range(m):
                hi = max(hi, C[r, k])
                lo = min(lo, C[r, k])
            up[r] = hi
            down[r] = -lo
        C[2 * f, i] = -1.0
        C[2 * f + 1, j] = -1.0
        worst = 0.0
        for r in range(2 * f, 2 * f + 2):
            for a in range(G.shape[0]):
                acc = 0.0
                for k in range(m):
                    acc += G[a, k] * C[r, k]
                worst = max(worst, abs(acc))
        errors[f] = worst
    return C, errors, up, down


@njit(cache=True)
def pair_lift(H, singular):  # pragma: no cover - compiled
    """The arrays of the pairs' test through a single failure (:func:`certify_rows`): each
    rotor's single-failure correction (row i: H_{i,:} / (1 - H_ii), entry i -1; zero where
    1 - H_ii < ``singular``), and per ordered pair (i, j) the largest rise and fall, off i and
    j, of the correction of j in A without i: column j of the projection H^(i) = H + H_{:,i}
    H_{i,:} / (1 - H_ii) over 1 - H^(i)_jj; inf where it does not exist (the rank would
    drop)."""
    m = H.shape[0]
    single = np.zeros((m, m))
    rise = np.full((m, m), np.inf)
    fall = np.full((m, m), np.inf)
    for i in range(m):
        gap = 1.0 - H[i, i]
        if gap < singular:
            continue
        for k in range(m):
            single[i, k] = H[i, k] / gap
        single[i, i] = -1.0
        for j in range(m):
            if j == i:
                continue
            gap_j = 1.0 - H[j, j] - H[j, i] * H[i, j] / gap
            if gap_j < singular:
                continue
            hi = 0.0
            lo = 0.0
            for k in range(m):
                if k != i and k != j:
                    v = (H[k, j] + H[k, i] * H[i, j] / gap) / gap_j
                    hi = max(hi, v)
                    lo = min(lo, v)
            rise[i, j] = hi
            fall[i, j] = -lo
    return single, rise, fall
