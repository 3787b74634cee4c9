"""MuJoCo model of a :class:`~modquad_gym.Structure`: one free rigid body driven by 4n rotors.

The model is built with MuJoCo's model-editing API (:func:`model_spec`, a ``mujoco.MjSpec``) and
compiled by :func:`build_model`; :func:`model_xml` is its MJCF text, written by MuJoCo (whose XML
writer keeps 6 significant digits: a model loaded back from the text differs from the compiled
spec by about 1e-6 relative, e.g. in the rotor site quaternions). It has:

* Body ``structure`` with a free joint. Its frame is the structure frame {S}: origin at the COM of
  the module centres, axes parallel to the modules', z up. It starts at ``(0, 0, HOME_HEIGHT)``.
* The body's mass and inertia are given explicitly (an inertial at the origin, the inertia as
  principal axes ``iquat`` and moments: :func:`~modquad_gym.sim.inertial.principal_axes`, so
  that a flat body keeps MuJoCo's A + B >= C; a module type whose inertia MuJoCo cannot compile
  is refused first, :func:`~modquad_gym.sim.inertial.check_simulable`):
  :attr:`Structure.mass` and :attr:`Structure.inertia` (each module its type's ``mass``, default
  0.3 kg, and ``inertia``, default a uniform box of side x side x 0.05 m, with parallel-axis
  terms; ``module_mass`` overrides every module's mass and scales its inertia alike). {S} sits at
  the mass-weighted centre of the module centres, so the body's COM is the origin of {S} for
  mixed structures too. So the simulated body is exactly the one the dynamic tasks' wrenches are
  computed for (:mod:`modquad_gym.dynamics`). One box geom per module (side x side x
  ``MODULE_THICKNESS``, drawn 3 % smaller so that neighbours show apart) and the rotor discs
  are massless visuals, coloured as in every picture (:mod:`modquad_gym.viz.raster`): rotors by
  spin (+1 blue, -1 orange), modules by type (the first module of a one-type structure green).
* One site ``rotor{k}`` per rotor at p_k, oriented so that its z-axis is the thrust direction d_k.
* One ``general`` actuator per rotor on its site: ``gear = (0, 0, 1, 0, 0, s_k c_tau)`` (thrust
  along the site z-axis plus the spin-signed drag torque about it), ``gainprm = 1``, no bias, no
  activation dynamics, ``ctrlrange = [0, f_max]`` with ``ctrllimited``. So ``ctrl = u`` produces
  exactly the wrench ``A u`` about the COM (checked by :func:`actuator_wrench`).
* Contacts are disabled: the structure flies, or hangs on the bench, and never touches anything.

With ``bench=True`` the model also holds the load cell of the wrench test stand
(:mod:`modquad_gym.sim.wrench_stand`): a child body ``load_cell`` rigidly attached to
``structure`` at the COM (no joint), with force and torque sensors on its site ``load_cell``, and
a weld equality that bolts ``load_cell`` to the world (the wall). The structure therefore keeps
its six DOF (nv = 6, actuators act) and every wrench it makes flows through the load cell into
the wall.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from modquad_gym.core.extras import import_optional
from modquad_gym.core.validation import check_f_max
from modquad_gym.geometry.inertia import inertia_about_com
from modquad_gym.geometry.module import DEFAULT_HEIGHT, GRAVITY
from modquad_gym.geometry.structure import Structure
from modquad_gym.sim.inertial import check_simulable, principal_axes, six_digit_moments
from modquad_gym.viz.raster import SPIN_COLOURS, module_fill, rgba

if TYPE_CHECKING:  # pragma: no cover
    from modquad_gym.dynamics import Payload

MODULE_THICKNESS = DEFAULT_HEIGHT
"""Height of a module's box in metres (drawn; the inertia is each module type's own)."""

HOME_HEIGHT = 1.0
"""Height of the COM above the floor at qpos0, in metres."""

TIMESTEP = 0.001
"""Simulation time step in seconds."""

LOAD_CELL_MASS = 0.01
"""Mass of the load cell's plate (bench only), kg."""

_ROTOR_RADIUS_FRACTION = 0.14  # rotor disc radius as a fraction of the module side
_ROTOR_COLOURS = {float(k): rgba(c, 0.9) for k, c in SPIN_COLOURS.items()}  # the pictures'
_LIT_SHADE, _LIT_SATURATION = 0.7, 2.0  # module fills under MuJoCo's light (see lit_fill)


def lit_fill(colour: str) -> list[float]:
    """The MuJoCo rgba of a module fill (hex, :func:`module_fill`): its hue, darkened and
    saturated so the headlight's ambient, diffuse and specular light do not wash the pale
    picture fills to white (measured: the first module's top rendered (255, 255, 254) beside
    the others' (255, 255, 255) with the plain fill; about 55 apart in red with this one)."""
    c = np.array(rgba(colour)[:3])
    grey = c.mean()
    lit = np.clip(_LIT_SHADE * (grey + _LIT_SATURATION * (c - grey)), 0.0, 1.0)
    return [round(float(v), 3) for v in lit] + [1.0]


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
        xml: the MJCF text of its spec (MuJoCo's writer: 6 significant digits).
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
        mujoco = import_optional("mujoco")

        data = mujoco.MjData(self.model)
        mujoco.mj_forward(self.model, data)
        return data


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


def model_spec(
    structure: Structure,
    f_max: float = 1.0,
    module_mass: float | None = None,
    bench: bool = False,
    payload: Payload | None = None,
):
    """The ``mujoco.MjSpec`` of a structure's model (see the module docstring), built with
    MuJoCo's model-editing API. ``module_mass`` (kg) overrides every module's own type mass; with
    differing type masses it would move the COM away from {S}, so it is refused for such a mixed
    structure. ``payload`` (a :class:`~modquad_gym.dynamics.Payload`) adds a point mass welded at
    its offset from the COM (body ``payload``, drawn as a small sphere)."""
    mujoco = import_optional("mujoco")

    if not isinstance(structure, Structure):
        raise ValueError(
            f"structure must be a modquad_gym.Structure, got {type(structure).__name__}"
        )
    f_max = check_f_max(f_max)
    check_simulable(structure)
    masses = _masses(structure, module_mass)
    if module_mass is not None and np.ptp(structure.masses) > 0:
        raise ValueError(
            "module_mass: the structure's module types weigh differently; their masses place "
            "its COM, so leave module_mass=None"
        )
    spec = mujoco.MjSpec()
    spec.modelname = f"modquad_{structure.n_modules}"
    _set_scene(spec, structure)
    body = spec.worldbody.add_body(name="structure", pos=[0.0, 0.0, HOME_HEIGHT])
    body.add_freejoint(name="root")
    _set_inertial(body, structure, masses)
    _add_modules(body, structure)
    _add_rotors(spec, body, structure, f_max)
    if bench:
        _add_load_cell(spec, body)
    if payload is not None and payload.mass > 0:
        _add_payload(body, payload)
    return spec


def model_xml(
    structure: Structure,
    f_max: float = 1.0,
    module_mass: float | None = None,
    bench: bool = False,
    payload: Payload | None = None,
) -> str:
    """The MJCF text of a structure's model (:func:`model_spec` written out by MuJoCo)."""
    return spec_xml(model_spec(structure, f_max, module_mass, bench, payload))


def spec_xml(spec) -> str:
    """MuJoCo's MJCF text of a :func:`model_spec` spec. MuJoCo's writer keeps 6 significant
    digits, which can tip a flat body's principal moments (C = A + B) over A + B >= C: body
    ``structure``'s moments are written rounded to 6 digits with the largest rounded down
    where needed (:func:`~modquad_gym.sim.inertial.six_digit_moments`), so the text loads."""
    body = spec.body("structure")
    exact = np.array(body.inertia)
    body.inertia = six_digit_moments(exact)
    try:
        return spec.to_xml()
    finally:
        body.inertia = exact


def _set_scene(spec, structure: Structure) -> None:
    """Options (flying, no contacts, tight solver tolerances), statistic, light and floor."""
    mujoco = import_optional("mujoco")

    spec.compiler.degree = False
    spec.compiler.autolimits = True
    opt = spec.option
    opt.timestep = TIMESTEP
    opt.integrator = mujoco.mjtIntegrator.mjINT_IMPLICITFAST
    opt.gravity = [0.0, 0.0, -GRAVITY]
    opt.tolerance, opt.iterations, opt.ls_tolerance = 1e-15, 200, 1e-12
    opt.disableflags |= mujoco.mjtDisableBit.mjDSBL_CONTACT
    extent = structure.side * (1 + max(np.ptp(np.asarray(structure.cells), axis=0)))
    spec.stat.center = [0.0, 0.0, HOME_HEIGHT]
    spec.stat.extent = float(f"{extent:.6g}")
    spec.visual.headlight.ambient = [0.4, 0.4, 0.4]
    spec.visual.headlight.diffuse = [0.6, 0.6, 0.6]
    spec.visual.global_.offwidth, spec.visual.global_.offheight = 1280, 960
    # a sky and a floor a reader recognises: MuJoCo's gradient skybox (blue above, pale at the
    # horizon) and a checker floor of 0.5 m squares with marked edges (texuniform: the squares
    # keep their size as the floor grows with the structure)
    spec.add_texture(
        name="sky", type=mujoco.mjtTexture.mjTEXTURE_SKYBOX,
        builtin=mujoco.mjtBuiltin.mjBUILTIN_GRADIENT, rgb1=[0.35, 0.55, 0.85],
        rgb2=[0.9, 0.93, 0.97], width=256, height=1536,
    )  # fmt: skip
    spec.add_texture(
        name="grid", type=mujoco.mjtTexture.mjTEXTURE_2D,
        builtin=mujoco.mjtBuiltin.mjBUILTIN_CHECKER, rgb1=[0.3, 0.35, 0.4],
        rgb2=[0.42, 0.47, 0.52], mark=mujoco.mjtMark.mjMARK_EDGE, markrgb=[0.7, 0.7, 0.7],
        width=256, height=256,
    )  # fmt: skip
    grid = spec.add_material(name="grid", texrepeat=[1, 1], texuniform=True)
    grid.textures[mujoco.mjtTextureRole.mjTEXROLE_RGB] = "grid"
    spec.worldbody.add_light(
        pos=[0, 0, 4], dir=[0, 0, -1], type=mujoco.mjtLightType.mjLIGHT_DIRECTIONAL
    )
    floor = float(f"{max(5.0, 2.0 * extent + 2.0):.6g}")  # the floor grows with the structure
    spec.worldbody.add_geom(
        name="floor", type=mujoco.mjtGeom.mjGEOM_PLANE, size=[floor, floor, 0.05],
        material="grid", contype=0, conaffinity=0,
    )  # fmt: skip


def _set_inertial(body, structure: Structure, masses: np.ndarray) -> None:
    """The body's explicit inertial: total mass and inertia about the COM (module docstring)."""
    scale = masses / structure.masses
    own = [m.inertia * k for m, k in zip(structure.modules, scale)]
    J = inertia_about_com(structure.module_centres, masses, own)
    body.explicitinertial = True
    body.mass = float(masses.sum())
    body.ipos = [0.0, 0.0, 0.0]
    quat, moments = principal_axes(J)  # a flat body keeps A + B >= C (sim.inertial)
    body.iquat, body.inertia = quat, moments


def _add_modules(body, structure: Structure) -> None:
    """One massless box geom per module, filled as in the pictures (:func:`module_fill`: by
    type, or with one type the first module green), shaded for the light (:func:`lit_fill`)."""
    mujoco = import_optional("mujoco")

    half = structure.side / 2.0 * 0.97
    for i, c in enumerate(structure.module_centres):
        body.add_geom(
            name=f"module{i}", type=mujoco.mjtGeom.mjGEOM_BOX, pos=c,
            size=[half, half, MODULE_THICKNESS / 2], mass=0.0,
            rgba=lit_fill(module_fill(structure, i)),
        )  # fmt: skip


def _add_rotors(spec, body, structure: Structure, f_max: float) -> None:
    """Per rotor: a massless visual disc, a site whose z-axis is the thrust direction, and one
    ``general`` actuator on the site (thrust along z plus the spin-signed drag torque)."""
    mujoco = import_optional("mujoco")

    radius = _ROTOR_RADIUS_FRACTION * structure.side
    lift = MODULE_THICKNESS / 2 + 0.8 * radius  # discs clear the box at 45 degree tilt
    rotors = zip(structure.rotor_positions, structure.rotor_directions, structure.rotor_spins,
                 structure.rotor_c_tau, strict=True)  # fmt: skip
    zaxis = mujoco.mjtOrientation.mjORIENTATION_ZAXIS
    for k, (p, d, s, c_tau) in enumerate(rotors):
        colour = _ROTOR_COLOURS[1.0 if s > 0 else -1.0]
        site = body.add_site(name=f"rotor{k}", pos=p, size=[0.005, 0.005, 0.005])
        site.alt.type, site.alt.zaxis = zaxis, d
        disc = body.add_geom(
            name=f"disc{k}", type=mujoco.mjtGeom.mjGEOM_CYLINDER, pos=p + [0.0, 0.0, lift],
            size=[radius, 0.004, 0.0], mass=0.0, rgba=colour, group=1,
        )  # fmt: skip
        disc.alt.type, disc.alt.zaxis = zaxis, d
        spec.add_actuator(
            name=f"thrust{k}", target=f"rotor{k}", trntype=mujoco.mjtTrn.mjTRN_SITE,
            gear=[0, 0, 1, 0, 0, s * c_tau], ctrllimited=mujoco.mjtLimited.mjLIMITED_TRUE,
            ctrlrange=[0.0, f_max], dyntype=mujoco.mjtDyn.mjDYN_NONE,
            gaintype=mujoco.mjtGain.mjGAIN_FIXED, gainprm=[1.0] + [0.0] * 9,
            biastype=mujoco.mjtBias.mjBIAS_NONE,
        )  # fmt: skip


def _add_payload(body, payload) -> None:
    """A point mass welded to the structure at its offset from the COM, drawn as a sphere."""
    mujoco = import_optional("mujoco")

    child = body.add_body(name="payload", pos=np.asarray(payload.offset, dtype=float))
    child.explicitinertial = True
    child.mass, child.ipos, child.inertia = float(payload.mass), [0.0] * 3, [0.0] * 3
    child.add_geom(
        name="payload", type=mujoco.mjtGeom.mjGEOM_SPHERE, size=[0.04, 0.0, 0.0], mass=0.0,
        rgba=[0.9, 0.5, 0.1, 1.0],
    )  # fmt: skip


def _add_load_cell(spec, body) -> None:
    """The bench's load cell: a child body at the COM (no joint), its force and torque sensors,
    and the weld that bolts it to the world (the wall)."""
    mujoco = import_optional("mujoco")

    cell = body.add_body(name="load_cell", pos=[0.0, 0.0, 0.0])
    cell.add_geom(
        name="load_cell", type=mujoco.mjtGeom.mjGEOM_CYLINDER, size=[0.03, 0.03, 0.0],
        mass=LOAD_CELL_MASS, rgba=[0.9, 0.8, 0.1, 1.0],
    )  # fmt: skip
    cell.add_site(name="load_cell", pos=[0.0, 0.0, 0.0], size=[0.01, 0.005, 0.005])
    # weld data: anchor (0, 0, 0); relpose (0, 1, 0, 0, 0, 0, 0), MuJoCo's "keep the pose at
    # qpos0"; torquescale 1 (MJCF's defaults)
    spec.add_equality(
        name="wall", type=mujoco.mjtEq.mjEQ_WELD, name1="load_cell",
        objtype=mujoco.mjtObj.mjOBJ_BODY, solref=[0.005, 1.0],
        data=[0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0],
    )  # fmt: skip
    for kind, sensor in (("force", mujoco.mjtSensor.mjSENS_FORCE),
                         ("torque", mujoco.mjtSensor.mjSENS_TORQUE)):  # fmt: skip
        spec.add_sensor(
            name=kind, type=sensor, objtype=mujoco.mjtObj.mjOBJ_SITE, objname="load_cell"
        )


def build_model(
    structure: Structure,
    f_max: float = 1.0,
    module_mass: float | None = None,
    bench: bool = False,
    payload: Payload | None = None,
) -> SimModel:
    """Compile the MuJoCo model of ``structure`` (see the module docstring).

    Args:
        structure: the structure; its frame {S} becomes the free body's frame.
        f_max: rotor thrust limit in N (actuator ctrlrange [0, f_max]).
        module_mass: mass of every module in kg (default: each module type's ``mass``).
        bench: add the load cell and the wall weld of the wrench bench.
        payload: a :class:`~modquad_gym.dynamics.Payload` welded to the structure, or None.
    """
    mujoco = import_optional("mujoco")

    spec = model_spec(structure, f_max, module_mass, bench, payload)
    model = spec.compile()
    xml = spec_xml(spec)
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
