"""The ``"auto"`` method (default): certificates first, the DAQP LP last.

A wrench is *accepted* when an x in the cube solves G x = r (the minimum-norm solution, then
Douglas-Rachford iterations between the affine set and the cube, vectorised over the undecided
wrenches); *rejected* when a direction d separates it, d . r > (1 + TOL) sum_j |d . g_j| (the
support function of the centred zonotope), with d the Douglas-Rachford residual in the dual metric
or a cached direction that separated an earlier wrench of this zonotope. Every certificate is
exact (checked in float64) and keeps a clearance of ``GUARD`` from the threshold; the few wrenches
left undecided go to the exact LP gamma (:mod:`modquad_gym.oracle.daqp_lp`). Margins use the
exact LP gamma.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from benchmarks.reference_oracle import cache
from modquad_gym.oracle.daqp_lp import gamma_and_direction
from modquad_gym.oracle.tolerance import ACCEPT, REJECT, decide_from_gamma

if TYPE_CHECKING:
    from modquad_gym.oracle.zonotope import Zonotope

_DR_ROUNDS = (10, 20)  # Douglas-Rachford iterations per round, certificates after each
_DR_MIN_ROWS = 4  # with fewer undecided wrenches, LPs cost less than the iterations
_CACHE_DIRECTIONS = 64


def reject_by_cache(z: Zonotope, R: np.ndarray) -> np.ndarray:
    """bool (t,): rows of R separated by a cached direction (one that separated an earlier
    wrench). Exact: True means gamma > 1 + TOL."""
    cached = cache(z).get("directions")
    if cached is None:
        return np.zeros(len(R), dtype=bool)
    dirs, supp = cached
    return ((R @ dirs.T) > supp * REJECT).any(axis=1)


def reject_by_box(z: Zonotope, R: np.ndarray) -> np.ndarray:
    """bool (t,): rows of R outside the zonotope's bounding box (the supports of the
    coordinate axes) scaled by 1 + TOL + GUARD. Exact, and free of overflow for any
    finite R: every row it keeps is bounded by the box."""
    return (np.abs(R) > z.box * REJECT).any(axis=1)


def reject_by_support(z: Zonotope, R: np.ndarray) -> np.ndarray:
    """bool (t,): rows of R (centred reduced wrenches) that a cheap direction separates: the
    cached directions, the coordinate axes (the left singular vectors of A) and the wrench's
    own direction in the plain and the dual metric. Exact: True means gamma > 1 + TOL."""
    reject = reject_by_box(z, R) | reject_by_cache(z, R)
    rest = np.flatnonzero(~reject)
    if len(rest):
        Ru = R[rest]
        k = len(rest)
        D = np.concatenate([Ru, Ru * z.dual])  # plain and dual metric
        proj = np.einsum("ij,ij->i", D, np.concatenate([Ru, Ru]))
        sep = proj > np.abs(D @ z.G).sum(axis=1) * REJECT
        reject[rest[sep[:k] | sep[k:]]] = True
    return reject


def decide_reduced(z: Zonotope, R: np.ndarray) -> np.ndarray:
    """Exact decisions for centred reduced wrenches R (t, rank) that lie in range(A)."""
    outside = reject_by_box(z, R)
    if outside.any():  # the rest is bounded by the box: no overflow below
        accept = np.zeros(len(R), dtype=bool)
        inside = np.flatnonzero(~outside)
        if len(inside):
            accept[inside] = decide_reduced(z, R[inside])
        return accept
    X0 = R @ z.P.T  # minimum-norm allocations
    accept = np.abs(X0).max(axis=1) <= ACCEPT
    if accept.all():
        return accept
    idx = np.flatnonzero(~accept)
    if "directions" in cache(z):  # directions that separated earlier wrenches
        idx = idx[~reject_by_cache(z, R[idx])]
    learned: list[np.ndarray] = []
    if len(idx) >= _DR_MIN_ROWS:
        idx = _douglas_rachford(z, R, X0, idx, accept, learned)
    for i in idx:  # the few undecided rows: the exact LP
        gamma, d = gamma_and_direction(z, R[i])
        accept[i] = ok = bool(decide_from_gamma(gamma))
        if not ok and d is not None and len(learned) < 4:
            learned.append(d[None])
    if learned:
        _remember(z, np.vstack(learned)[:4])
    return accept


def _douglas_rachford(
    z: Zonotope,
    R: np.ndarray,
    X0: np.ndarray,
    idx: np.ndarray,
    accept: np.ndarray,
    learned: list[np.ndarray],
) -> np.ndarray:
    """Douglas-Rachford between {x : G x = r} and the cube for the rows ``idx`` of R, in rounds;
    after each round, accept rows whose affine point lies in the cube (``accept`` is set) and
    reject rows that the residual direction separates in the dual metric (a few of those
    directions go to ``learned``); returns the rows left undecided."""
    m = z.m
    step = _dr_step(z)
    # transposed, so that Z and B are contiguous blocks of C = [Z; B] (2m, k)
    X0t, Rt = X0[idx].T.copy(), R[idx].T
    C = np.empty((2 * m, len(idx)))
    C[:m] = X0t
    T = np.empty_like(X0t)
    for n_iter in _DR_ROUNDS:
        Z, B = C[:m], C[m:]
        for _ in range(n_iter):
            # Z <- Z + P_affine(2 B - Z) - B = step [Z; B] + x0, with B = P_cube(Z)
            np.maximum(Z, -1.0, out=B)
            np.minimum(B, 1.0, out=B)
            np.matmul(step, C, out=T)
            np.add(T, X0t, out=Z)
        np.maximum(Z, -1.0, out=B)
        np.minimum(B, 1.0, out=B)
        E = Rt - z.G @ B  # residual of the cube point B (r, k)
        X = z.P @ E
        X += B  # the affine point nearest to B
        ok = np.abs(X).max(axis=0) <= ACCEPT
        D = E * z.dual[:, None]
        rej = np.einsum("ik,ik->k", D, Rt) > np.abs(z.G.T @ D).sum(axis=0) * REJECT
        accept[idx[ok]] = True
        if rej.any():
            learned.append(D[:, rej][:, :2].T)
        keep = ~(ok | rej)
        if keep.all():
            continue
        idx, C, X0t, Rt, T = idx[keep], C[:, keep], X0t[:, keep], Rt[:, keep], T[:, keep]
        if len(idx) < _DR_MIN_ROWS:
            break
    return idx


def _dr_step(z: Zonotope) -> np.ndarray:
    """(m, 2m): one Douglas-Rachford step as a left factor of [Z; B] (columns are rows):
    Z + P_affine(2 B - Z) - B - x0 = (I - N) Z + (2 N - I) B, N the null(G) projector."""
    step = cache(z).get("dr_step")
    if step is None:
        m = z.m
        step = np.empty((m, 2 * m))
        row = np.matmul(z.V.T, z.V, out=step[:, :m])  # row-space projector, I - N
        np.multiply(row, -2.0, out=step[:, m:])
        step[:, m:] += np.eye(m)
        cache(z)["dr_step"] = step
    return step


def _remember(z: Zonotope, D: np.ndarray) -> None:
    """Put directions D (k, r) (any length: the tests are scale-free) first in the cache of
    directions that separated earlier wrenches."""
    supp = np.abs(D @ z.G).sum(axis=1)
    cached = cache(z).get("directions")
    if cached is not None:
        keep = _CACHE_DIRECTIONS - len(D)
        D, supp = np.concatenate([D, cached[0][:keep]]), np.concatenate([supp, cached[1][:keep]])
    cache(z)["directions"] = (D, supp)
