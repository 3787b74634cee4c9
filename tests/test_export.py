"""Export round-trips: the MJCF loads in MuJoCo with one actuator per rotor producing A u, the
URDF parses with a maintained URDF library (yourdfpy) into the same rotor frames, mass and
inertia, and the JSON holds the structure's numbers; the command line writes each format."""

from __future__ import annotations

import io
import json

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
    assert len([v for v in robot.link_map["base_link"].visuals]) == s.n_modules


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
    else:  # base_link fixed to the world (URDF has no floating base), a hinge per propeller
        assert model.njnt == model.nv == 4 * s.n_modules
        assert model.body_mass[1:].sum() == pytest.approx(0.04 * s.mass)  # the propellers
        data.qvel[:] = 100.0  # spinning propellers
    qpos0 = data.qpos.copy()
    for _ in range(20):
        mujoco.mj_step(model, data)
    assert np.isfinite(data.qpos).all() and np.isfinite(data.qvel).all()
    assert not np.allclose(data.qpos, qpos0)  # it moved: the steps did simulate


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
