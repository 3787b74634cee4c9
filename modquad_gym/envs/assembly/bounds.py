"""The shortlist's bounds (``lookahead_top_k``): what support functions say about a child without
an oracle call, each a proved bound on what the exact oracle would say.

A child's support on a direction d, ``h_W(d) = f_max / 2 sum_k (|d . a_k| + d . a_k)``, bounds
every feasible wrench's projection, so a wrench beyond it (by more than the oracle's tolerance)
is infeasible: an upper bound on the satisfied share. W is symmetric about its centre c, so any
d bounds a wrench's gauge gamma about c from below, hence its clipped margin ``1 - gamma`` from
above (:func:`support_bounds`, :func:`ray_bounds`).
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from modquad_gym.core.jit import njit

FLAT = 1e-9
"""Widths (and offsets) below this (in units of denom) count as zero: a flat direction of a
rank-deficient W bounds nothing but what lies off it."""


class Bounds(NamedTuple):
    """What the shortlist knows of L children without an oracle call."""

    share: np.ndarray
    """(L,) upper bounds on the satisfied share."""
    gamma: np.ndarray
    """(L, t) lower bounds on each wrench's gamma (:func:`margin_bound`: on the mean margin)."""
    h: np.ndarray
    """(L, K) supports on the feature directions / denom (the support rows' input)."""
    slack: np.ndarray
    """(L,) the support screen's slack (:meth:`~.features.AssemblyFeatures.support`)."""


def margin_bound(gamma: np.ndarray) -> np.ndarray:
    """The mean over wrenches of ``1 - gamma`` clipped to [-1, 1], per row of ``gamma``."""
    return np.clip(1.0 - gamma, -1.0, 1.0).mean(axis=1)


def support_bounds(
    h_Cn: np.ndarray, slack: np.ndarray, centre: np.ndarray, WD: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """(share bound (L,), gamma bound (L, t)) of L structures with supports ``h_Cn`` (L, K),
    slacks (L,) and centres ``centre`` (L, K) (:meth:`~.features.AssemblyFeatures.supports`)
    against wrenches of projections ``WD`` (t, K), all divided by denom (which cancels).

    gamma is a wrench's gauge about W's centre c (the oracle's: its margin is 1 - gamma). W is
    symmetric about c, so w = c + gamma z with z in W - c gives |d . (w - c)| <= gamma
    (h_W(d) - d . c) in every direction d: the largest ratio bounds gamma from below, hence
    the margin from above. The share bound counts the wrenches the support test cannot
    reject (it never rejects one the oracle accepts; see ``slack``)."""
    share, gamma = np.empty(len(h_Cn)), np.empty((len(h_Cn), len(WD)))
    _support_bounds(h_Cn, slack, centre, WD, FLAT, share, gamma)
    return share, gamma


@njit(cache=True)
def _support_bounds(h_Cn, slack, centre, WD, flat, share, gamma):  # pragma: no cover - compiled
    """:func:`support_bounds` in one pass, no (L, t, K) arrays: per structure and wrench the
    largest deficit ``WD - h`` and the largest :func:`ratios` of ``|WD - c|`` to ``h - c``
    (the same operations on the same numbers as numpy's element-wise version)."""
    L, t, K = h_Cn.shape[0], WD.shape[0], WD.shape[1]
    for l in range(L):
        kept = 0
        for i in range(t):
            deficit = -np.inf
            ratio = -np.inf
            for d in range(K):
                deficit = max(deficit, WD[i, d] - h_Cn[l, d])
                off = abs(WD[i, d] - centre[l, d])
                width = h_Cn[l, d] - centre[l, d]
                if width > flat:
                    ratio = max(ratio, off / width)
                else:
                    ratio = max(ratio, np.inf if off > flat else 0.0)
            kept += deficit <= slack[l]
            gamma[l, i] = ratio
        share[l] = kept / t


def ray_bounds(A: np.ndarray, D: np.ndarray, W: np.ndarray, f_max: float) -> np.ndarray:
    """gamma bound (L, t) of the structures of configuration matrices ``A`` (L, 6, m) for the
    wrenches ``W`` (t, 6), each in its own direction (a row of ``D``, (t, 6); zero: none),
    by the inequality of :func:`support_bounds`."""
    absolute, signed = projections(D, A)
    return ray_ratios(absolute, signed, D, W, f_max, np.linalg.norm(A, axis=1).sum(axis=1))


def ray_ratios(absolute, signed, D, W, f_max: float, norms) -> np.ndarray:
    """:func:`ray_bounds` from the :func:`projections` of the directions ``D`` and the
    structures' sums of column norms ``norms`` (L,) (the scale of a flat width)."""
    half = f_max / 2.0
    off = np.abs(np.einsum("ti,ti->t", D, W)[None] - signed * half)
    flat = FLAT * half * np.linalg.norm(D, axis=1)[None] * norms[:, None]
    return ratios(off, absolute * half, flat)


@njit(cache=True, fastmath={"reassoc", "contract"})
def projections(D, A):  # pragma: no cover - compiled
    """(sum_k |d . a_k|, sum_k d . a_k), each (L, R), for directions D (R, 6) and the columns
    a_k of the matrices A (L, 6, m): one pass, no (L, R, m) array (the supports, W's centre
    and the widths about it follow). The sums over k are reordered (SIMD: 5x faster at 100
    columns), so they differ from numpy's in the last bits: bounds, not decisions."""
    L, m, R = A.shape[0], A.shape[2], D.shape[0]
    absolute = np.empty((L, R))
    signed = np.empty((L, R))
    for l in range(L):
        a0, a1, a2, a3, a4, a5 = A[l, 0], A[l, 1], A[l, 2], A[l, 3], A[l, 4], A[l, 5]
        for r in range(R):
            d0, d1, d2, d3, d4, d5 = D[r, 0], D[r, 1], D[r, 2], D[r, 3], D[r, 4], D[r, 5]
            total, size = 0.0, 0.0
            for k in range(m):
                p = d0 * a0[k] + d1 * a1[k] + d2 * a2[k] + d3 * a3[k] + d4 * a4[k] + d5 * a5[k]
                size += abs(p)
                total += p
            absolute[l, r] = size
            signed[l, r] = total
    return absolute, signed


def ratios(off: np.ndarray, width: np.ndarray, flat) -> np.ndarray:
    """off / width where the width exceeds ``flat``; else inf where the offset does too (off a
    flat direction: not in W), 0 where it does not (no bound)."""
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(width > flat, off / width, np.where(off > flat, np.inf, 0.0))
