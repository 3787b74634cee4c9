"""The rigid body the hover controls (:class:`Plant`) and its linearisation about level hover.

Rank-deficient structures: every producible wrench A u lies in range(A). For a straight line of
modules (rank 5) the missing direction n (``A^T n = 0``, :func:`unreachable_wrench_directions`)
is, for a line along x with the default T-module, ``n = (0, 0.1497, 0, 0.9887, 0, 0)``:
``0.1497 f_y + 0.9887 tau_x = 0`` for every u. Read as a screw (:func:`wrench_axis`), no rotor
wrench has a moment about the axis parallel to the line through the point 0.151 m above the
COM. In acceleration terms the body cannot get ``n^T M [a ; alpha] != 0`` (M = diag(m I, J)).

* Under a body-following load the net wrench stays in range(A) at every attitude, so the
  linearisation has an uncontrollable double integrator (sideways position mixed with roll about
  the line): no linear feedback damps it, and the hover falls back to the projected PD there.
* Under the world-fixed load (default) the tilt coupling ``G theta`` feeds the missing direction
  (``n^T G theta`` contains ``0.1497 w_z theta_x`` for a line along x): the line rolls to push
  itself sideways, like a quadrotor, so the linearisation is controllable whenever the hover
  thrust is not zero. A single module (rank 4, two missing directions) is stabilisable the same
  way. A wrench off range(A) cannot be held by anything.

State ``x = [p - p_ref, theta, v, omega]`` (world position error, rotation vector of R, world
velocity, body rates); ``d/dt [p; theta] = [v; omega]``, ``M d/dt [v; omega] = A du + G theta``
with ``G = -[[w_f]x ; [w_tau]x]`` (world-fixed load) or ``G = 0`` (body-following load).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from modquad_gym.sim.hover.config import LOAD_FRAMES
from modquad_gym.sim.hover.rotations import skew
from modquad_gym.sim.model import SimModel


def body_inertia(sim: SimModel) -> np.ndarray:
    """J (3, 3): the structure's inertia about its COM in {S}."""
    m = sim.model
    b = sim.body_id
    w, x, y, z = m.body_iquat[b]
    Q = np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
            [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
            [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
        ]
    )
    return Q @ np.diag(m.body_inertia[b]) @ Q.T


def inverse_inertia(mass: float, J: np.ndarray) -> np.ndarray:
    """M^-1 (6, 6) for M = diag(m I, J)."""
    Minv = np.zeros((6, 6))
    Minv[:3, :3] = np.eye(3) / mass
    Minv[3:, 3:] = np.linalg.inv(J)
    return Minv


@dataclass(frozen=True)
class Plant:
    """What the controller knows of the body: A, f_max, mass, inertia and derived matrices."""

    A: np.ndarray
    f_max: float
    mass: float
    J: np.ndarray
    Minv: np.ndarray
    pinv: np.ndarray
    P: np.ndarray  # A A^+, the projection onto range(A)

    @classmethod
    def of(cls, sim: SimModel) -> Plant:
        """The plant of a flight model (the controller's model is exact in this simulation)."""
        return cls.build(sim.A, sim.f_max, sim.mass, body_inertia(sim))

    @classmethod
    def build(cls, A: np.ndarray, f_max: float, mass: float, J: np.ndarray) -> Plant:
        """The plant of configuration matrix A, thrust limit, mass and inertia J about the COM."""
        pinv = np.linalg.pinv(A)
        return cls(A, f_max, mass, J, inverse_inertia(mass, J), pinv, A @ pinv)

    @property
    def trim(self) -> np.ndarray:
        """The take-off trim wrench: every rotor at half thrust (the feasible set's centre)."""
        return self.A.sum(axis=1) * self.f_max / 2.0


def unreachable_wrench_directions(A: np.ndarray, rtol: float = 1e-9) -> np.ndarray:
    """(6, 6 - rank A): an orthonormal basis of the wrench directions A can never produce.

    Each column n satisfies ``n . (A u) = 0`` for every u (the left null space of A). Empty
    (6, 0) for a full-rank structure, one column for a straight line, two for one module. The
    sign of each column is fixed so that its largest entry is positive.
    """
    A = np.asarray(A, dtype=float)
    U, s, _ = np.linalg.svd(A)
    rank = int(np.sum(s > rtol * s[0])) if s.size and s[0] > 0 else 0
    N = U[:, rank:].copy()
    N[np.abs(N) < 1e-14] = 0.0
    for j in range(N.shape[1]):
        if N[np.argmax(np.abs(N[:, j])), j] < 0:
            N[:, j] *= -1.0
    return N


def wrench_axis(n: np.ndarray) -> dict:
    """Read an unreachable direction n = (n_f, n_tau) as a screw (an axis and a pitch).

    ``n . w = |n_tau| ((tau - r x f) . a + pitch f . a)`` for every wrench w = (f, tau), with the
    axis direction a = n_tau / |n_tau|, r = n_tau x n_f / |n_tau|^2 the axis point closest to the
    COM and pitch = n_f . n_tau / |n_tau|^2. So the rotors can never make a moment about that axis
    (plus pitch times force along it); with pitch 0 (straight lines), a pure moment about the axis.
    If n_tau = 0, n is a force direction the rotors cannot push along (axis None).
    """
    n = np.asarray(n, dtype=float)
    nf, nt = n[:3], n[3:]
    t2 = float(nt @ nt)

    def clean(x: np.ndarray) -> list[float]:  # round-off to exact zeros (readable reports)
        return [0.0 if abs(v) < 1e-12 else float(v) for v in x]

    if t2 < 1e-18:
        return {"axis": None, "point": None, "pitch": None, "force_direction": clean(nf)}
    pitch = float(nf @ nt / t2)
    return {
        "axis": clean(nt / math.sqrt(t2)),
        "point": clean(np.cross(nt, nf) / t2),
        "pitch": 0.0 if abs(pitch) < 1e-12 else pitch,
        "force_direction": None,
    }


def hover_linearization(
    A: np.ndarray, w: np.ndarray, mass: float, J: np.ndarray, load_frame: str = "world"
) -> tuple[np.ndarray, np.ndarray]:
    """Linearised hover about level, at the reference, with A u = w: ``dx/dt = F x + B du``.

    State x = [p - p_ref (world), theta (rotation vector), v (world), omega (body)] (12), input
    du = u - u_w (4n). ``M d/dt [v; omega] = A du + G theta`` with ``G = -[[w_f]x ; [w_tau]x]``
    for the world-fixed load (the rotor wrench tilts, the load does not) and G = 0 for the
    body-following load (module docstring).
    """
    if load_frame not in LOAD_FRAMES:
        raise ValueError(f"load_frame must be one of {LOAD_FRAMES}, got {load_frame!r}")
    Minv = inverse_inertia(mass, J)
    F = np.zeros((12, 12))
    F[:6, 6:] = np.eye(6)
    if load_frame == "world":
        G = -np.vstack([skew(w[:3]), skew(w[3:])])
        F[6:, 3:6] = Minv @ G
    B = np.zeros((12, A.shape[1]))
    B[6:] = Minv @ A
    return F, B
