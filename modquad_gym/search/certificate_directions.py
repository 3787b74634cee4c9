"""Candidate separating directions of one smaller structure, for a certificate's proofs
(:mod:`.certificates`), and the words of a refusal when none is strong enough.

The oracle's LP dual comes first: a facet normal, the best direction when the wrench lies
beyond a facet. Beyond a vertex or an edge of the zonotope every normal of its cone separates
as well by the LP's measure (gamma), and the LP returns one of them, which may be far weaker in
the checker's test (its tolerance grows with the Euclidean length of the direction, and every
rotor not beyond the proofs' band costs B |d . a_k|): for one module that must lift a little
more than its four rotors at full thrust, the dual is mostly a yaw torque and separates 8 times
less than the lift itself. So more directions follow, tried only when the dual fails: the push
of the rotors that the oracle's allocation drives beyond the band, with the other rotors'
columns projected out (:func:`vertex_direction`), then the wrench itself, its part centred on
the zonotope (both in range(A)), its force part and its torque part. Re-solving the LP with the
proofs' wider band gives nothing new: widening every thrust range by the band scales the
centred zonotope about its centre, which leaves the LP's duals alone.
"""

from __future__ import annotations

import math

import numpy as np

from modquad_gym import proofcheck as pc
from modquad_gym.search.certificate_answer import centred_allocation


def candidates(A: np.ndarray, W: np.ndarray, f_max: float):
    """Yield (direction in wrench space (6,), wrench index, excess) for the structure of matrix
    A against the wrenches W (t, 6): the off-range part of the first wrench off range(A), then,
    for each wrench the oracle rejects (hardest first), its LP dual, :func:`vertex_direction`
    and :func:`own_directions`. ``excess``: the least thrust beyond [0, f_max], in units of
    f_max, with which A reaches that wrench ((gamma - 1) / 2 of the oracle's LP; inf off
    range). Nothing when A satisfies every wrench (the oracle's decision). Lazy: a wrench's LP
    is solved only when the caller asks for more than the directions before."""
    from modquad_gym.oracle import TOL, Zonotope
    from modquad_gym.oracle.backends import decide_with

    z = Zonotope(A, f_max)
    R, off = z.reduce(W)
    if off.any():
        i = int(np.argmax(off))
        yield W[i] - z.Q @ (z.Q.T @ W[i]), i, math.inf
    bad = np.flatnonzero(~decide_with(z, W, "auto"))  # the oracle's exact decisions
    for i in bad[np.argsort(-np.linalg.norm(W[bad], axis=1), kind="stable")]:  # hardest first
        gamma, d = z.separating_direction(R[i])
        if not gamma > 1.0 + TOL:
            continue
        excess = (gamma - 1.0) / 2.0
        if np.any(d):
            yield z.Q @ d, int(i), excess
        v = vertex_direction(z, R[i])
        if v is not None:
            yield v, int(i), excess
        for v in own_directions(W[i], z.Q @ R[i] * f_max, z.Q):
            yield v, int(i), excess


def vertex_direction(z, r: np.ndarray) -> np.ndarray | None:
    """The direction that the proofs' band leaves the most room in, for the centred reduced
    wrench ``r`` of zonotope ``z``: with x the oracle's most centred allocation (G x = r), the
    rotors beyond the band (|x_k| > 1 + 2 B) push along sign(x_k) a_k, and each other rotor
    costs B |d . a_k| in the checker's test, so the direction is the sum of the former pushes
    with the other columns' span projected out (None when no rotor is beyond the band, or
    nothing is left)."""
    x = centred_allocation(z, r)
    beyond = np.abs(x) > 1.0 + 2.0 * pc.PROOF_BAND
    if not beyond.any():
        return None
    v = z.A[:, beyond] @ np.sign(x[beyond])
    rest = z.A[:, ~beyond]
    if rest.shape[1] and np.any(rest):
        U, S, _ = np.linalg.svd(rest, full_matrices=False)
        span = U[:, S > 1e-9 * S[0]]
        v = v - span @ (span.T @ v)
    return v if np.linalg.norm(v) > 1e-12 * np.linalg.norm(z.A) else None


def own_directions(w: np.ndarray, centred: np.ndarray, Q: np.ndarray) -> list[np.ndarray]:
    """The non-zero, distinct directions read off one wrench ``w``: its part in range(A)
    (columns of ``Q``), ``centred`` (w less the zonotope's centre, in range(A)), its force part
    and its torque part."""
    force, torque = np.zeros(6), np.zeros(6)
    force[:3], torque[3:] = w[:3], w[3:]
    out: list[np.ndarray] = []
    for v in (Q @ (Q.T @ w), centred, force, torque):
        n = float(np.linalg.norm(v))
        if n > 0 and np.isfinite(n) and not any(np.allclose(v / n, u, 0, 1e-12) for u in out):
            out.append(v / n)
    return out


def too_close(what: str, wrench: int, excess: float, strict: float) -> str:
    """Why no direction tried separates ``what`` (a structure, maybe after a failure) from
    the task's ``wrench`` (0-based, named 1-based), which it reaches only with thrusts
    ``excess`` f_max beyond [0, f_max] (inf: off its range)."""
    row = f"wrench row {wrench + 1} of the task (1-based; a motion's repeated samples once)"
    if not np.isfinite(excess):
        return (
            f"{what} leaves {row} off its range by so little that no direction separates it "
            f"by {strict:g} times the checker's tolerance: no certificate"
        )
    head = f"{what} reaches {row} only with thrusts {excess:.6g} f_max beyond [0, f_max]"
    if excess <= pc.PROOF_BAND:
        return (
            f"{head}: the oracle rejects it (beyond its {pc.THRUST_TOL:g}) but the proofs "
            f"exclude only thrusts beyond {pc.PROOF_BAND:g} f_max, so no certificate exists"
        )
    return (
        f"{head}, so close to the proofs' band ({pc.PROOF_BAND:g} f_max) that no direction "
        "tried (the oracle's LP dual, the push of its rotors beyond the band, the wrench's own) "
        f"separates it by {strict:g} times the checker's tolerance: no certificate"
    )
