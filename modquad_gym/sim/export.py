"""Export a structure for other tools: MJCF (MuJoCo), URDF (ROS, PyBullet, Drake, Isaac, ...) and
JSON (rotor poses, directions, spins, mass, inertia and the configuration matrix).

Every format describes the same rigid body in the structure frame {S} (origin at the COM, z up,
SI units, :mod:`modquad_gym.geometry.structure`):

* Rotor k has a frame at its position p_k whose z-axis is its thrust direction d_k: the smallest
  rotation that turns e3 onto d_k (for a tilted rotor, the tilt about its arm; MuJoCo's
  ``zaxis`` makes the same frame). Its spin sign s_k says which way its drag torque acts:
  thrust f gives the torque ``s_k c_tau f d_k`` on the body, so the propeller turns about
  ``-s_k d_k``.
* Thrust is in newtons in an export: ``f_max`` is each rotor's largest thrust. Whether the robot
  can lift itself is :func:`thrust_to_weight` (>= 1 exactly when it can hover level with no
  external load); every file states it, and :func:`hover_f_max` is the least ``f_max`` that
  hovers. The searches' normalised units (f_max = 1) leave a default T-module short of its
  0.3 kg weight (ratio 0.961), so a robot meant to fly needs a larger ``f_max``.
* ``mjcf``: the model of :func:`modquad_gym.sim.model.model_spec` (built with ``mujoco.MjSpec``,
  written by MuJoCo): one free body, a box per module, one site ``rotor{k}`` and one actuator
  ``thrust{k}`` per rotor, ``ctrl = u`` in [0, f_max] producing ``A u``, and custom numerics
  ``thrust_to_weight`` and ``hover_f_max``. Needs the ``sim`` extra (the URDF and the JSON need
  nothing beyond the core install). :mod:`modquad_gym.sim.export_flight` flies such a file.
* ``urdf``: link ``base_link`` at {S} with a box (visual and collision) per module; per rotor a
  link ``rotor{k}`` (the propeller: a disc, visual and collision) on a ``continuous`` joint
  ``rotor{k}_joint`` whose origin is the rotor frame and whose axis is the propeller's turning
  direction (``0 0 -s_k`` in the rotor frame; the disc's radius is
  :data:`ROTOR_RADIUS_FRACTION` of the module side, :data:`ROTOR_THICKNESS` thick). Each
  propeller carries a share f of its module: f of the module's mass, centred on the rotor, and
  f of the module's own inertia (a scaled copy of the module's, the one shape that fits every
  module type, flat ones included); f is :data:`ROTOR_MASS_FRACTION` (1 %), halved while what
  the module keeps would have less than half its room left in some direction
  (:func:`~modquad_gym.sim.inertial.rotor_share`: a module whose inertia is small for its
  rotors' arms gets light propellers). ``base_link`` carries the rest, its inertial placed so
  that the whole robot has exactly the structure's mass, COM (the origin of {S}) and inertia
  about the COM, and so that every link is a physical body (positive principal moments obeying
  the triangle inequality). A flat module type (height 0) lies on the triangle boundary, where
  MuJoCo's check depends on round-off: it is thickened by at most 1e-7 of its largest moment
  (:func:`~modquad_gym.sim.inertial.thickened`). Simulators refuse a moving link without mass
  (MuJoCo: "mass and inertia of moving bodies must be larger than mjMINVAL"); a module type
  whose inertia MuJoCo cannot compile is refused before writing
  (:func:`~modquad_gym.sim.inertial.check_simulable`). The root link floats in PyBullet
  (``useFixedBase=False``, its default) and Drake (a body not welded to the world); MuJoCo's
  URDF import attaches the root link to the world without a joint, so :func:`urdf_spec` loads
  the file and adds a free joint. A
  ``<mujoco><compiler .../></mujoco>`` element (MuJoCo's URDF extension, ignored by other
  readers) keeps the visuals and the base as a body. URDF has no thrust: the JSON (or the
  MJCF) holds ``f_max``, ``c_tau`` and the configuration matrix. The URDF is written with
  ElementTree: the maintained URDF libraries (yourdfpy, urdfpy) would add trimesh and lxml to
  the core install and drop the ``<mujoco>`` element; the tests read it back with yourdfpy.
* ``json``: :func:`structure_dict`.
"""

from __future__ import annotations

import json
import math
import warnings
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np

from modquad_gym.core.extras import import_optional
from modquad_gym.core.validation import check_f_max, float_array, refuse_non_numbers
from modquad_gym.geometry.structure import Structure
from modquad_gym.sim.export_formats import (  # noqa: F401 (FORMATS, SUFFIXES, is_path: here too)
    FORMATS,
    SUFFIXES,
    export_format,
    is_path,
    parse_export,
    read_export,
)
from modquad_gym.sim.inertial import (  # noqa: F401 (base_inertial, ROTOR_MASS_FRACTION: here too)
    ROTOR_MASS_FRACTION,
    base_inertial,
    check_simulable,
    propeller_inertials,
)
from modquad_gym.tasks.files import STRUCTURE_FORMAT

MODULE_THICKNESS = 0.05
"""Height of a module's box in the URDF visuals, metres (as in the MuJoCo model)."""

ROTOR_RADIUS_FRACTION = 0.14
"""A URDF propeller's radius as a fraction of its module's side (the MuJoCo model's rotor discs)."""

ROTOR_THICKNESS = 0.01
"""A URDF propeller disc's thickness, metres."""


def rotor_quaternion(direction) -> np.ndarray:
    """(w, x, y, z), w >= 0: the smallest rotation that turns e3 onto the unit ``direction``
    (scipy's ``Rotation.align_vectors`` of one pair; straight down: half a turn about x).
    ``direction``: 3 finite numbers, not all zero (else a ValueError naming it)."""
    refuse_non_numbers(direction, "direction", "entry")
    d = float_array(direction, "direction", f"3 numbers, got {direction!r:.60}")
    big = float(np.abs(d).max()) if d.shape == (3,) else math.nan
    if not 0.0 < big < math.inf:  # nan: not 3 finite numbers
        raise ValueError(f"direction must be 3 finite numbers, not all zero, got {direction!r:.60}")
    d = d / big  # entries of order one: no overflow in the norm
    d = d / np.linalg.norm(d)
    if d[2] < -1.0 + 1e-12:  # antiparallel: every half turn about a horizontal axis is smallest
        return np.array([0.0, 1.0, 0.0, 0.0])
    from scipy.spatial.transform import Rotation

    rotation, _ = Rotation.align_vectors([d], [[0.0, 0.0, 1.0]])
    x, y, z, w = rotation.as_quat(canonical=True)
    return np.array([w, x, y, z])


def quaternion_matrix(q) -> np.ndarray:
    """The rotation matrix of the unit quaternion (w, x, y, z)."""
    from scipy.spatial.transform import Rotation

    w, x, y, z = q
    return Rotation.from_quat([x, y, z, w]).as_matrix()


def _rpy(R: np.ndarray) -> tuple[float, float, float]:
    """URDF roll, pitch, yaw of R = Rz(yaw) Ry(pitch) Rx(roll) (extrinsic x, y, z). At pitch
    +-pi/2 (a horizontal rotor) only roll - yaw or roll + yaw is defined: scipy sets yaw to 0
    and the angles still rebuild R."""
    from scipy.spatial.transform import Rotation

    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", "Gimbal lock detected", UserWarning)
        roll, pitch, yaw = Rotation.from_matrix(R).as_euler("xyz")
    return float(roll), float(pitch), float(yaw)


def thrust_to_weight(structure: Structure, f_max: float = 1.0) -> float:
    """The largest multiple of its own weight the robot holds up level, with no net torque or
    sideways force, at ``f_max`` newtons per rotor: the oracle's
    :func:`~modquad_gym.oracle.lambda_ratio` of the hover wrench ``[0, 0, m g, 0, 0, 0]``.
    >= 1 exactly when it can hover with no external load, by the oracle's rule (the plain LP's
    value within its tolerance, 1e-6 relative); for T-modules the rotors' summed vertical
    thrust over the weight, 4 n f_max cos(eta) / (m g). ``f_max`` in 1e-300..1e12, as every
    task's (:func:`~modquad_gym.core.validation.check_f_max`)."""
    from modquad_gym.geometry.module import GRAVITY
    from modquad_gym.oracle import lambda_ratio

    structure, f_max = check_structure(structure), check_f_max(f_max)
    hover = [[0.0, 0.0, structure.mass * GRAVITY, 0.0, 0.0, 0.0]]
    return float(lambda_ratio(structure.configuration_matrix(), hover, f_max)[0])


def hover_f_max(structure: Structure) -> float:
    """The least thrust per rotor (N) at which the robot hovers: the feasible wrenches scale
    with f_max, so ``f_max / thrust_to_weight`` (inf if no thrust can hold it level)."""
    ratio = thrust_to_weight(structure, 1.0)
    return math.inf if ratio <= 0 else 1.0 / ratio


def lift_statement(structure: Structure, f_max: float = 1.0) -> str:
    """One line on whether the robot lifts itself at ``f_max`` N per rotor, for files and the
    command line."""
    ratio = thrust_to_weight(structure, f_max)
    need = hover_f_max(structure)
    shown = f"{ratio:.3f}" if ratio < 1e6 else f"{ratio:.3g}"  # not 12 digits at f_max 1e12
    head = (
        f"thrust-to-weight {shown} at f_max {f_max:g} N per rotor "
        f"({structure.n_modules} modules, {structure.mass:g} kg)"
    )
    if ratio >= 1.0:
        return f"{head}: it hovers (from f_max {need:.3g} N)"
    return f"{head}: it cannot lift itself; it hovers from f_max {need:.3g} N"


def structure_dict(structure: Structure, f_max: float = 1.0) -> dict:
    """The structure as plain JSON data: frame and units, cells and module types, mass and
    inertia (about the COM, {S} axes), rotor poses (each with the index of its module: types
    may have any number of rotors), and the configuration matrix A (6 x R for R rotors,
    column k = rotor k: the wrench [f; tau] about the COM per unit thrust)."""
    f_max = check_f_max(f_max)
    s = check_structure(structure)
    owner = np.repeat(np.arange(s.n_modules), [m.n_rotors for m in s.modules])
    rotors = zip(owner, s.rotor_positions, s.rotor_directions, s.rotor_spins, s.rotor_c_tau,
                 strict=True)  # fmt: skip
    return {
        "format": STRUCTURE_FORMAT,
        "version": 1,
        "frame": "{S}: origin at the centre of mass, axes parallel to the modules', z up",
        "units": {"length": "m", "mass": "kg", "inertia": "kg m^2", "thrust": "N"},
        "n_modules": s.n_modules,
        "mass": s.mass,
        "inertia": np.asarray(s.inertia).tolist(),
        "f_max": f_max,
        "thrust_to_weight": thrust_to_weight(s, f_max),
        "hover_f_max": hover_f_max(s),
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
                "module": int(i),
                "position": p.tolist(),
                "direction": d.tolist(),
                "quaternion": rotor_quaternion(d).tolist(),
                "spin": int(spin),
                "c_tau": float(c_tau),
            }
            for i, p, d, spin, c_tau in rotors
        ],
        "configuration_matrix": s.configuration_matrix().tolist(),
    }


def rotor_links(structure: Structure) -> list[tuple[float, np.ndarray]]:
    """(mass, inertia (3, 3) about its centre in the rotor frame) of each URDF propeller link,
    one per rotor: a share of its module's mass and inertia (module docstring)."""
    masses, own = propeller_inertials(structure)
    frames = _rotor_matrices(structure)
    return [(float(mass), R.T @ J @ R) for mass, J, R in zip(masses, own, frames, strict=True)]


MUJOCO_URDF_COMPILER = {"discardvisual": "false", "fusestatic": "false", "strippath": "false"}
"""Attributes of the URDF's ``<mujoco><compiler/></mujoco>`` element (MuJoCo's URDF extension):
keep the visuals (MuJoCo drops them by default) and keep ``base_link`` a body of its own."""


def urdf_text(structure: Structure, name: str | None = None, f_max: float = 1.0) -> str:
    """The URDF of ``structure`` (see the module docstring); a comment states its
    thrust-to-weight ratio at ``f_max`` N per rotor (:func:`lift_statement`). ``name`` (the
    robot's name; default ``modquad_N``) is a non-empty line of printable text."""
    s = check_structure(structure)
    check_simulable(s)
    if name is not None and not (isinstance(name, str) and name.strip() and name.isprintable()):
        raise ValueError(f"name must be None or a non-empty line of printable text, got {name!r}")
    robot = ET.Element("robot", name=name or f"modquad_{s.n_modules}")
    ET.SubElement(ET.SubElement(robot, "mujoco"), "compiler", **MUJOCO_URDF_COMPILER)
    base = ET.SubElement(robot, "link", name="base_link")
    mass, com, J = base_inertial(s)
    _inertial(base, mass, com, J)
    for i, (centre, m) in enumerate(zip(s.module_centres, s.modules, strict=True)):
        box = ("box", {"size": _vec([m.side, m.side, MODULE_THICKNESS])})
        _shape(base, "visual", f"module{i}_{m.name}", centre, box)
        _shape(base, "collision", f"module{i}_collision", centre, box)
    rotors = zip(s.rotor_positions, s.rotor_directions, s.rotor_spins, rotor_links(s),
                 [m for m in s.modules for _ in range(m.n_rotors)], strict=True)  # fmt: skip
    for k, (p, d, spin, (mass, J), m) in enumerate(rotors):
        link = ET.SubElement(robot, "link", name=f"rotor{k}")
        _inertial(link, mass, np.zeros(3), J)
        disc = ("cylinder", {"radius": _num(ROTOR_RADIUS_FRACTION * m.side),
                             "length": _num(ROTOR_THICKNESS)})  # fmt: skip
        _shape(link, "visual", f"propeller{k}", np.zeros(3), disc)
        _shape(link, "collision", f"propeller{k}_collision", np.zeros(3), disc)
        joint = ET.SubElement(robot, "joint", name=f"rotor{k}_joint", type="continuous")
        rpy = _rpy(quaternion_matrix(rotor_quaternion(d)))
        ET.SubElement(joint, "origin", xyz=_vec(p), rpy=_vec(rpy))
        ET.SubElement(joint, "parent", link="base_link")
        ET.SubElement(joint, "child", link=f"rotor{k}")
        ET.SubElement(joint, "axis", xyz=_vec([0.0, 0.0, -float(spin)]))
    ET.indent(robot)
    comment = (
        f"<!-- modquad_gym structure: {lift_statement(s, f_max)}. URDF holds no thrust: take "
        "f_max, c_tau and the configuration matrix from the JSON export or the MJCF. -->\n"
    )
    return '<?xml version="1.0"?>\n' + comment + ET.tostring(robot, encoding="unicode") + "\n"


def urdf_spec(source):
    """A ``mujoco.MjSpec`` of an exported URDF (a path, or the URDF text) that floats: MuJoCo's
    URDF import attaches the root link to the world without a joint, so a free joint ``root``
    is added to ``base_link``. ``urdf_spec(path).compile()`` is the floating robot."""
    mujoco = import_optional("mujoco")

    text, where = read_export(source, "URDF")
    spec = parse_export(mujoco.MjSpec.from_string, text, where)
    base = spec.body("base_link")
    if base is None:
        raise ValueError(f"{where}: no link 'base_link' (not a modquad_gym URDF export)")
    if not any(j.type == mujoco.mjtJoint.mjJNT_FREE for j in base.joints):
        base.add_freejoint(name="root")
    return spec


def mjcf_text(structure: Structure, f_max: float = 1.0) -> str:
    """The MJCF of ``structure``'s MuJoCo model (:func:`modquad_gym.sim.model.model_spec`) with
    its thrust-to-weight ratio: a comment and the custom numerics ``thrust_to_weight`` and
    ``hover_f_max`` (N; ``model.numeric("thrust_to_weight").data`` once loaded)."""
    from modquad_gym.sim.model import model_spec, spec_xml

    spec = model_spec(structure, f_max)
    spec.add_numeric(name="thrust_to_weight", data=[thrust_to_weight(structure, f_max)])
    spec.add_numeric(name="hover_f_max", data=[min(hover_f_max(structure), 1e300)])
    comment = f"<!-- modquad_gym structure: {lift_statement(structure, f_max)} -->\n"
    return comment + spec_xml(spec)


def export_text(structure: Structure, fmt: str, f_max: float = 1.0) -> str:
    """``structure`` in the format ``fmt`` (one of :data:`FORMATS`) as text; ``f_max`` in
    1e-300..1e12 N (:func:`~modquad_gym.core.validation.check_f_max`)."""
    check_structure(structure)
    f_max = check_f_max(f_max)
    if not isinstance(fmt, str) or fmt not in FORMATS:  # an array's `in` would ask its truth
        raise ValueError(f"format: unknown {fmt!r}; use one of {', '.join(FORMATS)}")
    if fmt in ("mjcf", "urdf"):
        check_simulable(structure)
    if fmt == "mjcf":
        return mjcf_text(structure, f_max)
    if fmt == "urdf":
        return urdf_text(structure, f_max=f_max)
    return json.dumps(structure_dict(structure, f_max), indent=1) + "\n"


def save_structure(
    structure: Structure,
    path,
    fmt: str | None = None,
    f_max: float = 1.0,
    force: bool = False,
    *,
    what: str = "path",
) -> Path:
    """Write ``structure`` to ``path`` in ``fmt`` (default: from the suffix, ``.xml`` = MJCF);
    an existing file is replaced only with ``force``. The same rules as ``modquad export``: a
    ``fmt`` that contradicts the suffix (JSON in b.xml) is refused
    (:func:`~modquad_gym.sim.export_formats.export_format`), and so is an ``f_max`` outside
    1e-300..1e12 N. A robot that cannot lift itself at ``f_max`` N per rotor gets a warning on
    the ``modquad_gym`` logger (:mod:`modquad_gym.core.notes`). ``what`` names ``path`` in the
    refusal of an existing file: an option of a command (``--export``), whose advice is then
    ``--force``, as :func:`~modquad_gym.core.outputs.check_output_file` words it. Returns the
    path written."""
    from modquad_gym.core.outputs import check_output_file, write_text
    from modquad_gym.core.validation import check_flag, check_path

    force = check_flag(force, "force")
    check_path(path)
    path = Path(path)
    fmt = export_format(path, fmt)
    text = export_text(structure, fmt, f_max)  # before touching the file: errors leave it alone
    path = check_output_file(path, force=force, what=what)
    write_text(path, text)
    ratio = thrust_to_weight(structure, f_max)
    if ratio < 1.0:
        from modquad_gym.core.notes import note

        note(
            f"warning: this robot cannot hover on its own rotors ({path}: thrust-to-weight "
            f"{ratio:.3f} at f_max {f_max:g} N); it hovers from "
            f"f_max {hover_f_max(structure):.3g} N (the documentation's page \"Export a "
            'structure", section "Exports that fly")',  # by title: a wheel has no docs/
            __name__,
        )
    return path


def check_structure(structure: object) -> Structure:
    """``structure`` itself when it is a :class:`~modquad_gym.geometry.structure.Structure`,
    else a ValueError naming its type (what every writer takes; its mass and inertia are
    finite: module masses are at most :data:`~modquad_gym.geometry.module.MAX_MASS`)."""
    if not isinstance(structure, Structure):
        raise ValueError(
            f"structure must be a modquad_gym.Structure, got {type(structure).__name__}"
        )
    return structure


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


def _shape(link: ET.Element, kind: str, name: str, at: np.ndarray, shape: tuple) -> None:
    """A ``<visual>`` or ``<collision>`` (``kind``) of ``link``: ``shape`` = (geometry tag,
    attributes) at ``at`` in the link frame."""
    element = ET.SubElement(link, kind, name=name)
    ET.SubElement(element, "origin", xyz=_vec(at), rpy="0 0 0")
    ET.SubElement(ET.SubElement(element, "geometry"), shape[0], **shape[1])


def _num(x: float) -> str:
    return repr(float(x))


def _vec(v) -> str:
    return " ".join(_num(x) for x in v)
