"""Export round-trips: the MJCF loads in MuJoCo with one actuator per rotor producing A u, the
URDF parses with a maintained URDF library (yourdfpy) into the same rotor frames, mass and
inertia, and the JSON holds the structure's numbers; the command line writes each format."""

from __future__ import annotations

import io
import json
import re

import numpy as np
import pytest

import modquad_gym as mq
from modquad_gym.cli import main
from modquad_gym.geometry.module import STOCK_TYPES as T
from modquad_gym.sim.export import quaternion_matrix, rotor_quaternion, structure_dict, urdf_text

STRUCTURES = [
    mq.Structure([(0, 0)]),
    mq.Structure([(0, 0), (1, 0), (0, 1)]),
    mq.Structure(
        [(0, 0), (1, 0), (2, 0), (1, 1)], modules=[T["t45"], T["flat"], T["t30m"], T["t45m"]]
    ),  # fmt: skip
]
IDS = ["one", "L3", "mixed4"]


@pytest.mark.parametrize("s", STRUCTURES, ids=IDS)
def test_mjcf_loads_in_mujoco_with_one_actuator_per_rotor(s):
    mujoco = pytest.importorskip("mujoco")
    from modquad_gym.sim.export import mjcf_text

    model = mujoco.MjModel.from_xml_string(mjcf_text(s, f_max=2.0))
    n = 4 * s.n_modules
    assert model.nu == n and model.nsite == n
    body = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, "structure")
    assert model.body_mass[body] == pytest.approx(s.mass, rel=1e-6)
    np.testing.assert_allclose(np.sort(model.body_inertia[body]),
                               np.linalg.eigvalsh(s.inertia), rtol=1e-5)  # fmt: skip
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    for k in range(n):
        site = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_SITE, f"rotor{k}")
        R = data.site_xmat[site].reshape(3, 3)
        np.testing.assert_allclose(model.site_pos[site], s.rotor_positions[k], atol=1e-6)
        np.testing.assert_allclose(R[:, 2], s.rotor_directions[k], atol=2e-6)
        assert model.actuator_ctrlrange[k].tolist() == [0.0, 2.0]
    u = np.random.default_rng(0).uniform(0, 2, n)
    data.ctrl[:] = u
    mujoco.mj_forward(model, data)
    q = data.qfrc_actuator[:6]  # force in the world (= {S} at rest), torque in the body frame
    np.testing.assert_allclose(q, s.configuration_matrix() @ u, atol=1e-5)


@pytest.mark.parametrize("s", STRUCTURES, ids=IDS)
def test_urdf_parses_into_the_same_rotor_frames_mass_and_inertia(s):
    yourdfpy = pytest.importorskip("yourdfpy")
    robot = yourdfpy.URDF.load(io.StringIO(urdf_text(s)), load_meshes=False)
    assert robot.validate()
    assert robot.base_link == "base_link"
    # the links together (base and propellers) are exactly the structure's rigid body
    mass, com, J = composite_inertial(robot)
    assert mass == pytest.approx(s.mass, rel=1e-12)
    np.testing.assert_allclose(com, 0.0, atol=1e-15)
    np.testing.assert_allclose(J, s.inertia, atol=1e-15)
    assert all(link.inertial.mass > 0 for link in robot.robot.links)  # no massless moving link
    for k in range(4 * s.n_modules):
        T_k = robot.get_transform(f"rotor{k}", "base_link")
        np.testing.assert_allclose(T_k[:3, 3], s.rotor_positions[k], atol=1e-12)
        np.testing.assert_allclose(T_k[:3, 2], s.rotor_directions[k], atol=1e-12)
        joint = robot.joint_map[f"rotor{k}_joint"]
        assert joint.type == "continuous"
        np.testing.assert_allclose(joint.axis, [0, 0, -s.rotor_spins[k]])
    assert len(robot.link_map["base_link"].visuals) == s.n_modules
    assert len(robot.link_map["base_link"].collisions) == s.n_modules  # a box per module
    assert all(len(robot.link_map[f"rotor{k}"].collisions) == 1 for k in range(4 * s.n_modules))


def composite_inertial(robot) -> tuple[float, np.ndarray, np.ndarray]:
    """(mass, COM, inertia about the COM) of every link of a yourdfpy robot, in base_link axes."""
    parts = []
    for link in robot.robot.links:
        T = robot.get_transform(link.name, "base_link") @ link.inertial.origin
        parts.append(
            (link.inertial.mass, T[:3, 3], T[:3, :3] @ link.inertial.inertia @ T[:3, :3].T)
        )
    mass = sum(m for m, _, _ in parts)
    com = sum(m * c for m, c, _ in parts) / mass
    J = sum(I + m * (np.eye(3) * ((c - com) @ (c - com)) - np.outer(c - com, c - com))
            for m, c, I in parts)  # fmt: skip
    return mass, com, J


@pytest.mark.parametrize("fmt", ["mjcf", "urdf"])
@pytest.mark.parametrize("s", STRUCTURES, ids=IDS)
def test_mjcf_and_urdf_load_in_mujoco_and_step(s, fmt):
    """Both exports load in MuJoCo (the URDF's propeller links have mass: a massless moving link
    is refused) and simulate: a few steps with the rotors at half thrust stay finite."""
    mujoco = pytest.importorskip("mujoco")
    from modquad_gym.sim.export import export_text

    model = mujoco.MjModel.from_xml_string(export_text(s, fmt, f_max=2.0))
    data = mujoco.MjData(model)
    if fmt == "mjcf":  # one free body, one actuator per rotor
        assert model.nv == 6 and model.nu == 4 * s.n_modules
        data.ctrl[:] = 1.0
    else:  # a plain import: base_link a body welded to the world, a hinge per propeller
        assert model.njnt == model.nv == 4 * s.n_modules
        assert model.body_mass[1:].sum() == pytest.approx(s.mass)
        data.qvel[:] = 100.0  # spinning propellers
    qpos0 = data.qpos.copy()
    for _ in range(20):
        mujoco.mj_step(model, data)
    assert np.isfinite(data.qpos).all() and np.isfinite(data.qvel).all()
    assert not np.allclose(data.qpos, qpos0)  # it moved: the steps did simulate


@pytest.mark.parametrize("s", STRUCTURES, ids=IDS)
def test_urdf_floats_in_mujoco_with_its_inertials_and_collision_geometry(s, tmp_path):
    """urdf_spec adds the free joint MuJoCo's URDF import leaves out: the robot is one floating
    rigid body of the structure's mass, COM and inertia (the free joint's block of the mass
    matrix), with a collision box per module and a disc per propeller, and it falls freely."""
    mujoco = pytest.importorskip("mujoco")
    from modquad_gym.sim.export import urdf_spec

    path = tmp_path / "s.urdf"
    path.write_text(urdf_text(s))
    model = urdf_spec(path).compile()
    n = 4 * s.n_modules
    assert model.jnt_type[0] == mujoco.mjtJoint.mjJNT_FREE and model.jnt_bodyid[0] == 1
    assert model.nq == 7 + n and model.nv == 6 + n  # a hinge per propeller
    collide = model.geom_contype != 0
    assert collide.sum() == s.n_modules + n  # module boxes and propeller discs
    assert (~collide).sum() == s.n_modules + n  # their visuals, kept by the <mujoco> hint
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    assert data.ncon == 0  # no part of the robot touches another
    assert model.body_subtreemass[1] == pytest.approx(s.mass, rel=1e-12)
    np.testing.assert_allclose(data.subtree_com[1], 0.0, atol=1e-12)
    M = np.zeros((model.nv, model.nv))
    mujoco.mj_fullM(model, data, M)
    np.testing.assert_allclose(M[:3, :3], s.mass * np.eye(3), rtol=1e-12)
    np.testing.assert_allclose(M[:3, 3:6], 0.0, atol=1e-12)  # the COM at the base's origin
    np.testing.assert_allclose(M[3:6, 3:6], s.inertia, atol=1e-12)
    steps = 100
    for _ in range(steps):
        mujoco.mj_step(model, data)
    t = steps * model.opt.timestep  # semi-implicit Euler: z = -g t^2 (1 + 1 / steps) / 2
    assert data.qpos[2] == pytest.approx(-9.81 * t * t * (1 + 1 / steps) / 2, rel=1e-9)


@pytest.mark.parametrize("s", STRUCTURES, ids=IDS)
def test_json_holds_the_structure(s):
    d = json.loads(json.dumps(structure_dict(s, f_max=1.5)))
    np.testing.assert_array_equal(d["configuration_matrix"], s.configuration_matrix())
    assert d["mass"] == s.mass and d["f_max"] == 1.5 and d["n_modules"] == s.n_modules
    np.testing.assert_array_equal(d["inertia"], s.inertia)
    assert [m["type"] for m in d["modules"]] == [m.name for m in s.modules]
    np.testing.assert_array_equal([m["centre"] for m in d["modules"]], s.module_centres)
    for k, rotor in enumerate(d["rotors"]):
        assert rotor["module"] == k // 4 and rotor["spin"] == s.rotor_spins[k]
        np.testing.assert_array_equal(rotor["position"], s.rotor_positions[k])
        R = quaternion_matrix(rotor["quaternion"])
        np.testing.assert_allclose(R[:, 2], s.rotor_directions[k], atol=1e-15)


def test_rotor_frame_is_the_tilt_about_the_arm():
    d = T["t45"].directions[0]
    q = rotor_quaternion(d)
    axis = q[1:] / np.linalg.norm(q[1:])
    arm = T["t45"].positions[0] / np.linalg.norm(T["t45"].positions[0])
    assert abs(axis @ arm) == pytest.approx(1.0)  # rotation about the arm
    assert 2 * np.arccos(q[0]) == pytest.approx(np.pi / 4)  # by the tilt
    np.testing.assert_allclose(quaternion_matrix(rotor_quaternion([0, 0, -1.0]))[:, 2], [0, 0, -1])


def test_export_command_writes_each_format(tmp_path, capsys):
    yourdfpy = pytest.importorskip("yourdfpy")
    cells = "[[0,0],[1,0],[0,1]]"
    assert main(["export", "--cells", cells, "--modules", "t45,flat,t45m",
                 "--out", str(tmp_path / "s.urdf")]) == 0  # fmt: skip
    robot = yourdfpy.URDF.load(str(tmp_path / "s.urdf"), load_meshes=False)
    assert len(robot.joint_map) == 12
    assert main(["export", "--task", "example:screwdriver", "--format", "json",
                 "--out", str(tmp_path / "found.data")]) == 0  # fmt: skip
    found = json.loads((tmp_path / "found.data").read_text())
    assert found["n_modules"] == 3 and found["f_max"] == 1.0
    assert main(["solve", "--task", "example:screwdriver", "--export",
                 str(tmp_path / "solved.json")]) == 0  # fmt: skip
    assert json.loads((tmp_path / "solved.json").read_text()) == found
    pytest.importorskip("mujoco")
    assert main(["export", "--cells", cells, "--out", str(tmp_path / "s.xml")]) == 0
    assert "<mujoco" in (tmp_path / "s.xml").read_text()


def test_export_refuses_bad_requests_before_any_work(tmp_path, capsys):
    out = tmp_path / "s.json"
    out.write_text("keep")
    assert main(["export", "--cells", "[[0,0]]", "--out", str(out)]) == 2  # no --force
    assert out.read_text() == "keep"
    assert main(["export", "--cells", "[[0,0]]", "--out", str(out), "--force"]) == 0
    assert main(["export", "--cells", "[[0,0]]", "--task", "example:screwdriver",
                 "--out", str(tmp_path / "a.json")]) == 2  # fmt: skip
    assert main(["export", "--cells", "[[0,0]]", "--out", str(tmp_path / "a.txt")]) == 2
    assert main(["solve", "--task", "example:screwdriver", "--task", "example:paper_seed0",
                 "--export", str(tmp_path / "b.json")]) == 2  # fmt: skip
    assert main(["solve", "--task", "example:screwdriver", "--export",
                 str(tmp_path / "b.stl")]) == 2  # fmt: skip
    err = capsys.readouterr().err
    assert "exists (use --force" in err and "give either --cells" in err
    assert "--export: give one task" in err and "--export: " in err
    assert not (tmp_path / "a.json").exists() and not (tmp_path / "b.json").exists()


# --- exports that fly -----------------------------------------------------------------------
def plain_thrust_to_weight(s, f_max: float) -> float:
    """The reference: max lambda with A u = lambda m g e3 (no torque), 0 <= u <= f_max (LP)."""
    from scipy.optimize import linprog

    A = s.configuration_matrix()
    w = np.array([0.0, 0.0, s.mass * mq.GRAVITY, 0.0, 0.0, 0.0])
    k = A.shape[1]
    res = linprog(np.r_[np.zeros(k), -1.0], A_eq=np.c_[A, -w], b_eq=np.zeros(6),
                  bounds=[(0, f_max)] * k + [(0, None)], method="highs")  # fmt: skip
    return float(res.x[-1])


@pytest.mark.parametrize("s", STRUCTURES, ids=IDS)
def test_thrust_to_weight_is_the_hover_lp_and_hover_f_max_its_boundary(s):
    from modquad_gym.sim.export import hover_f_max, thrust_to_weight

    for f_max in (1.0, 2.1):  # the oracle's tolerance: thrust bounds widened by TOL / 2
        assert thrust_to_weight(s, f_max) == pytest.approx(plain_thrust_to_weight(s, f_max),
                                                           rel=1e-6)  # fmt: skip
    need = hover_f_max(s)
    hover = [[0.0, 0.0, s.mass * mq.GRAVITY, 0.0, 0.0, 0.0]]
    A = s.configuration_matrix()
    assert mq.feasible(A, hover, f_max=need * (1 + 1e-6))[0]
    assert not mq.feasible(A, hover, f_max=need * (1 - 1e-6))[0]
    if not s.is_mixed:  # T-modules: every rotor's vertical thrust, over the weight
        eta = np.pi / 4
        assert thrust_to_weight(s, 1.0) == pytest.approx(
            4 * s.n_modules * np.cos(eta) / (s.mass * mq.GRAVITY), rel=1e-6
        )
        assert thrust_to_weight(s, 1.0) == pytest.approx(0.961, abs=5e-4)  # 2.83 N vs 2.94 N


def test_every_format_states_its_thrust_to_weight(tmp_path):
    mujoco = pytest.importorskip("mujoco")
    from modquad_gym.sim.export import export_text, thrust_to_weight

    s = STRUCTURES[1]
    ratio = thrust_to_weight(s, 2.1)
    for fmt in ("mjcf", "urdf"):
        assert "thrust-to-weight 2.018 at f_max 2.1 N per rotor" in export_text(s, fmt, 2.1)
    model = mujoco.MjModel.from_xml_string(export_text(s, "mjcf", 2.1))
    # MuJoCo's XML writer keeps 6 significant digits
    assert model.numeric("thrust_to_weight").data[0] == pytest.approx(ratio, rel=1e-5)
    assert model.numeric("hover_f_max").data[0] == pytest.approx(2.1 / ratio, rel=1e-5)
    d = json.loads(export_text(s, "json", 2.1))
    assert d["thrust_to_weight"] == ratio and d["units"]["thrust"] == "N"
    assert "it cannot lift itself" in export_text(s, "urdf", 1.0)


def test_an_exported_mjcf_hovers_on_its_own_rotors_when_it_can_lift_itself(tmp_path, capsys):
    """The file alone, gravity and the package's hover controller, no external load: at 2.1 N
    per rotor (thrust-to-weight 2.02) the screwdriver's structure comes back from the take-off
    offset within 1 s; at the default 1 N (0.961) it sinks, and the command says so."""
    pytest.importorskip("mujoco")
    from modquad_gym.sim.export_flight import fly_mjcf

    out = tmp_path / "hover.xml"
    assert main(["export", "--task", "example:screwdriver", "--f-max", "2.1",
                 "--out", str(out)]) == 0  # fmt: skip
    said = capsys.readouterr()
    assert "thrust-to-weight 2.018" in said.out and "it hovers" in said.out
    assert "warning" not in said.err
    flight = fly_mjcf(out, seconds=1.0)
    assert flight.thrust_to_weight == pytest.approx(2.018, abs=1e-3)
    assert flight.max_position_error_m == pytest.approx(0.041, abs=2e-3)  # the start offset
    assert flight.final_position_error_m < 0.01 and flight.final_attitude_error_rad < 0.01
    assert flight.saturated_fraction == 0.0

    sinks = tmp_path / "sinks.xml"
    assert main(["export", "--cells", "[[0,0]]", "--out", str(sinks)]) == 0
    said = capsys.readouterr()
    assert "thrust-to-weight 0.961" in said.out and "cannot lift itself" in said.out
    assert said.err.count("\n") == 1 and "warning: this robot cannot hover" in said.err
    # the warning comes from save_structure (logger modquad_gym): solve --export says it too
    assert main(["solve", "--task", "example:screwdriver", "--quiet", "--export",
                 str(tmp_path / "solved.urdf")]) == 0  # fmt: skip
    assert "warning: this robot cannot hover" in capsys.readouterr().err
    fall = fly_mjcf(sinks.read_text(), seconds=1.0)
    assert fall.thrust_to_weight < 1 and fall.saturated_fraction == 1.0
    assert fall.final_position_error_m > 0.2  # it sank


def test_fly_mjcf_refuses_a_model_that_is_not_an_export(tmp_path):
    pytest.importorskip("mujoco")
    from modquad_gym.sim.export_flight import fly_mjcf

    other = tmp_path / "other.xml"
    other.write_text('<mujoco><worldbody><body name="b"><freejoint/>'
                     '<geom size="0.1"/></body></worldbody></mujoco>')  # fmt: skip
    with pytest.raises(ValueError, match=r"other.xml: no free body 'structure'"):
        fly_mjcf(other)
    with pytest.raises(ValueError, match="seconds"):
        fly_mjcf(other, seconds=0)


def test_the_hover_warning_names_the_docs_page_by_its_title(tmp_path, capsys):
    """A wheel install has no docs/ folder: the warning names the page and section by the
    titles the documentation site shows, and both exist in docs/export.md."""
    from pathlib import Path

    from modquad_gym.sim.export import save_structure

    save_structure(mq.Structure([(0, 0)]), tmp_path / "one.json")
    said = capsys.readouterr().err
    page = (Path(__file__).resolve().parents[1] / "docs" / "export.md").read_text()
    title, section = re.search(r'page "([^"]+)", section "([^"]+)"', said).groups()
    assert page.startswith(f"# {title}\n") and f"\n## {section}\n" in page
    assert "docs/" not in said and said.count("\n") == 1
