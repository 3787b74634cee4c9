"""The ``"compiled"`` method (and the decisions of ``"auto"``): compiled certificates, the exact
LP for the rest.

Each batch of wrenches against one zonotope is one compiled call (:mod:`.kernels`): an
allocation in the cube or a separating direction, both checked in float64 by the tolerance rule
(:mod:`~modquad_gym.oracle.tolerance`), for every wrench it decides. The directions that
separated earlier wrenches are remembered per zonotope (its ``kernel`` field) and tried first
on later ones. The few wrenches no certificate decides (within GUARD of the threshold, or a
walk stopped by its pivot limit) get the exact DAQP gamma (:mod:`.daqp_lp`). Margins come from
the same walk run to the optimum (:func:`gamma_compiled`), where its bounds certify its gamma.

:func:`screen_compiled` fuses a caller's support screen with the decisions, for
:meth:`~modquad_gym.oracle.WrenchOracle.screened` (the environment decides every step this way).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from modquad_gym.oracle.daqp_lp import gamma_daqp
from modquad_gym.oracle.tolerance import decide_from_gamma

if TYPE_CHECKING:
    from modquad_gym.oracle.zonotope import Zonotope

DIRECTIONS = 16
"""Directions remembered per zonotope (where earlier wrenches were decided; tried first)."""


def _prepared(z: Zonotope) -> tuple[tuple, tuple, tuple]:
    """(the kernels' per-zonotope arrays, the remembered directions: (DIRECTIONS, rank), their
    supports, how many were added; the generators walked: (G k, P / k, k) of
    :func:`~.kernels.walk_view`) of z, built once."""
    prepared = z.kernel
    if prepared is None:
        from modquad_gym.oracle import kernels  # numba: compiled on first use, cached on disk

        memory = (np.zeros((DIRECTIONS, z.rank)), np.ones(DIRECTIONS), np.zeros(1, np.int64))
        view = kernels.walk_view(z)
        prepared = z.kernel = (kernels.prepare(view[0], view[1]), memory, view)
    return prepared


def _rows(R: np.ndarray, k: float) -> np.ndarray:
    """The rows R in the walked coordinates (R k), contiguous float64."""
    return np.ascontiguousarray(R if k == 1.0 else R * k, dtype=float)


def verdicts(z: Zonotope, R: np.ndarray) -> np.ndarray:
    """int8 (t,) per row of R (centred reduced wrenches in range(A)): 1 feasible, 0 infeasible
    (each by a certificate), -1 undecided."""
    from modquad_gym.oracle import kernels

    prep, memory, (G, P, k) = _prepared(z)
    out = np.empty(len(R), dtype=np.int8)
    kernels.decide_rows(G, P, prep, _rows(R, k), memory, out)
    return out


def decide_compiled(z: Zonotope, R: np.ndarray) -> np.ndarray:
    """Exact decisions (t,) for rows of R (centred reduced wrenches in range(A)): certificates,
    the DAQP gamma and the tolerance rule for the undecided."""
    verdict = verdicts(z, R)
    rest = np.flatnonzero(verdict == -1)
    if len(rest):
        verdict[rest] = decide_from_gamma(gamma_daqp(z, R[rest]))
    return verdict == 1


def gamma_compiled(
    z: Zonotope, R: np.ndarray, cap: float = np.inf, dirs: np.ndarray | None = None
) -> np.ndarray:
    """Exact gamma per row of R (centred reduced wrenches in range(A)): the walk to the optimum
    (:func:`~modquad_gym.oracle.kernels.gamma_rows`), the DAQP gamma where it gives up or its
    two bounds disagree (:data:`~modquad_gym.oracle.kernels.GAP`). A row whose gamma is
    certified above ``cap`` gets a certified lower bound (> cap) instead: the walk stops as
    soon as it proves that (a clipped margin needs no more). ``dirs`` (t, rank),
    when given, receives each row's last direction of the walk (a facet normal at the
    optimum, a separating direction past ``cap``)."""
    from modquad_gym.oracle import kernels

    prep, _, (G, P, k) = _prepared(z)
    out = np.empty(len(R))
    dirs = np.empty((0, z.rank)) if dirs is None else dirs
    kernels.gamma_rows(G, P, prep, _rows(R, k), float(cap), out, dirs)
    if k != 1.0 and len(dirs):
        dirs *= k  # y / k in the walked coordinates
    rest = np.flatnonzero(np.isnan(out))
    if len(rest):
        out[rest] = gamma_daqp(z, R[rest])
    return out


def gamma_compiled_from(
    z: Zonotope,
    R: np.ndarray,
    cap: float,
    starts: np.ndarray,
    signs: np.ndarray,
    out: np.ndarray | None = None,
) -> np.ndarray:
    """gamma as :func:`gamma_compiled` with ``cap``, each row's walk started at the vertex of
    its row of ``starts`` (int64 (t, rank - 1) tight columns; -1: no start) with the column
    bounds of its row of ``signs`` (int8 (t, m), 0: unknown): the optimal vertices of a similar
    zonotope (one module less) for the same wrenches start next to the optimum, where the crash
    to a first vertex costs as much as the pivots. Both arrays then hold each row's optimal
    vertex (-1 and 0 where the walk stopped elsewhere). ``out`` (t,), when given, is filled in
    place: only its nan rows are computed, the others are the caller's (no vertex)."""
    from modquad_gym.oracle import kernels

    prep, _, (G, P, k) = _prepared(z)
    out = np.full(len(R), np.nan) if out is None else out
    kernels.gamma_rows_from(
        G, P, prep, _rows(R, k), float(cap), out, np.empty((0, z.rank)), starts, signs
    )
    rest = np.flatnonzero(np.isnan(out))
    if len(rest):
        out[rest] = gamma_daqp(z, R[rest])
    return out


def screen_compiled(
    z: Zonotope, W: np.ndarray, WD: np.ndarray, h: np.ndarray, slack: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(per_wrench (t,), verdict int8 (t,), counts (tested, feasible, undecided)) of raw
    wrenches W (t, 6) after the screen ``per_wrench = max_d (WD - h) <= slack``: verdict -2 where
    the screen rejects a wrench (not tested), 0 / 1 decided, -1 undecided (near the off-range
    rule, huge, or no certificate: the caller settles those by an LP)."""
    from modquad_gym.oracle import kernels

    prep, memory, (G, P, k) = _prepared(z)
    f_max = z.f_max / k  # the walked coordinates: w / f_max, and the rule's f_max, times k
    if not 0.0 < f_max < np.inf:  # out of the float range: the screen alone, the LP decides
        per_wrench = np.max(WD - h, axis=1, initial=-np.inf)
        verdict = np.where(per_wrench <= slack, -1, -2).astype(np.int8)
        tested = int(np.count_nonzero(verdict == -1))
        return per_wrench, verdict, np.array([tested, 0, tested])
    per_wrench = np.empty(len(W))
    verdict = np.empty(len(W), dtype=np.int8)
    counts = np.zeros(3, dtype=np.int64)
    kernels.decide_screened(W, WD, h, slack, f_max, k, z.Q, z.c * k, G, P, prep, memory,
                            per_wrench, verdict, counts)  # fmt: skip
    return per_wrench, verdict, counts
