"""MuJoCo model of a :class:`~modquad_gym.Structure`: one free rigid body driven by 4n rotors.

The model (MJCF, compiled by :func:`build_model`):

* Body ``structure`` with a free joint. Its frame is the structure frame {S}: origin at the COM of
  the module centres, axes parallel to the modules', z up. It starts at ``(0, 0, HOME_HEIGHT)``.
* The body's mass and inertia are given explicitly (an ``inertial`` element at the origin):
  :attr:`Structure.mass` and :attr:`Structure.inertia` (each module its type's ``mass``, default
  0.3 kg, and ``inertia``, default a uniform box of side x side x 0.05 m, with parallel-axis
  terms; ``module_mass`` overrides every module's mass and scales its inertia alike). {S} sits at
  the mass-weighted centre of the module centres, so the body's COM is the origin of {S} for
  mixed structures too. So the simulated body is exactly the one the dynamic tasks' wrenches are
  computed for (:mod:`modquad_gym.dynamics`). One box geom per module (side x side x
  ``MODULE_THICKNESS``, drawn 3 % smaller so that neighbours show apart) and the rotor discs
  are massless visuals; modules are coloured by type (the first module of a one-type structure
  green).
* One site ``rotor{k}`` per rotor at p_k, oriented so that its z-axis is the thrust direction d_k.
* One ``general`` actuator per rotor on its site: ``gear = (0, 0, 1, 0, 0, s_k c_tau)`` (thrust
  along the site z-axis plus the spin-signed drag torque about it), ``gainprm = 1``, no bias, no
  activation dynamics, ``ctrlrange = [0, f_max]`` with ``ctrllimited``. So ``ctrl = u`` produces
  exactly the wrench ``A u`` about the COM (checked by :func:`actuator_wrench`).
* Contacts are disabled: the structure flies, or hangs on the bench, and never touches anything.

With ``bench=True`` the model also holds the load cell of :mod:`modquad_gym.sim.bench`: a child
body ``load_cell`` rigidly attached to ``structure`` at the COM (no joint), with force and torque
sensors on its site ``load_cell``, and a weld equality that bolts ``load_cell`` to the world (the
wall). The structure therefore keeps its six DOF (nv = 6, actuators act) and every wrench it
makes flows through the load cell into the wall.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from modquad_gym.geometry.inertia import inertia_about_com
from modquad_gym.geometry.module import DEFAULT_HEIGHT, DEFAULT_MASS, GRAVITY
from modquad_gym.geometry.structure import Structure
from modquad_gym.oracle import check_f_max
from modquad_gym.viz.raster import type_colour

MODULE_MASS = DEFAULT_MASS
"""Default mass of one module in kg (:data:`modquad_gym.geometry.module.DEFAULT_MASS`)."""

MODULE_THICKNESS = DEFAULT_HEIGHT
"""Height of a module's box in metres (drawn; the inertia is each module type's own)."""

HOME_HEIGHT = 1.0
"""Height of the COM above the floor at qpos0, in metres."""

TIMESTEP = 0.001
"""Simulation time step in seconds."""

LOAD_CELL_MASS = 0.01
"""Mass of the load cell's plate (bench only), kg."""

_ROTOR_RADIUS_FRACTION = 0.14  # rotor disc radius as a fraction of the module side
_ROTOR_COLOURS = {1.0: "0.85 0.2 0.2 0.9", -1.0: "0.2 0.35 0.85 0.9"}
_MODULE_COLOURS = ("0.3 0.7 0.35 1", "0.55 0.55 0.6 1")  # first (initial) module green


@dataclass(frozen=True)
class SimModel:
    """A compiled MuJoCo model of a structure and what is needed to read it back.

    Attributes:
        model: the ``mujoco.MjModel``.
        structure: the structure it was built from.
        A: the structure's configuration matrix (6, 4n); actuator k is column k.
        f_max: the rotors' thrust limit (the actuators' ctrlrange is [0, f_max]).
        mass: mass of body ``structure`` (the modules) in kg, the load cell excluded.
        body_id: id of body ``structure``.
        bench: True when the model holds the load cell and the wall weld.
        xml: the MJCF text it was compiled from.
    """

    model: object
    structure: Structure
    A: np.ndarray
    f_max: float
    mass: float
    body_id: int
    bench: bool
    xml: str

    @property
    def n_rotors(self) -> int:
        return self.A.shape[1]

    def new_data(self):
        """A fresh ``mujoco.MjData`` at qpos0 (COM at (0, 0, HOME_HEIGHT), level), forwarded."""
        import mujoco

        data = mujoco.MjData(self.model)
        mujoco.mj_forward(self.model, data)
        return data


def _fmt(v: np.ndarray | list[float]) -> str:
    return " ".join(f"{float(x):.17g}" for x in v)


def _masses(structure: Structure, module_mass: float | None) -> np.ndarray:
    """Each module's mass in kg: its type's, or ``module_mass`` for every module."""
    if module_mass is None:
        return structure.masses
    if (
        isinstance(module_mass, bool)
        or not isinstance(module_mass, (int, float, np.integer, np.floating))
        or not (module_mass > 0 and np.isfinite(module_mass))
    ):
        raise ValueError(f"module_mass must be a positive mass in kg, got {module_mass!r}")
    return np.full(structure.n_modules, float(module_mass))


def model_xml(
    structure: Structure,
    f_max: float = 1.0,
    module_mass: float | None = None,
    bench: bool = False,
    payload=None,
) -> str:
    """The MJCF text of a structure's model (see the module docstring). ``module_mass`` (kg)
    overrides every module's own type mass; with differing type masses it would move the COM
    away from {S}, so it is refused for such a mixed structure. ``payload`` (a
    :class:`~modquad_gym.dynamics.Payload`) adds a point mass welded at its offset from the COM
    (body ``payload``, drawn as a small sphere)."""
    if not isinstance(structure, Structure):
        raise ValueError(
            f"structure must be a modquad_gym.Structure, got {type(structure).__name__}"
        )
    f_max = check_f_max(f_max)
    masses = _masses(structure, module_mass)
    if module_mass is not None and np.ptp(structure.masses) > 0:
        raise ValueError(
            "module_mass: the structure's module types weigh differently; their masses place "
            "its COM, so leave module_mass=None"
        )
    discs, sites, actuators = _rotor_elements(structure, f_max)
    load_cell, equality, sensors = _BENCH_ELEMENTS if bench else ("", "", "")
    if payload is not None and payload.mass > 0:
        load_cell += (
            f'<body name="payload" pos="{_fmt(payload.offset)}"><inertial pos="0 0 0" '
            f'mass="{payload.mass:.17g}" diaginertia="0 0 0"/><geom name="payload" '
            'type="sphere" size="0.04" mass="0" rgba="0.9 0.5 0.1 1"/></body>'
        )
    nl = "\n    "
    extent = structure.side * (1 + max(np.ptp(np.asarray(structure.cells), axis=0)))
    return _MJCF.format(
        inertial=_inertial(structure, masses),
        n_modules=structure.n_modules,
        timestep=TIMESTEP,
        gravity=f"{-GRAVITY:.17g}",
        home=HOME_HEIGHT,
        extent=f"{extent:.6g}",
        floor=f"{max(5.0, 2.0 * extent + 2.0):.6g}",
        geoms=nl.join(_module_geoms(structure, masses) + discs),
        sites=nl.join(sites),
        load_cell=load_cell,
        equality=equality,
        actuators=nl.join(actuators),
        sensors=sensors,
    )


def _inertial(structure: Structure, masses: np.ndarray) -> str:
    """The body's ``inertial`` element: total mass and inertia about the COM (module docstring)."""
    scale = masses / structure.masses
    own = [m.inertia * k for m, k in zip(structure.modules, scale)]
    J = inertia_about_com(structure.module_centres, masses, own)
    full = _fmt([J[0, 0], J[1, 1], J[2, 2], J[0, 1], J[0, 2], J[1, 2]])
    return f'<inertial pos="0 0 0" mass="{float(masses.sum()):.17g}" fullinertia="{full}"/>'


def _module_geoms(structure: Structure, masses: np.ndarray) -> list[str]:
    """One box geom per module, coloured by type (one type: the first module green)."""
    half = structure.side / 2.0
    geoms = []
    for i, (c, t) in enumerate(zip(structure.module_centres, structure.type_indices)):
        if structure.is_mixed:  # the fills of the pictures (modquad_gym.viz.raster.type_colour)
            fill = type_colour(structure.modules[i], t)
            rgba = " ".join(f"{int(fill[k : k + 2], 16) / 255:.3g}" for k in (1, 3, 5)) + " 1"
        else:
            rgba = _MODULE_COLOURS[0] if i == 0 else _MODULE_COLOURS[1]
        geoms.append(
            f'<geom name="module{i}" type="box" pos="{_fmt(c)}" '
            f'size="{half * 0.97:.17g} {half * 0.97:.17g} {MODULE_THICKNESS / 2:.17g}" '
            f'mass="0" rgba="{rgba}"/>'
        )
    return geoms


def _rotor_elements(structure: Structure, f_max: float) -> tuple[list, list, list]:
    """Per rotor: its visual disc geom, its thrust site and its actuator."""
    discs, sites, actuators = [], [], []
    radius = _ROTOR_RADIUS_FRACTION * structure.side
    lift = MODULE_THICKNESS / 2 + 0.8 * radius  # discs clear the box at 45 degree tilt
    rotors = zip(structure.rotor_positions, structure.rotor_directions, structure.rotor_spins,
                 structure.rotor_c_tau, strict=True)  # fmt: skip
    for k, (p, d, s, c_tau) in enumerate(rotors):
        rgba = _ROTOR_COLOURS[1.0 if s > 0 else -1.0]
        sites.append(f'<site name="rotor{k}" pos="{_fmt(p)}" zaxis="{_fmt(d)}" size="0.005"/>')
        disc_pos = p + np.array([0.0, 0.0, lift])
        discs.append(
            f'<geom name="disc{k}" type="cylinder" pos="{_fmt(disc_pos)}" zaxis="{_fmt(d)}" '
            f'size="{radius:.17g} 0.004" mass="0" rgba="{rgba}" group="1"/>'
        )
        actuators.append(
            f'<general name="thrust{k}" site="rotor{k}" gear="0 0 1 0 0 {s * c_tau:.17g}" '
            f'ctrllimited="true" ctrlrange="0 {f_max:.17g}" dyntype="none" gaintype="fixed" '
            f'gainprm="1" biastype="none"/>'
        )
    return discs, sites, actuators


_BENCH_ELEMENTS = (
    f'<body name="load_cell" pos="0 0 0">'
    f'<geom name="load_cell" type="cylinder" size="0.03 0.03" mass="{LOAD_CELL_MASS}" '
    f'rgba="0.9 0.8 0.1 1"/>'
    f'<site name="load_cell" pos="0 0 0" size="0.01"/></body>',
    '<equality><weld name="wall" body1="load_cell" solref="0.005 1"/></equality>',
    '<sensor><force name="force" site="load_cell"/>'
    '<torque name="torque" site="load_cell"/></sensor>',
)
"""The bench's load cell body (inside ``structure``), its wall weld and its sensors."""

_MJCF = """<mujoco model="modquad_{n_modules}">
  <compiler angle="radian" autolimits="true"/>
  <option timestep="{timestep}" integrator="implicitfast" gravity="0 0 {gravity}"
    tolerance="1e-15" iterations="200" ls_tolerance="1e-12">
    <flag contact="disable"/>
  </option>
  <statistic center="0 0 {home}" extent="{extent}"/>
  <visual><headlight ambient="0.4 0.4 0.4" diffuse="0.6 0.6 0.6"/>
    <global offwidth="1280" offheight="960"/></visual>
  <asset>
    <texture name="grid" type="2d" builtin="checker" rgb1="0.92 0.92 0.92" rgb2="0.8 0.8 0.8"
      width="256" height="256"/>
    <material name="grid" texture="grid" texrepeat="8 8"/>
  </asset>
  <worldbody>
    <light pos="0 0 4" dir="0 0 -1" directional="true"/>
    <geom name="floor" type="plane" size="{floor} {floor} 0.05" material="grid" contype="0"
      conaffinity="0"/>
    <body name="structure" pos="0 0 {home}">
    <freejoint name="root"/>
    {inertial}
    {geoms}
    {sites}
    {load_cell}
    </body>
  </worldbody>
  {equality}
  <actuator>
    {actuators}
  </actuator>
  {sensors}
</mujoco>
"""
"""The MJCF skeleton :func:`model_xml` fills in."""


def build_model(
    structure: Structure,
    f_max: float = 1.0,
    module_mass: float | None = None,
    bench: bool = False,
    payload=None,
) -> SimModel:
    """Compile the MuJoCo model of ``structure`` (see the module docstring).

    Args:
        structure: the structure; its frame {S} becomes the free body's frame.
        f_max: rotor thrust limit in N (actuator ctrlrange [0, f_max]).
        module_mass: mass of every module in kg (default: each module type's ``mass``).
        bench: add the load cell and the wall weld of the wrench bench.
        payload: a :class:`~modquad_gym.dynamics.Payload` welded to the structure, or None.
    """
    import mujoco

    xml = model_xml(structure, f_max, module_mass, bench, payload)
    model = mujoco.MjModel.from_xml_string(xml)
    body = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, "structure")
    mass = float(model.body_mass[body])
    A = np.array(structure.configuration_matrix())
    return SimModel(model, structure, A, check_f_max(f_max), mass, body, bench, xml)


def body_rotation(sim: SimModel, data) -> np.ndarray:
    """R (3, 3): the orientation of {S} in the world frame (columns are {S}'s axes)."""
    return np.array(data.xmat[sim.body_id]).reshape(3, 3)


def actuator_wrench(sim: SimModel, data) -> np.ndarray:
    """The rotors' wrench [f; tau] in {S}, torque about the COM, from MuJoCo's ``qfrc_actuator``.

    MuJoCo's free-joint generalised forces are the force in the *world* frame (dofs 0-2) and the
    torque about the joint anchor (the body origin, here the COM) in the *body* frame (dofs 3-5),
    so the force is rotated back into {S} and the torque is taken as is. ``mj_forward`` (or a
    step) must have run after setting ``data.ctrl``.
    """
    q = np.array(data.qfrc_actuator[:6])
    R = body_rotation(sim, data)
    return np.concatenate([R.T @ q[:3], q[3:]])
