"""The wrench the rotors must produce to fly a structure along a trajectory (Newton-Euler).

For a rigid body of mass m and inertia J about its COM (the {S} origin), with attitude R (world
<- body), COM acceleration a (world), body rates omega and angular acceleration alpha (body),
the rotors' wrench in {S}, torque about the COM, is

    f = m R^T (a + g e3),        tau = J alpha + omega x (J omega),

g = :data:`GRAVITY` along -z of the world. A payload (:class:`Payload`) is a point mass m_p
rigidly held at offset r in {S}: its acceleration in the body frame is
``R^T a + alpha x r + omega x (omega x r)``, so the rotors also carry

    f_p = m_p (R^T (a + g e3) + alpha x r + omega x (omega x r)),    tau_p = r x f_p.

These formulas are checked in the tests against MuJoCo's inverse dynamics (``mj_inverse``) of
the same body to 1e-9 relative.

The wrench is linear in the structure's mass m and inertia vector j (Jxx, Jyy, Jzz, Jxy, Jxz,
Jyz; :mod:`modquad_gym.geometry.inertia`): ``w = base + m per_mass + per_inertia j``
(:class:`LinearWrenches`), which lets a search decide many structures without recomputing the
dynamics, and bounds reason about mass and inertia that grow with the module count.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np

from modquad_gym.dynamics.trajectory import Trajectory
from modquad_gym.geometry.inertia import to_tensor, to_vector
from modquad_gym.geometry.module import GRAVITY
from modquad_gym.geometry.structure import Structure

E3 = np.array([0.0, 0.0, 1.0])


@dataclass(frozen=True)
class Payload:
    """A point mass rigidly held by the structure.

    Attributes:
        mass: kg, >= 0.
        offset: (3,) position in {S} relative to the structure's COM, metres (e.g. (0, 0, -0.2)
            hangs it 20 cm below the COM).
    """

    mass: float
    offset: tuple[float, float, float] = (0.0, 0.0, 0.0)

    def __post_init__(self) -> None:
        from modquad_gym.core.validation import check_real, float_array, refuse_non_numbers

        object.__setattr__(self, "mass", check_real(self.mass, "payload.mass", low=0.0))
        refuse_non_numbers(self.offset, "payload.offset", "entry")
        r = float_array(self.offset, "payload.offset", f"[x, y, z] in metres, got {self.offset!r}")
        if r.shape != (3,) or not np.all(np.isfinite(r)):
            raise ValueError(f"payload.offset must be 3 finite numbers (m), got {self.offset!r}")
        object.__setattr__(self, "offset", tuple(float(v) for v in r))
        if self.mass == 0 and np.any(r != 0):  # it would be dropped, its offset with it
            raise ValueError(
                f"payload.offset {list(self.offset)} places a payload, but payload.mass is 0 kg: "
                "give a mass above 0, or no payload"
            )

    @classmethod
    def from_dict(cls, data: object) -> Payload:
        """From ``{"mass": kg, "offset": [x, y, z]}`` (offset optional); unknown keys refused."""
        if not isinstance(data, dict):
            raise ValueError(f"payload must be an object with 'mass' (kg), got {data!r}")
        unknown = sorted(set(data) - {"mass", "offset"})
        if unknown:
            raise ValueError(f"payload.{unknown[0]}: unknown key; known: mass, offset")
        if "mass" not in data:
            raise ValueError("payload.mass: missing (required, kg)")
        return cls(data["mass"], data.get("offset", (0.0, 0.0, 0.0)))

    def to_dict(self) -> dict:
        return {"mass": self.mass, "offset": list(self.offset)}


def specific_force(trajectory: Trajectory) -> np.ndarray:
    """(k, 3) R^T (a + g e3): the rotor force per kilogram of body, in {S}."""
    return np.einsum("kji,kj->ki", trajectory.rotations(), trajectory.acceleration + GRAVITY * E3)


def rigid_body_wrenches(
    trajectory: Trajectory, mass: float, inertia: np.ndarray, payload: Payload | None = None
) -> np.ndarray:
    """(k, 6) rotor wrenches of a body of ``mass`` kg and ``inertia`` (3, 3) about its COM
    flying ``trajectory`` (module docstring), with an optional payload."""
    J = np.asarray(inertia, dtype=float)
    w, alpha = trajectory.angular_velocity, trajectory.angular_acceleration
    s = specific_force(trajectory)
    tau = alpha @ J.T + np.cross(w, w @ J.T)
    out = np.hstack([mass * s, tau])
    if payload is not None and payload.mass > 0:
        out += payload_wrenches(trajectory, payload, s)
    return out


def payload_wrenches(
    trajectory: Trajectory, payload: Payload, s: np.ndarray | None = None
) -> np.ndarray:
    """(k, 6) what the payload adds to the rotors' wrench (module docstring)."""
    s = specific_force(trajectory) if s is None else s
    r = np.asarray(payload.offset)
    w, alpha = trajectory.angular_velocity, trajectory.angular_acceleration
    acc = s + np.cross(alpha, r) + np.cross(w, np.cross(w, r))
    f = payload.mass * acc
    return np.hstack([f, np.cross(r, f)])


def required_wrenches(
    structure: Structure, trajectory: Trajectory, payload: Payload | None = None
) -> np.ndarray:
    """(k, 6) the rotor wrench in {S} about the COM that flies ``structure`` along
    ``trajectory`` (the motion of its COM), carrying ``payload``: Newton-Euler with the
    structure's :attr:`~Structure.mass` and :attr:`~Structure.inertia` (module docstring)."""
    if not isinstance(structure, Structure):
        raise ValueError(f"structure must be a Structure, got {type(structure).__name__}")
    if not isinstance(trajectory, Trajectory):
        raise ValueError(f"trajectory must be a Trajectory, got {type(trajectory).__name__}")
    if payload is not None and not isinstance(payload, Payload):
        raise ValueError(f"payload must be a Payload or None, got {type(payload).__name__}")
    return rigid_body_wrenches(trajectory, structure.mass, structure.inertia, payload)


@dataclass(frozen=True, eq=False)
class LinearWrenches:
    """Rotor wrenches linear in a structure's mass m and inertia vector j:
    ``W(m, j) = base + m per_mass + per_inertia @ j``.

    Attributes:
        base: (k, 6) what does not depend on the structure (payload, exerted wrenches).
        per_mass: (k, 6) the wrench per kg of structure (specific force; no torque: the weight
            and the inertial force act at the COM).
        per_inertia: (k, 6, 6) the wrench per unit of each inertia component (torque rows only).
    """

    base: np.ndarray
    per_mass: np.ndarray
    per_inertia: np.ndarray

    @classmethod
    def of(
        cls,
        trajectory: Trajectory,
        payload: Payload | None = None,
        exerted: np.ndarray | None = None,
    ) -> LinearWrenches:
        """The decomposition for a trajectory, a payload and exerted wrenches (k, 6)."""
        k = trajectory.n_samples
        s = specific_force(trajectory)
        base = np.zeros((k, 6))
        if payload is not None and payload.mass > 0:
            base += payload_wrenches(trajectory, payload, s)
        if exerted is not None:
            base += exerted
        per_mass = np.hstack([s, np.zeros((k, 3))])
        per_inertia = np.zeros((k, 6, 6))
        if not trajectory.is_level:
            w, alpha = trajectory.angular_velocity, trajectory.angular_acceleration
            for c, E in enumerate(to_tensor(np.eye(6))):
                per_inertia[:, 3:, c] = alpha @ E.T + np.cross(w, w @ E.T)
        for a in (base, per_mass, per_inertia):
            a.setflags(write=False)
        return cls(base, per_mass, per_inertia)

    @classmethod
    def of_static(cls, wrenches: np.ndarray, carries_weight: bool = False) -> LinearWrenches:
        """The model of static task wrenches (t, 6): the wrenches themselves, plus the
        structure's weight ``m g e_z`` when the rotors also carry it (a task of kind
        ``external``; the weight acts at the COM, so it adds no torque)."""
        base = np.array(wrenches, dtype=float)
        per_mass = np.zeros_like(base)
        if carries_weight:
            per_mass[:, 2] = GRAVITY
        per_inertia = np.broadcast_to(np.zeros((1, 6, 6)), (len(base), 6, 6))  # no copy
        for a in (base, per_mass):
            a.setflags(write=False)
        model = cls(base, per_mass, per_inertia)
        # known without looking at the arrays (an environment makes one per episode)
        model.__dict__.update(uses_mass=carries_weight, uses_inertia=False,
                              lift_per_kg=GRAVITY if carries_weight else 0.0)  # fmt: skip
        return model

    @cached_property
    def uses_mass(self) -> bool:
        """True when the wrenches depend on the structure's mass."""
        return bool(np.any(self.per_mass))

    @cached_property
    def lift_per_kg(self) -> float | None:
        """The structure's weight term when every row carries the same ``c e_z`` per kg (c;
        0.0 when the wrenches do not depend on the mass), None otherwise."""
        p = self.per_mass
        if not len(p) or np.any(p[:, [0, 1, 3, 4, 5]]) or np.any(p[:, 2] != p[0, 2]):
            return None if len(p) else 0.0
        return float(p[0, 2])

    @cached_property
    def uses_inertia(self) -> bool:
        """False when the wrenches depend on the structure through its mass alone."""
        return bool(np.any(self.per_inertia))

    def at(self, mass: float, inertia: np.ndarray | None = None) -> np.ndarray:
        """(k, 6) the wrenches for one structure: ``inertia`` a (3, 3) tensor or a (6,)
        vector (needed when :attr:`uses_inertia`)."""
        W = self.base + mass * self.per_mass
        if self.uses_inertia:
            if inertia is None:
                raise ValueError("these wrenches depend on the structure's inertia: pass it")
            j = np.asarray(inertia, dtype=float)
            W = W + self.per_inertia @ (to_vector(j) if j.shape == (3, 3) else j)
        return W

    def compact(self) -> LinearWrenches:
        """The same wrench model with repeated samples (e.g. the hover holds) kept once: every
        search decision is a max or an all() over the samples, which repeats do not change.
        Only equal samples are repeats: samples that differ, by however little, may decide
        differently (a rounding to fixed decimals merged whole samples of a task scaled down)."""
        k = len(self.base)
        rows = np.hstack([self.base, self.per_mass, self.per_inertia.reshape(k, -1)]) + 0.0
        _, first = np.unique(rows, axis=0, return_index=True)
        keep = np.sort(first)
        if len(keep) == k:
            return self
        parts = [
            np.ascontiguousarray(a[keep]) for a in (self.base, self.per_mass, self.per_inertia)
        ]
        for a in parts:
            a.setflags(write=False)
        return LinearWrenches(*parts)

    def for_structure(self, structure: Structure) -> np.ndarray:
        """(k, 6) the wrenches for ``structure`` (its mass and inertia)."""
        return self.at(structure.mass, structure.inertia)
