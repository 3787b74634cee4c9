"""Module types: the rotor data of one docking module (paper Def. 1 and Def. 5).

A module type is plain data: where its rotors sit in the module frame {M} (any number of them:
four in the stock types), which way each pushes, and which way each spins.
`ModuleType.from_tilts` builds any quadrotor type whose rotors are tilted about their own arms
(heterogeneous H-ModQuad types are just other tilt vectors); `TModule` is the paper's T-module,
eta_1 = eta_3 = -eta_2 = -eta_4 = eta.

Rotor layout (our choice; the paper's figure is not in the source text): rotors sit at the centres
of the four quadrants of the square module of side ``side``, counter-clockwise from the front-left,
    p_1 = (+a, +a, 0), p_2 = (-a, +a, 0), p_3 = (-a, -a, 0), p_4 = (+a, -a, 0),  a = side / 4,
and spin sign (-1)^(1+k): rotors 1 and 3 turn one way, 2 and 4 the other (a standard X quadrotor).

Drag torque: a rotor pushing with thrust f along d also exerts a reaction torque
``spin * c_tau * f * d`` about its axis. ``c_tau`` is the drag-to-thrust ratio in metres; the
default 0.01 m is a typical value for the small propellers of ModQuad-size modules (reported
values lie between 0.006 m and 0.02 m). The paper leaves it unspecified.

Mass: every module type carries its mass in kg (default :data:`DEFAULT_MASS` = 0.3 kg, our
modelling assumption for a 0.4 m module with frame, battery and four motors; the MuJoCo model
uses it too). It places the centre of mass of a mixed structure (each module's mass at its
centre) and, for tasks of kind ``external``, is weight the rotors must also carry.

Inertia: every module type carries its inertia tensor about the module centre in module axes
(:attr:`ModuleType.inertia`, kg m^2). Unless given, it is that of a uniform box of the module's
side l, side l and height h (default :data:`DEFAULT_HEIGHT` = 0.05 m, the MuJoCo model's box):
``m / 12 * diag(l^2 + h^2, l^2 + h^2, 2 l^2)`` - for the default 0.3 kg, 0.4 m module
diag(4.0625e-3, 4.0625e-3, 8.0e-3) kg m^2. A structure sums these with parallel-axis terms
(:attr:`modquad_gym.geometry.structure.Structure.inertia`). Dynamic tasks
(:mod:`modquad_gym.dynamics`) need it; static tasks do not.

Stock types (:data:`STOCK_TYPES`, short names for the command line, :func:`palette`):

* ``t45``: the paper's T-module (Def. 5), eta = pi/4;
* ``t45m``: the mirrored tilt pattern, every tilt negated (eta_1 = eta_3 = -pi/4, spins
  unchanged): each rotor's lateral force and tilt yaw torque reverse, so the rotor's drag
  torque adds to its tilt yaw torque (in ``t45`` it subtracts);
* ``t30`` / ``t30m``: the same pattern with a shallower tilt eta = pi/6 (more lift, less lateral
  force and torque); the tilt angle is the design parameter of the tilted-rotor modules of
  H-ModQuad (J. Xu, D. S. D'Antonio, D. Saldana, "H-ModQuad: Modular Multi-Rotors with 4, 5, and 6
  Controllable DOF", ICRA 2021, arXiv:2106.04048), whose heterogeneous modules motivate mixing;
* ``flat``: an untilted quadrotor module (eta = 0), the module of ModQuad (D. Saldana,
  B. Gabrich, G. Li, M. Yim, V. Kumar, "ModQuad: The Flying Modular Structure that Self-Assembles
  in Midair", ICRA 2018): the most lift per rotor, no lateral force.
"""

from __future__ import annotations

import hashlib
import math
from collections.abc import Iterable
from dataclasses import dataclass, field

import numpy as np

from modquad_gym.core.validation import check_real, refuse_complex
from modquad_gym.proofcheck_format import MAX_LENGTH

DEFAULT_SIDE = 0.4
"""Module side length l in metres (paper Sec. VI)."""

DEFAULT_C_TAU = 0.01
"""Drag-to-thrust ratio c_tau in metres (see the module docstring)."""

DEFAULT_MASS = 0.3
"""Mass of one module in kg (see the module docstring)."""

DEFAULT_HEIGHT = 0.05
"""Height in metres of the uniform box whose inertia a module has unless given."""

GRAVITY = 9.81
"""Gravitational acceleration in m/s^2 (the self-weight of ``external`` tasks, MuJoCo)."""

MAX_MASS = 1e12
"""Most kg of a module type: the largest f_max (1e12 N per rotor,
:data:`~modquad_gym.core.validation.F_MAX_RANGE`) lifts about 1.6e12 kg with 16 rotors, so a
heavier module could not lift itself at any f_max the package takes."""

_QUADRANTS = np.array([[1.0, 1.0, 0.0], [-1.0, 1.0, 0.0], [-1.0, -1.0, 0.0], [1.0, -1.0, 0.0]])
_SPINS = np.array([1.0, -1.0, 1.0, -1.0])


def _rotate_about(axis: np.ndarray, angle: float, v: np.ndarray) -> np.ndarray:
    """Rodrigues' rotation of vector ``v`` by ``angle`` about the unit ``axis``."""
    return (
        v * math.cos(angle)
        + np.cross(axis, v) * math.sin(angle)
        + axis * float(axis @ v) * (1.0 - math.cos(angle))
    )


@dataclass(frozen=True, eq=False)
class ModuleType:
    """Rotor data of one module type, in the module frame {M} (origin at the module centre).

    Attributes:
        positions: (r, 3) rotor positions p_j in metres (r >= 1 rotors; the stock types have
            4), each coordinate within +-:data:`MAX_LENGTH` of the module centre.
        directions: (r, 3) thrust directions R_j e3 (non-zero, of a length within the float
            range; stored normalised).
        spins: (r,) spin signs, each +1 or -1, multiplying the drag torque c_tau * f * d.
        side: module side length l in metres, in (0, :data:`MAX_LENGTH`] (modules dock on a
            grid of pitch ``side``).
        c_tau: drag-to-thrust ratio in metres, in [0, :data:`MAX_LENGTH`].
        name: a label for reports (the stock types use their short command-line names).
        mass: mass in kg, in (0, :data:`MAX_MASS`], its centre of mass at the module centre
            (default :data:`DEFAULT_MASS`).
        height: height in metres, in [0, :data:`MAX_LENGTH`], of the uniform box whose inertia
            the module has by default.
        inertia: (3, 3) inertia tensor in kg m^2 about the module centre, module axes; default
            (None) the uniform box of side x side x ``height`` (module docstring). A given one
            must be symmetric with principal moments that are >= 0 and obey the triangle
            inequality (a real body's). The MuJoCo model and the MJCF and URDF exports further
            need every principal moment positive (:mod:`modquad_gym.sim.inertial`); the
            searches do not use the inertia.

    Each argument is checked when the type is made: a wrong one is a ValueError naming it (its
    expected shape for the arrays). :data:`MAX_LENGTH` (10 m) is the certificate checker's
    limit on a type's lengths (:mod:`modquad_gym.proofcheck_format`).

    Types compare by identity (two equal-looking types are two types); :attr:`digest` names the
    rotor data, side, drag ratio and mass (and a given non-box inertia), so that copies can be
    recognised.
    """

    positions: np.ndarray
    directions: np.ndarray
    spins: np.ndarray
    side: float = DEFAULT_SIDE
    c_tau: float = DEFAULT_C_TAU
    name: str = "module"
    mass: float = DEFAULT_MASS
    height: float = DEFAULT_HEIGHT
    inertia: np.ndarray | None = None
    columns: np.ndarray = field(init=False, repr=False)

    def __post_init__(self) -> None:
        for what in ("positions", "directions", "spins", "inertia"):
            refuse_complex(getattr(self, what), what)
        scalars = _scalars(self.side, self.c_tau, self.name, self.mass, self.height)
        pos, dirs, spins = _rotor_arrays(self.positions, self.directions, self.spins, self.name)
        norms = np.linalg.norm(dirs, axis=1)
        for what, value in scalars:
            object.__setattr__(self, what, value)
        box = box_inertia(self.mass, self.side, self.side, self.height)
        given = self.inertia is not None
        J = check_inertia(self.inertia) if given else box
        object.__setattr__(self, "_box_inertia", not given or bool(np.allclose(J, box, 0, 1e-15)))
        J.setflags(write=False)
        object.__setattr__(self, "inertia", J)
        dirs = dirs / norms[:, None]
        for name, value in (("positions", pos), ("directions", dirs), ("spins", spins)):
            value.setflags(write=False)
            object.__setattr__(self, name, value)
        # Wrench columns of this module about its own centre (eq. 1 with p_k in {M}).
        cols = np.vstack([dirs.T, (np.cross(pos, dirs) + self.c_tau * spins[:, None] * dirs).T])
        cols.setflags(write=False)
        object.__setattr__(self, "columns", cols)

    @property
    def n_rotors(self) -> int:
        return self.positions.shape[0]

    @property
    def weight(self) -> float:
        """The module's weight m g in newtons."""
        return self.mass * GRAVITY

    @property
    def digest(self) -> str:
        """A short hash of the rotor data, side, drag ratio, mass and a given (non-box) inertia,
        each to 12 digits of its own scale (positions the side's, so that a type scaled down
        keeps its distinctions): equal for copies of one type, different for types that act or
        weigh differently."""
        h = hashlib.sha256()
        parts = (self.positions / self.side, self.directions, self.spins, self.side, self.c_tau,
                 self.mass, *([] if self._box_inertia else [self.inertia]))  # fmt: skip
        for a in parts:  # the default box inertia follows from side and mass
            a = np.asarray(a, dtype=float)
            scale = float(np.abs(a).max(initial=0.0)) or 1.0
            h.update(np.ascontiguousarray(np.round(a / scale, 12) + 0.0).tobytes())
            h.update(np.array([float(f"{scale:.12g}")]).tobytes())
        return h.hexdigest()[:16]

    @classmethod
    def from_tilts(
        cls,
        tilts: tuple[float, float, float, float] | np.ndarray,
        side: float = DEFAULT_SIDE,
        c_tau: float = DEFAULT_C_TAU,
        name: str = "tilted",
        mass: float = DEFAULT_MASS,
        height: float = DEFAULT_HEIGHT,
        inertia: np.ndarray | None = None,
    ) -> ModuleType:
        """A quadrotor module whose rotor j is tilted by ``tilts[j]`` (radians) about its arm p_j.

        Positive tilt turns the thrust vector by the right-hand rule about the arm direction.
        ``height`` and ``inertia`` as in the class docstring.
        """
        refuse_complex(tilts, "tilts")
        side = check_real(side, "side", high=MAX_LENGTH, positive=True)  # before the rotors
        tilts = np.asarray(tilts, dtype=float)
        if tilts.shape != (4,) or not np.all(np.isfinite(tilts)):
            raise ValueError(f"tilts must be 4 finite angles in radians, got {tilts!r}")
        positions = _QUADRANTS * (side / 4.0)
        arms = _QUADRANTS / np.linalg.norm(_QUADRANTS, axis=1, keepdims=True)
        e3 = np.array([0.0, 0.0, 1.0])
        directions = np.array([_rotate_about(arm, t, e3) for arm, t in zip(arms, tilts)])
        return cls(
            positions, directions, _SPINS.copy(), side=side, c_tau=c_tau, name=name, mass=mass,
            height=height, inertia=inertia,
        )  # fmt: skip

    def __repr__(self) -> str:
        return (
            f"ModuleType(name={self.name!r}, rotors={self.n_rotors}, side={self.side:g} m, "
            f"c_tau={self.c_tau:g} m, mass={self.mass:g} kg)"
        )


def _scalars(side: object, c_tau: object, name: object, mass: object, height: object) -> tuple:
    """((field, value), ...) of a module type's scalar fields, checked (one ValueError naming
    the field: a real number, never a boolean or a string) and made Python floats."""
    if not isinstance(name, str) or not name:
        raise ValueError(f"name must be a non-empty string, got {name!r}")
    return (
        ("side", check_real(side, "side", high=MAX_LENGTH, positive=True)),
        ("c_tau", check_real(c_tau, "c_tau", 0.0, MAX_LENGTH)),
        ("name", name),
        ("mass", check_real(mass, "mass", high=MAX_MASS, positive=True)),
        ("height", check_real(height, "height", 0.0, MAX_LENGTH)),
    )


def _numbers(value: object, what: str, shape: str) -> np.ndarray:
    """``value`` as a float array (a copy), or a ValueError naming ``what`` and the ``shape``
    expected when it is not an array of real numbers (text, booleans, ragged rows)."""
    expected = f"{what} must be a {shape} array of numbers"
    try:
        raw = np.asarray(value)
    except (TypeError, ValueError, OverflowError):  # ragged rows
        raise ValueError(f"{expected}, got {value!r:.80}") from None
    if raw.dtype.kind not in "iuf":
        raise ValueError(f"{expected}, got {value!r:.80}")
    return raw.astype(float)


def _rotor_arrays(positions: object, directions: object, spins: object, name: str) -> tuple:
    """(positions (r, 3), directions (r, 3), spins (r,)) as float arrays, checked: shapes,
    finite positions within +-MAX_LENGTH m, non-zero finite directions whose length is a finite
    float (else normalising one would make it zero), spins of +-1 (each a ValueError naming the
    field; a direction's, the module type ``name`` and the rotor too)."""
    pos = _numbers(positions, "positions", "(r, 3)")
    if pos.ndim != 2 or pos.shape[1] != 3 or pos.shape[0] == 0:
        raise ValueError(
            f"positions must be a (r, 3) array of numbers, r >= 1, got shape {pos.shape}"
        )
    r = pos.shape[0]
    dirs = _numbers(directions, "directions", f"({r}, 3)")
    if dirs.shape != pos.shape:
        raise ValueError(
            f"directions must be a ({r}, 3) array of numbers (a row per rotor of positions), "
            f"got shape {dirs.shape}"
        )
    spins = _numbers(spins, "spins", f"({r},)")
    if spins.shape != (r,):
        raise ValueError(
            f"spins must be a ({r},) array of numbers (one per rotor), got shape {spins.shape}"
        )
    if not np.all(np.abs(pos) <= MAX_LENGTH):  # NaN fails too
        raise ValueError(
            f"positions must be finite, each coordinate within +-{MAX_LENGTH:g} m of the module "
            f"centre, got {pos.tolist()!r:.80}"
        )
    with np.errstate(over="ignore"):  # a length that overflows: inf, refused here
        norms = np.linalg.norm(dirs, axis=1)
    bad = ~((norms >= 1e-12) & (norms < np.inf))  # NaN fails too
    if bad.any():
        i = int(np.flatnonzero(bad)[0])
        why = "must be finite and non-zero"
        if np.isfinite(dirs[i]).all() and norms[i] == np.inf:
            why = "has a length that overflows a float (scale it down)"
        raise ValueError(
            f"directions[{i}] (rotor {i + 1} of module type {name!r}) {why}, got {dirs[i].tolist()}"
        )
    if not np.all(np.abs(spins) == 1):
        raise ValueError(f"spins must each be +1 or -1, got {spins.tolist()!r:.80}")
    return pos, dirs, spins


def check_module(value: object, name: str = "module", *, optional: bool = False):
    """``value`` when it is a :class:`ModuleType` (or None, with ``optional``), else a
    ValueError naming ``name`` and the value."""
    if not (isinstance(value, ModuleType) or optional and value is None):
        either = " or None" if optional else ""
        raise ValueError(f"{name} must be a ModuleType{either}, got {value!r:.60}")
    return value


def box_inertia(mass: float, x: float, y: float, z: float) -> np.ndarray:
    """(3, 3) inertia of a uniform box of ``mass`` kg and edges x, y, z m about its centre."""
    return mass / 12.0 * np.diag([y * y + z * z, x * x + z * z, x * x + y * y])


def check_inertia(J: object, what: str = "inertia") -> np.ndarray:
    """A float (3, 3) copy of ``J`` if it is a physical inertia tensor (symmetric, principal
    moments >= 0 obeying the triangle inequality), else a ValueError naming ``what``."""
    refuse_complex(J, what)
    arr = _numbers(J, what, "(3, 3)")
    if arr.shape != (3, 3) or not np.all(np.isfinite(arr)):
        raise ValueError(f"{what} must be a finite (3, 3) array in kg m^2, got shape {arr.shape}")
    scale = float(np.abs(arr).max())
    if not np.allclose(arr, arr.T, rtol=0, atol=1e-12 * scale):
        raise ValueError(f"{what} must be symmetric, got {arr.tolist()}")
    arr = (arr + arr.T) / 2
    p = np.linalg.eigvalsh(arr)
    slack = 1e-12 * scale
    if p[0] < -slack or p[0] + p[1] < p[2] - slack:
        raise ValueError(
            f"{what}: principal moments {p.tolist()} are not those of a body (each >= 0, each "
            "at most the sum of the other two)"
        )
    return arr


def TModule(
    eta: float = math.pi / 4,
    side: float = DEFAULT_SIDE,
    c_tau: float = DEFAULT_C_TAU,
    mass: float = DEFAULT_MASS,
) -> ModuleType:
    """The paper's T-module (Def. 5): rotor j tilted by eta_j about its arm, with
    eta_1 = eta_3 = -eta_2 = -eta_4 = ``eta`` (default pi/4). Every structure of T-modules is
    torque-balanced: equal thrust on all rotors produces a pure vertical force.

    ``eta`` must lie in [-pi/2, pi/2]: a rotor tilted further points downwards."""
    from modquad_gym.core.validation import check_real

    eta = check_real(eta, "eta", -math.pi / 2, math.pi / 2)
    return ModuleType.from_tilts(
        (eta, -eta, eta, -eta), side=side, c_tau=c_tau, name=f"T(eta={eta:.4g})", mass=mass
    )


def _stock() -> dict[str, ModuleType]:
    q, s = math.pi / 4, math.pi / 6
    return {
        "t45": ModuleType.from_tilts((q, -q, q, -q), name="t45"),
        "t45m": ModuleType.from_tilts((-q, q, -q, q), name="t45m"),
        "t30": ModuleType.from_tilts((s, -s, s, -s), name="t30"),
        "t30m": ModuleType.from_tilts((-s, s, -s, s), name="t30m"),
        "flat": ModuleType.from_tilts((0.0, 0.0, 0.0, 0.0), name="flat"),
    }


STOCK_TYPES: dict[str, ModuleType] = _stock()
"""The stock module types by short name (module docstring). ``STOCK_TYPES["t45"]`` has the
same rotor data as ``TModule()`` (a different object: types compare by identity)."""


def palette(spec: str | Iterable[str | ModuleType], repeats: bool = False) -> list[ModuleType]:
    """Module types from a comma-separated list of stock names (``"t45,t45m,flat"``) or a list
    of names and :class:`ModuleType` objects. Raises ValueError naming an unknown name, an empty
    entry, or a repeated one unless ``repeats`` (a type per cell of a given structure, not a
    palette to choose from)."""
    if not isinstance(spec, (str, Iterable)):
        raise ValueError(
            f"modules must be comma-separated type names or a list of them, got {spec!r}"
        )
    items = spec.split(",") if isinstance(spec, str) else list(spec)
    if not items:
        raise ValueError("modules: give at least one module type")
    out: list[ModuleType] = []
    for item in items:
        if isinstance(item, ModuleType):
            out.append(item)
            continue
        if not isinstance(item, str):
            raise ValueError(f"modules: {item!r} is neither a type name nor a ModuleType")
        name = item.strip()
        if name not in STOCK_TYPES:
            known = ", ".join(STOCK_TYPES)
            raise ValueError(f"modules: unknown module type {name!r}; known: {known}")
        out.append(STOCK_TYPES[name])
    if not repeats and len({id(m) for m in out}) != len(out):
        raise ValueError(f"modules: a type is listed twice in {[m.name for m in out]}")
    return out
