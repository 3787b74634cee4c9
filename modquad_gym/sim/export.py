"""Export a structure for other tools: MJCF (MuJoCo), URDF (ROS, PyBullet, Drake, Isaac, ...) and
JSON (rotor poses, directions, spins, mass, inertia and the configuration matrix).

Every format describes the same rigid body in the structure frame {S} (origin at the COM, z up,
SI units, :mod:`modquad_gym.geometry.structure`):

* Rotor k has a frame at its position p_k whose z-axis is its thrust direction d_k: the smallest
  rotation that turns e3 onto d_k (for a tilted rotor, the tilt about its arm; MuJoCo's
  ``zaxis`` makes the same frame). Its spin sign s_k says which way its drag torque acts:
  thrust f gives the torque ``s_k c_tau f d_k`` on the body, so the propeller turns about
  ``-s_k d_k``.
* ``mjcf``: the model of :func:`modquad_gym.sim.model.model_spec` (built with ``mujoco.MjSpec``,
  written by MuJoCo): one free body, a box per module, one site ``rotor{k}`` and one actuator
  ``thrust{k}`` per rotor, ``ctrl = u`` in [0, f_max] producing ``A u``. Needs the ``sim`` extra
  (the URDF and the JSON need nothing beyond the core install).
* ``urdf``: link ``base_link`` at {S} with a box visual per module; per rotor a link
  ``rotor{k}`` (the propeller) on a ``continuous`` joint ``rotor{k}_joint`` whose origin is the
  rotor frame and whose axis is the propeller's turning direction (``0 0 -s_k`` in the rotor
  frame). Each propeller carries :data:`ROTOR_MASS_FRACTION` of its module's mass as a solid
  disc (radius :data:`ROTOR_RADIUS_FRACTION` of the module side, :data:`ROTOR_THICKNESS` thick)
  and ``base_link`` the rest, its inertial placed so that the whole robot has exactly the
  structure's mass, COM (the origin of {S}) and inertia about the COM. (Simulators refuse a
  moving link without mass, e.g. MuJoCo's "mass and inertia of moving bodies must be larger
  than mjMINVAL".) URDF has no floating base: MuJoCo, PyBullet and Drake fix ``base_link`` to
  the world unless told otherwise. URDF has no thrust either: the JSON (or the MJCF) holds
  ``f_max``, ``c_tau`` and the configuration matrix.
* ``json``: :func:`structure_dict`.
"""

from __future__ import annotations

import json
import math
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np

from modquad_gym.geometry.inertia import inertia_about_com
from modquad_gym.geometry.structure import Structure

FORMATS = ("mjcf", "urdf", "json")
"""The export formats."""

SUFFIXES = {"mjcf": ".xml", "urdf": ".urdf", "json": ".json"}
"""The usual file suffix of each format."""

MODULE_THICKNESS = 0.05
"""Height of a module's box in the URDF visuals, metres (as in the MuJoCo model)."""

ROTOR_MASS_FRACTION = 0.01
"""Share of its module's mass that each URDF propeller link carries (3 g of a 0.3 kg module: a
small propeller); ``base_link`` carries the rest."""

ROTOR_RADIUS_FRACTION = 0.14
"""A URDF propeller's radius as a fraction of its module's side (the MuJoCo model's rotor discs)."""

ROTOR_THICKNESS = 0.01
"""A URDF propeller disc's thickness, metres."""


def rotor_quaternion(direction) -> np.ndarray:
    """(w, x, y, z): the smallest rotation that turns e3 onto the unit ``direction``."""
    d = np.asarray(direction, dtype=float) / np.linalg.norm(direction)
    if d[2] < -1.0 + 1e-12:  # straight down: half a turn about x
        return np.array([0.0, 1.0, 0.0, 0.0])
    q = np.array([1.0 + d[2], -d[1], d[0], 0.0])
    return q / np.linalg.norm(q)


def quaternion_matrix(q) -> np.ndarray:
    """The rotation matrix of the unit quaternion (w, x, y, z)."""
    w, x, y, z = q
    return np.array([
        [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
        [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
        [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
    ])  # fmt: skip


def _rpy(R: np.ndarray) -> tuple[float, float, float]:
    """URDF roll, pitch, yaw of R = Rz(yaw) Ry(pitch) Rx(roll)."""
    pitch = math.asin(max(-1.0, min(1.0, -R[2, 0])))
    return math.atan2(R[2, 1], R[2, 2]), pitch, math.atan2(R[1, 0], R[0, 0])


def structure_dict(structure: Structure, f_max: float = 1.0) -> dict:
    """The structure as plain JSON data: frame and units, cells and module types, mass and
    inertia (about the COM, {S} axes), rotor poses, and the configuration matrix A (6 x 4n,
    column k = rotor k: the wrench [f; tau] about the COM per unit thrust)."""
    from modquad_gym.core.validation import check_f_max

    f_max = check_f_max(f_max)
    s = structure
    rotors = zip(s.rotor_positions, s.rotor_directions, s.rotor_spins, s.rotor_c_tau,
                 strict=True)  # fmt: skip
    return {
        "format": "modquad_gym.structure",
        "version": 1,
        "frame": "{S}: origin at the centre of mass, axes parallel to the modules', z up",
        "units": {"length": "m", "mass": "kg", "inertia": "kg m^2", "thrust": "f_max units"},
        "n_modules": s.n_modules,
        "mass": s.mass,
        "inertia": np.asarray(s.inertia).tolist(),
        "f_max": f_max,
        "modules": [
            {
                "cell": list(cell),
                "type": m.name,
                "centre": centre.tolist(),
                "mass": m.mass,
                "inertia": np.asarray(m.inertia).tolist(),
                "side": m.side,
            }
            for cell, m, centre in zip(s.cells, s.modules, s.module_centres, strict=True)
        ],
        "rotors": [
            {
                "module": k // 4,
                "position": p.tolist(),
                "direction": d.tolist(),
                "quaternion": rotor_quaternion(d).tolist(),
                "spin": int(spin),
                "c_tau": float(c_tau),
            }
            for k, (p, d, spin, c_tau) in enumerate(rotors)
        ],
        "configuration_matrix": s.configuration_matrix().tolist(),
    }


def rotor_links(structure: Structure) -> list[tuple[float, np.ndarray]]:
    """(mass, inertia (3, 3) about its centre in the rotor frame) of each URDF propeller link:
    a solid disc of :data:`ROTOR_MASS_FRACTION` of its module's mass (module docstring)."""
    out = []
    for m in structure.modules:
        mass = ROTOR_MASS_FRACTION * m.mass
        r, h = ROTOR_RADIUS_FRACTION * m.side, ROTOR_THICKNESS
        across = mass * (3 * r * r + h * h) / 12  # about a diameter
        out += [(mass, np.diag([across, across, mass * r * r / 2]))] * 4
    return out


def base_inertial(structure: Structure) -> tuple[float, np.ndarray, np.ndarray]:
    """(mass, COM (3,) in {S}, inertia (3, 3) about that COM) of the URDF's ``base_link``: the
    structure less its propeller links, so that base and propellers together have exactly the
    structure's mass, COM (the origin) and inertia about the COM."""
    s = structure
    rotors = rotor_links(s)
    P = np.asarray(s.rotor_positions, dtype=float)
    masses = np.array([m for m, _ in rotors])
    own = [R @ J @ R.T for (_, J), R in zip(rotors, _rotor_matrices(s), strict=True)]
    mass = s.mass - masses.sum()
    com = -(masses @ P) / mass  # the whole robot's COM stays at the origin
    J = np.asarray(s.inertia, dtype=float) - inertia_about_com(P, masses, own)
    J -= mass * (np.eye(3) * (com @ com) - np.outer(com, com))  # about the base's own COM
    return mass, com, (J + J.T) / 2


def urdf_text(structure: Structure, name: str | None = None) -> str:
    """The URDF of ``structure`` (see the module docstring)."""
    s = structure
    robot = ET.Element("robot", name=name or f"modquad_{s.n_modules}")
    base = ET.SubElement(robot, "link", name="base_link")
    mass, com, J = base_inertial(s)
    _inertial(base, mass, com, J)
    for i, (centre, m) in enumerate(zip(s.module_centres, s.modules, strict=True)):
        visual = ET.SubElement(base, "visual", name=f"module{i}_{m.name}")
        ET.SubElement(visual, "origin", xyz=_vec(centre), rpy="0 0 0")
        geometry = ET.SubElement(visual, "geometry")
        ET.SubElement(geometry, "box", size=_vec([m.side, m.side, MODULE_THICKNESS]))
    rotors = zip(s.rotor_positions, s.rotor_directions, s.rotor_spins, rotor_links(s),
                 strict=True)  # fmt: skip
    for k, (p, d, spin, (mass, J)) in enumerate(rotors):
        _inertial(ET.SubElement(robot, "link", name=f"rotor{k}"), mass, np.zeros(3), J)
        joint = ET.SubElement(robot, "joint", name=f"rotor{k}_joint", type="continuous")
        rpy = _rpy(quaternion_matrix(rotor_quaternion(d)))
        ET.SubElement(joint, "origin", xyz=_vec(p), rpy=_vec(rpy))
        ET.SubElement(joint, "parent", link="base_link")
        ET.SubElement(joint, "child", link=f"rotor{k}")
        ET.SubElement(joint, "axis", xyz=_vec([0.0, 0.0, -float(spin)]))
    ET.indent(robot)
    return '<?xml version="1.0"?>\n' + ET.tostring(robot, encoding="unicode") + "\n"


def mjcf_text(structure: Structure, f_max: float = 1.0) -> str:
    """The MJCF of ``structure``'s MuJoCo model (:func:`modquad_gym.sim.model.model_xml`)."""
    from modquad_gym.sim.model import model_xml

    return model_xml(structure, f_max)


def export_text(structure: Structure, fmt: str, f_max: float = 1.0) -> str:
    """``structure`` in the format ``fmt`` (one of :data:`FORMATS`) as text."""
    if fmt == "mjcf":
        return mjcf_text(structure, f_max)
    if fmt == "urdf":
        from modquad_gym.core.validation import check_f_max

        check_f_max(f_max)
        return urdf_text(structure)
    if fmt == "json":
        return json.dumps(structure_dict(structure, f_max), indent=1) + "\n"
    raise ValueError(f"format: unknown {fmt!r}; use one of {', '.join(FORMATS)}")


def save_structure(
    structure: Structure, path, fmt: str | None = None, f_max: float = 1.0, force: bool = False
) -> Path:
    """Write ``structure`` to ``path`` in ``fmt`` (default: from the suffix, ``.xml`` = MJCF);
    an existing file is replaced only with ``force``. Returns the path written."""
    from modquad_gym.core.outputs import check_output_file, write_text

    path = Path(path)
    if fmt is None:
        by_suffix = {suffix: name for name, suffix in SUFFIXES.items()}
        fmt = by_suffix.get(path.suffix.lower())
        if fmt is None:
            raise ValueError(f"{path}: say the format (one of {', '.join(FORMATS)})")
    text = export_text(structure, fmt, f_max)  # before touching the file: errors leave it alone
    path = check_output_file(path, force=force, what="--out")
    write_text(path, text)
    return path


def _rotor_matrices(structure: Structure) -> list[np.ndarray]:
    """Each rotor frame's rotation in {S} (z-axis = the thrust direction)."""
    return [quaternion_matrix(rotor_quaternion(d)) for d in structure.rotor_directions]


def _inertial(link: ET.Element, mass: float, com: np.ndarray, J: np.ndarray) -> None:
    """``link``'s ``<inertial>``: ``mass`` at ``com`` with inertia ``J`` about it (link axes)."""
    inertial = ET.SubElement(link, "inertial")
    ET.SubElement(inertial, "origin", xyz=_vec(com), rpy="0 0 0")
    ET.SubElement(inertial, "mass", value=_num(mass))
    ET.SubElement(inertial, "inertia", **{
        f"i{a}{b}": _num(J[i, j]) for (a, i), (b, j) in
        ((("x", 0), ("x", 0)), (("x", 0), ("y", 1)), (("x", 0), ("z", 2)),
         (("y", 1), ("y", 1)), (("y", 1), ("z", 2)), (("z", 2), ("z", 2)))
    })  # fmt: skip


def _num(x: float) -> str:
    return repr(float(x))


def _vec(v) -> str:
    return " ".join(_num(x) for x in v)
