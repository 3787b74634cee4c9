"""Inertias a simulator accepts: the checks and forms shared by the MuJoCo model
(:mod:`modquad_gym.sim.model`) and the URDF export (:mod:`modquad_gym.sim.export`).

MuJoCo compiles a moving body only if its principal moments are each larger than ``mjMINVAL``
(:data:`MJ_MINVAL`) and obey the triangle inequality A + B >= C, checked exactly, without a
tolerance, on the moments of its own eigen-decomposition. A module type's inertia may be one
that no simulator takes (``ModuleType`` accepts every physical inertia, zero included: the
searches do not use it); :func:`check_simulable` refuses such a type before any model is built.

A flat body (a module of height 0, a structure of them) lies exactly on the triangle boundary
(C = A + B), where round-off decides MuJoCo's check. Two forms keep such bodies loading:

* :func:`principal_axes`: the body's inertia as principal axes and moments whose largest moment
  is at most the sum of the other two in floating point (MuJoCo then takes the moments as
  written; the MJCF body uses it);
* :func:`thickened`: an inertia whose thinnest second moment is at least :data:`FLAT_RATIO` of
  its largest (the plate given a thickness of about 3e-4 of its width: a change of at most
  1e-7 of the largest moment, and none at all for a body that is not flat). The URDF, whose
  reader rotates each tensor into its link frame before MuJoCo checks it, needs this margin;
* :func:`six_digit_moments`: the moments as the MJCF text holds them (MuJoCo's writer keeps 6
  digits), rounded so that the text keeps A + B >= C too.
"""

from __future__ import annotations

import itertools
from collections.abc import Iterable

import numpy as np

from modquad_gym.geometry.inertia import inertia_about_com
from modquad_gym.geometry.module import ModuleType
from modquad_gym.geometry.structure import Structure

MJ_MINVAL = 1e-15
"""MuJoCo's ``mjMINVAL``: the least mass and principal moment of a moving body."""

ROTOR_MASS_FRACTION = 0.01
"""The largest share of its module's mass (and inertia) that each URDF propeller link carries
(3 g of a 0.3 kg module: a small propeller; :func:`rotor_share`); ``base_link`` carries the
rest."""

FLAT_RATIO = 1e-7
"""Least ratio of a URDF body's thinnest second moment to its largest (:func:`thickened`)."""


def check_simulable(types: Structure | Iterable[ModuleType]) -> None:
    """A ValueError naming the first module type (of a structure, or of ``types``) whose
    inertia MuJoCo cannot compile: a principal moment not larger than :data:`MJ_MINVAL` (a point
    or a rod) or one larger than the sum of the other two (MuJoCo checks A + B >= C without a
    tolerance)."""
    for m in types.palette if isinstance(types, Structure) else types:
        p = np.linalg.eigvalsh(m.inertia)
        if not (p[0] > MJ_MINVAL and p[0] + p[1] >= p[2]):
            raise ValueError(
                f"module type {m.name!r}: inertia with principal moments "
                f"{[float(f'{v:.6g}') for v in p]} kg m^2 cannot be simulated: each must exceed "
                f"{MJ_MINVAL:g} and be at most the sum of the other two (MuJoCo's rule)"
            )


def second_moment(J: np.ndarray) -> np.ndarray:
    """The second moment of mass sum m r r^T of the body of inertia ``J`` (same point and
    axes): tr(J)/2 I - J. A body's inertia is physical exactly when this is positive
    semi-definite (its eigenvalues sigma_i = (A_j + A_k - A_i) / 2 >= 0)."""
    J = np.asarray(J, dtype=float)
    return np.trace(J) / 2 * np.eye(3) - J


def thickened(J: np.ndarray, ratio: float = FLAT_RATIO) -> np.ndarray:
    """``J`` itself unless its thinnest second moment is below ``ratio`` of its largest; then
    the inertia with those second moments raised to that floor (module docstring)."""
    S = second_moment(J)
    w, V = np.linalg.eigh(S)
    floor = ratio * w[-1]
    if w[0] >= floor:
        return np.asarray(J, dtype=float)
    S = (V * np.maximum(w, floor)) @ V.T
    return np.trace(S) * np.eye(3) - S


def principal_axes(J: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(quaternion (w, x, y, z), principal moments (3,)) of the symmetric ``J``: the moments
    about the axes of the rotation R (J = R diag(moments) R^T), the axes ordered and signed to
    be nearest the body's own (a diagonal ``J`` keeps its axes: the identity), and the largest
    moment at most the sum of the other two in floating point (where round-off put it just
    above, as for a flat body)."""
    w, V = np.linalg.eigh((np.asarray(J, dtype=float) + np.asarray(J, dtype=float).T) / 2)
    perm = max(
        itertools.permutations(range(3)), key=lambda p: sum(abs(V[i, p[i]]) for i in range(3))
    )
    V, w = V[:, perm], w[list(perm)]
    V = V * np.where(np.diag(V) < 0, -1.0, 1.0)
    if np.linalg.det(V) < 0:
        V[:, int(np.argmin(np.abs(np.diag(V))))] *= -1.0
    i = int(np.argmax(w))
    w[i] = min(w[i], w[(i + 1) % 3] + w[(i + 2) % 3])
    from scipy.spatial.transform import Rotation

    x, y, z, s = Rotation.from_matrix(V).as_quat(canonical=True)
    return np.array([s, x, y, z]), w


def rotor_share(m: ModuleType, most: float) -> float:
    """The share f of module type ``m``'s mass and (thickened) inertia that each of its URDF
    propeller links carries: ``most``, halved until what the module keeps, about its own
    centre of mass, has at least half of the second moment (1 - r f) J_m leaves it in every
    direction (so that the URDF's ``base_link`` is a body with a margin). A ValueError naming
    the type's inertia when no share of at least 1e-6 of ``most`` fits (its rotors lie outside
    the body its inertia describes) or when the propellers would fall below MuJoCo's least
    mass or moment."""
    S = second_moment(thickened(m.inertia))
    q = m.positions
    r, Q, s = m.n_rotors, q.T @ q, q.sum(axis=0)
    f = min(most, 0.5 / r)
    tol = 1e-12 * float(np.abs(S).max())
    while f >= 1e-6 * most:
        keep = 1.0 - r * f
        rest = keep * S - f * m.mass * Q - f * f * m.mass * np.outer(s, s) / keep
        if np.linalg.eigvalsh(rest - keep / 2 * S)[0] >= -tol:
            if min(f * m.mass, f * np.linalg.eigvalsh(thickened(m.inertia))[0]) > MJ_MINVAL:
                return f
            break
        f /= 2
    raise ValueError(
        f"module type {m.name!r}: its inertia leaves no room for its {r} rotors' mass at their "
        "positions, so the URDF's propeller links cannot carry any; give the type an inertia "
        "that includes its rotors"
    )


def six_digit_moments(moments: np.ndarray) -> list[float]:
    """Principal ``moments`` rounded to 6 significant digits (what MuJoCo's XML writer keeps),
    the largest then lowered by units of its 6th digit until it is at most the sum of the
    other two: a text that keeps A + B >= C where the exact moments did."""
    w = [float(f"{v:.6g}") for v in moments]
    i = int(np.argmax(w))
    while w[i] > w[(i + 1) % 3] + w[(i + 2) % 3]:
        w[i] = float(f"{w[i] - 10.0 ** (np.floor(np.log10(w[i])) - 5):.6g}")
    return w


def base_inertial(structure: Structure) -> tuple[float, np.ndarray, np.ndarray]:
    """(mass, COM (3,) in {S}, inertia (3, 3) about that COM) of the URDF's ``base_link``: the
    structure less its propeller links, so that base and propellers together have exactly the
    structure's mass, COM (the origin) and inertia about the COM (a flat module type's
    thickened: :func:`~modquad_gym.sim.inertial.thickened`)."""
    s = structure
    P = np.asarray(s.rotor_positions, dtype=float)
    masses, own = propeller_inertials(s)
    mass = s.mass - masses.sum()
    com = -(masses @ P) / mass  # the whole robot's COM stays at the origin
    modules = [thickened(m.inertia) for m in s.modules]
    J = inertia_about_com(s.module_centres, s.masses, modules) - inertia_about_com(P, masses, own)
    J -= mass * (np.eye(3) * (com @ com) - np.outer(com, com))  # about the base's own COM
    return mass, com, (J + J.T) / 2


def propeller_inertials(structure: Structure) -> tuple[np.ndarray, np.ndarray]:
    """(masses (R,), inertias (R, 3, 3) about their centres in {S} axes) of the R propeller
    links, one per rotor in rotor order: each the share :func:`rotor_share` of its module's
    mass and thickened inertia (one share per module type)."""
    share = {id(m): rotor_share(m, ROTOR_MASS_FRACTION) for m in structure.palette}
    masses, own = [], []
    for m in structure.modules:
        f = share[id(m)]
        masses += [f * m.mass] * m.n_rotors
        own += [f * thickened(m.inertia)] * m.n_rotors
    return np.array(masses), np.array(own)
