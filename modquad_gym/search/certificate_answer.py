"""The answer's part of a certificate (:mod:`.certificates`): its cells, its types and thrusts
that reach every task wrench (after every single failure of a tolerant answer) within the
checker's tolerances (:func:`~modquad_gym.proofcheck.residual_allowed`)."""

from __future__ import annotations

import numpy as np

from modquad_gym import proofcheck as pc


class CertificateError(ValueError):
    """The result cannot be certified (not certified, or a level too large to prove)."""


def answer(structure, problem, T, task, f_max, fault) -> dict:
    """The answer's cells, types and thrusts for every wrench (after every failure)."""
    cells = np.asarray(structure.cells, dtype=np.int64)
    types = _type_indices(structure, problem.palette)
    if types.min() < 0:
        raise CertificateError("the answer has a module type outside the problem's palette")
    a, M, j, j_size = T.columns(cells[None].astype(float), types[None], sizes=True)
    A, t = a[0].T, len(task[0])
    W, size = (pc.wrenches(task, np.arange(t), np.repeat(M, t), np.repeat(x, t, axis=0), b)
               for x, b in ((j, False), (j_size, True)))  # fmt: skip
    m, n = A.shape[1], len(cells)
    fails = (
        [np.zeros(m, bool)]
        if fault is None
        else list(pc.failed_columns(fault, np.arange(m if fault == "rotor" else n), n, T.rotors))
    )
    allocations = [_allocate(A, W, size, f_max, ~off) for off in fails]
    return {"cells": cells.tolist(), "types": types.tolist(), "allocations": allocations}


def _allocate(A, W, size, f_max, keep) -> list:
    """(t, m) thrusts reaching each wrench with the columns ``keep`` (the others zero): the
    least-norm correction of half thrust where it stays within [0, f_max] and well within the
    checker's residual (``size``: the wrenches' term magnitudes), else the most centred
    allocation of the oracle's LP, corrected onto A u = w by least squares."""
    from modquad_gym.oracle import Zonotope

    B = A[:, keep]
    pinv = np.linalg.pinv(B)
    half = np.full(B.shape[1], f_max / 2.0)
    U = np.zeros((len(W), A.shape[1]))
    U[:, keep] = half + (W - B @ half) @ pinv.T
    inside = (U[:, keep] >= 0).all(axis=1) & (U[:, keep] <= f_max).all(axis=1)
    allowed = 1e-3 * pc.residual_allowed(B, W, size, f_max)
    resid = (np.abs(U @ A.T - W) <= allowed).all(axis=1)
    rest = np.flatnonzero(~(inside & resid))
    if len(rest):
        z = Zonotope(B, f_max)
        R, off = z.reduce(W[rest])
        if off.any():
            raise CertificateError(f"the answer cannot exert wrench {rest[np.argmax(off)]}")
        for i, r in zip(rest, R):
            u = (1.0 + centred_allocation(z, r)) * (f_max / 2.0)
            U[i, keep] = u - pinv @ (B @ u - W[i])
    band = pc.THRUST_TOL * f_max
    outside = (U[:, keep] < -band).any(axis=1) | (U[:, keep] > f_max + band).any(axis=1)
    missed = ~(np.abs(U @ A.T - W) <= pc.residual_allowed(B, W, size, f_max)).all(axis=1)
    if (outside | missed).any():  # the oracle accepted it within its tolerances
        k = int(np.argmax(outside | missed))
        band_why = "thrusts beyond the oracle's band (its round-off decided it): too close"
        range_why = ("a residual within the oracle's off-range tolerance (1e-9 of f_max + |w|), "
                     "beyond a certificate's (1e-11 of each component's scale)")  # fmt: skip
        why = band_why if outside[k] else range_why
        raise CertificateError(f"the answer reaches wrench {k} only with {why}: no certificate")
    return U.tolist()


def centred_allocation(z, r: np.ndarray) -> np.ndarray:
    """The most centred allocation x (G x = r, |x|_inf = gamma) of one centred reduced wrench:
    the DAQP LP of the oracle (:mod:`modquad_gym.oracle.daqp_lp`), HiGHS when DAQP fails."""
    import daqp

    from modquad_gym.oracle.lp import GammaLP, ray_cost, ray_matrix

    nr = float(np.linalg.norm(r))
    if nr <= 1e-14 * max(z.scale, 1.0):
        return np.zeros(z.m)
    m = z.m
    x, _, flag, _ = daqp.solve(
        np.zeros((m + 1, m + 1)), ray_cost(m), ray_matrix(z.G, r / nr),
        np.concatenate([np.ones(m), [1e30], np.zeros(z.rank)]),
        np.concatenate([-np.ones(m), [0.0], np.zeros(z.rank)]),
        np.array([0] * (m + 1) + [5] * z.rank, dtype=np.int32),
    )  # fmt: skip
    if flag == 1 and x[-1] > 0:
        return x[:m] * (nr / x[-1])
    return GammaLP.build(z.G).solve(r).x[:-1]


def _type_indices(structure, palette) -> np.ndarray:
    ids = {id(m): k for k, m in enumerate(palette)}
    digests = {m.digest: k for k, m in enumerate(palette)}
    return np.array([ids.get(id(m), digests.get(m.digest, -1)) for m in structure.modules])
