"""Feedback gains of one segment (an LQR, an LQI with an unknown load, or the PD fallback) and
the corrective wrenches they command.

The LQR's cost mimics critically damped PD loops on acceleration: state weights ``omega_pos^4``
(position), ``omega_att^4`` (attitude), ``(4 damping^2 - 2) omega^2`` (rates), input cost
``|M^-1 A du|^2`` (plus a tiny ``|du|^2`` for uniqueness). For a full-rank structure this is the
PD with natural frequencies ``omega_pos`` and ``omega_att`` (up to the small tilt coupling); for
a line it also uses the tilt coupling (:mod:`.linearization`), and the position along the
unreachable direction ``M n`` is weighted ``unreachable_weight`` times more so that the
tilt-to-translate loop is not much slower than the others. With an unknown load the integrals
of the position error and of the attitude directions in which a level rest can be pinned are
added as states (weights ``omega_int^2 omega^4``): for a rank-5 line the two attitude directions
orthogonal to ``g = G^T n`` (at rest ``g . theta = 0`` anyway). If the Riccati equation has no
stabilising solution (body-following load on a line, a single module, no hover thrust) the
segment runs the fallback ``P [R^T m (-Kp e_p - Kd v) ; J (-Kr theta - Kw omega)]`` with
``P = A A^+``, so the allocation never fights an unreachable direction.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from modquad_gym.sim.hover.config import HoverGains
from modquad_gym.sim.hover.linearization import (
    Plant,
    hover_linearization,
    unreachable_wrench_directions,
)
from modquad_gym.sim.hover.rotations import cross

LQR, PD_FALLBACK = "lqr", "pd_fallback"


@dataclass
class Design:
    """Gains of one segment: LQR (K, and K_i, C for the integral) or the PD fallback."""

    kind: str  # LQR or PD_FALLBACK
    K: np.ndarray | None = None
    Ki: np.ndarray | None = None
    C: np.ndarray | None = None
    w: np.ndarray | None = None


def _mass_matrix(mass: float, J: np.ndarray) -> np.ndarray:
    M = np.zeros((6, 6))
    M[:3, :3] = np.eye(3) * mass
    M[3:, 3:] = J
    return M


def _state_weights(gains: HoverGains, Mmat: np.ndarray, N: np.ndarray) -> np.ndarray:
    """Q (12, 12) of the LQR, the unreachable directions weighted up."""
    wp, wa, z = gains.omega_pos, gains.omega_att, gains.damping
    rate = max(4.0 * z * z - 2.0, 0.0)
    q = [wp**4, wa**4, rate * wp**2, rate * wa**2]  # position, attitude, velocity, rates
    Q = np.diag(np.repeat(q, 3))
    for j in range(N.shape[1]):
        d = Mmat @ N[:, j]
        d /= np.linalg.norm(d)
        Q[:6, :6] += gains.unreachable_weight * wp**4 * np.outer(d, d)
        Q[6:, 6:] += gains.unreachable_weight * rate * wp**2 * np.outer(d, d)
    return Q


def _integrated(F: np.ndarray, N: np.ndarray, Mmat: np.ndarray, load_frame: str) -> np.ndarray:
    """C (k, 6): the integrated errors, e_p and the attitude directions a level rest can pin."""
    if N.shape[1]:
        G = F[6:, 3:6] if load_frame == "world" else np.zeros((6, 3))
        NG = N.T @ (Mmat @ G)
        _, sv, vt = np.linalg.svd(NG)
        r = int(np.sum(sv > 1e-9 * max(1.0, float(np.abs(NG).max(initial=0.0)))))
        Bth = vt[r:].T
    else:
        Bth = np.eye(3)
    C = np.zeros((3 + Bth.shape[1], 6))
    C[:3, :3] = np.eye(3)
    C[3:, 3:] = Bth.T
    return C


def _augment(F, B, Q, C, N, Mmat, gains: HoverGains):
    """The LQI problem: F, B, Q extended by the integrals C (e_p, theta)."""
    wp, wa = gains.omega_pos, gains.omega_att
    k = C.shape[0]
    Fa = np.zeros((12 + k, 12 + k))
    Fa[:12, :12] = F
    Fa[12:, :6] = C
    Ba = np.vstack([B, np.zeros((k, B.shape[1]))])
    qi = gains.omega_int**2 * np.concatenate([np.full(3, wp**4), np.full(k - 3, wa**4)])
    Qa = np.zeros((12 + k, 12 + k))
    Qa[:12, :12] = Q
    Qa[12:, 12:] = np.diag(qi)
    for j in range(N.shape[1]):  # the unreachable direction's integral, weighted likewise
        d = C @ (Mmat @ N[:, j])
        if np.linalg.norm(d) > 1e-12:
            d /= np.linalg.norm(d)
            qd = gains.unreachable_weight * gains.omega_int**2 * wp**4
            Qa[12:, 12:] += qd * np.outer(d, d)
    return Fa, Ba, Qa


def _stabilising_gain(F, B, Q, Rm) -> np.ndarray | None:
    """The LQR gain, or None when the Riccati equation has no stabilising solution."""
    from scipy.linalg import solve_continuous_are

    try:
        P = solve_continuous_are(F, B, Q, Rm)
        K = np.linalg.solve(Rm, B.T @ P)
        ok = bool(np.all(np.isfinite(K)))
        if ok:
            ok = float(np.linalg.eigvals(F - B @ K).real.max()) < -1e-2
    except (np.linalg.LinAlgError, ValueError):
        ok = False
    return K if ok else None


def design_gains(
    A: np.ndarray,
    w: np.ndarray,
    mass: float,
    J: np.ndarray,
    gains: HoverGains,
    load_frame: str,
    integral: bool,
) -> Design:
    """LQR (LQI with ``integral``) gains at w; the PD fallback if none stabilises."""
    F, B = hover_linearization(A, w, mass, J, load_frame)
    Mmat = _mass_matrix(mass, J)
    N = unreachable_wrench_directions(A)
    Q = _state_weights(gains, Mmat, N)
    MA = B[6:]
    Rm = MA.T @ MA
    Rm += 1e-6 * max(float(np.trace(Rm)) / Rm.shape[0], 1e-12) * np.eye(Rm.shape[0])
    C = None
    if integral:
        C = _integrated(F, N, Mmat, load_frame)
        F, B, Q = _augment(F, B, Q, C, N, Mmat, gains)
    K = _stabilising_gain(F, B, Q, Rm)
    if K is None:
        return Design(PD_FALLBACK, w=w)
    return Design(LQR, K=K[:, :12], Ki=K[:, 12:] if integral else None, C=C, w=w)


def corrections(
    des: Design,
    plant: Plant,
    gains: HoverGains,
    state: tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray],
) -> tuple[np.ndarray, np.ndarray]:
    """(attitude, position) corrective wrenches at ``state = (R, e_p, theta, v, omega)``.

    The attitude part includes the gyroscopic term ``P [0 ; omega x J omega]``."""
    R, e_p, theta, v, omega = state
    A, P, m, J = plant.A, plant.P, plant.mass, plant.J
    gyro = P @ np.concatenate([np.zeros(3), cross(omega, J @ omega)])
    if des.kind == LQR:
        w_att = A @ (-des.K[:, 3:6] @ theta - des.K[:, 9:] @ omega) + gyro
        w_pos = A @ (-des.K[:, :3] @ e_p - des.K[:, 6:9] @ v)
        return w_att, w_pos
    kp_p, kd_p = gains.omega_pos**2, 2 * gains.damping * gains.omega_pos
    kp_r, kd_r = gains.omega_att**2, 2 * gains.damping * gains.omega_att
    f_corr = R.T @ (m * (-kp_p * e_p - kd_p * v))
    t_corr = J @ (-kp_r * theta - kd_r * omega)
    w_att = P @ np.concatenate([np.zeros(3), t_corr]) + gyro
    w_pos = P @ np.concatenate([f_corr, np.zeros(3)])
    return w_att, w_pos


def integral_rate(
    des: Design, plant: Plant, gains: HoverGains, R: np.ndarray, e_p: np.ndarray, theta: np.ndarray
) -> np.ndarray:
    """d/dt of the integral part of the load estimate (velocity form: bumpless rescheduling)."""
    if des.kind == LQR:
        return -(plant.A @ (des.Ki @ (des.C @ np.concatenate([e_p, theta]))))
    ki_p = gains.omega_int * gains.omega_pos**2
    ki_r = gains.omega_int * gains.omega_att**2
    c = np.concatenate([R.T @ (-plant.mass * ki_p * e_p), plant.J @ (-ki_r * theta)])
    return plant.P @ c
