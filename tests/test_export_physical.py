"""The exports describe physical bodies for every module type the package accepts: URDF links a
simulator compiles (small or flat module inertias included) with the structure's exact totals,
one propeller (URDF) and one JSON rotor record per rotor for any rotor count, and a module type
whose inertia MuJoCo cannot compile refused before any work, naming the type and ``inertia``."""

from __future__ import annotations

import io
import itertools
import json
import re
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pytest

import modquad_gym as mq
from modquad_gym.geometry.module import STOCK_TYPES, ModuleType
from modquad_gym.geometry.structure import structure_levels
from modquad_gym.sim.export import base_inertial, export_text

mujoco = pytest.importorskip("mujoco")

TILTS = [0.5, -0.5, 0.5, -0.5]
L3 = [(0, 0), (1, 0), (0, 1)]
ANGLES = np.arange(6) * np.pi / 3
HEXA = ModuleType(np.c_[0.12 * np.cos(ANGLES), 0.12 * np.sin(ANGLES), np.zeros(6)],
                  np.tile([0, 0, 1.0], (6, 1)), [1, -1, 1, -1, 1, -1], name="hexa")  # fmt: skip
TRI = ModuleType(STOCK_TYPES["t45"].positions[:3], STOCK_TYPES["t45"].directions[:3], [1, -1, 1],
                 name="tri")  # fmt: skip


def urdf_totals(s: mq.Structure) -> tuple[float, np.ndarray, np.ndarray]:
    """(mass, COM, inertia about the COM) of the exported URDF compiled by the package's own
    loader: the floating base's block of MuJoCo's mass matrix."""
    from modquad_gym.sim.export import urdf_spec

    model = urdf_spec(export_text(s, "urdf")).compile()
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    M = np.zeros((model.nv, model.nv))
    mujoco.mj_fullM(model, data, M)
    return float(model.body_subtreemass[1]), np.array(data.subtree_com[1]), M[3:6, 3:6]


def physical(J: np.ndarray) -> bool:
    p = np.linalg.eigvalsh(J)
    return bool(p[0] > 0 and p[0] + p[1] > p[2])


@pytest.mark.parametrize(
    "module, flat",
    [
        (ModuleType.from_tilts(TILTS, name="lightframe", inertia=np.eye(3) * 1e-5), False),
        (ModuleType.from_tilts(TILTS, name="thin", height=0.005), False),
        (ModuleType.from_tilts(TILTS, name="flat0", height=0.0), True),
    ],
    ids=["inertia-1e-5", "height-0.005", "height-0"],
)
@pytest.mark.parametrize("cells", [[(0, 0)], L3], ids=["one", "L3"])
def test_urdf_links_are_physical_and_keep_the_structures_totals(module, flat, cells):
    """A small or flat module inertia used to leave base_link with negative principal moments
    (or A + B < C): MuJoCo refused the file. Now every link compiles and the links together
    have the structure's mass, COM and inertia (a flat type's thickened by at most 1e-7 of its
    largest moment)."""
    s = mq.Structure(cells, module=module)
    assert physical(base_inertial(s)[2])
    mass, com, J = urdf_totals(s)
    assert mass == pytest.approx(s.mass, rel=1e-12)
    np.testing.assert_allclose(com, 0.0, atol=1e-12)
    scale = np.abs(s.inertia).max()
    assert np.abs(J - s.inertia).max() <= (2e-7 if flat else 1e-12) * scale


def test_flat_modules_load_in_every_model_for_every_shape_of_four():
    """Height 0 puts every structure on the triangle boundary: the model, its MJCF text and the
    URDF used to fail by round-off for some shapes; now each compiles for all 19 of 4 cells."""
    from modquad_gym.sim.export import mjcf_text, urdf_spec
    from modquad_gym.sim.model import build_model

    flat = ModuleType.from_tilts(TILTS, name="flat0", height=0.0)
    shapes = next(itertools.islice(structure_levels(4), 3, None))
    assert len(shapes) == 19
    for key in shapes:
        s = mq.Structure(key, module=flat)
        model = build_model(s).model
        inertia = np.sort(model.body_inertia[1])
        np.testing.assert_allclose(inertia, np.linalg.eigvalsh(s.inertia), rtol=1e-12)
        mujoco.MjModel.from_xml_string(mjcf_text(s))
        urdf_spec(export_text(s, "urdf")).compile()


@pytest.mark.parametrize(
    "s",
    [mq.Structure([(0, 0), (1, 0)], module=HEXA),
     mq.Structure([(0, 0), (1, 0)], modules=[TRI, mq.TModule()]),
     mq.Structure(L3, modules=[mq.TModule(), HEXA, TRI])],
    ids=["hexa-pair", "tri-and-T", "hexa-tri-T"],
)  # fmt: skip
def test_exports_handle_any_rotor_count_column_by_column(s):
    """Types of 3 and 6 rotors: the JSON used to give module k // 4 and the URDF failed in
    zip(); now rotor k of either is column k of A, owned by its real module."""
    A = s.configuration_matrix()
    owner = np.repeat(np.arange(s.n_modules), [m.n_rotors for m in s.modules])
    d = json.loads(export_text(s, "json"))
    assert len(d["rotors"]) == A.shape[1]
    for k, r in enumerate(d["rotors"]):
        assert r["module"] == owner[k]
        p, u = np.array(r["position"]), np.array(r["direction"])
        column = np.r_[u, np.cross(p, u) + r["spin"] * r["c_tau"] * u]
        np.testing.assert_allclose(column, A[:, k], atol=1e-15)
        module = s.modules[r["module"]]
        local = p - np.array(d["modules"][r["module"]]["centre"])
        assert any(np.allclose(local, q, atol=1e-15) for q in module.positions)
    yourdfpy = pytest.importorskip("yourdfpy")
    robot = yourdfpy.URDF.load(io.StringIO(export_text(s, "urdf")), load_meshes=False)
    rotors = [name for name in robot.link_map if name.startswith("rotor")]
    assert len(rotors) == A.shape[1]
    for k in range(A.shape[1]):
        T = robot.get_transform(f"rotor{k}", "base_link")
        spin = -robot.joint_map[f"rotor{k}_joint"].axis[2]
        column = np.r_[T[:3, 2], np.cross(T[:3, 3], T[:3, 2]) + spin * s.rotor_c_tau[k] * T[:3, 2]]
        np.testing.assert_allclose(column, A[:, k], atol=1e-12)
    mass, com, J = urdf_totals(s)
    assert mass == pytest.approx(s.mass, rel=1e-12)
    np.testing.assert_allclose(J, s.inertia, atol=1e-12 * np.abs(s.inertia).max())


UNSIMULABLE = [
    ("pointmass", np.zeros((3, 3))),  # principal moments 0: accepted by ModuleType
    ("rod", np.diag([0.0, 1e-3, 1e-3])),
    ("roundoff", np.diag([1e-3, 1e-3, 2e-3 + 1e-18])),  # A + B < C by round-off
]


@pytest.mark.parametrize("name, J", UNSIMULABLE, ids=[n for n, _ in UNSIMULABLE])
def test_a_type_mujoco_cannot_compile_is_refused_before_any_work(name, J, tmp_path):
    from modquad_gym.sim.export import save_structure
    from modquad_gym.sim.fault_flight import fly_with_failure
    from modquad_gym.sim.model import build_model
    from modquad_gym.sim.validate import validate

    module = ModuleType.from_tilts(TILTS, name=name, inertia=J)
    assert mq.exhaustive_search([[0, 0, 1.0, 0, 0, 0]], n_max=2, modules=[module]).structure
    s = mq.Structure(L3, module=module)
    task = [[0, 0, 1.0, 0, 0, 0]]
    for door in (lambda: export_text(s, "mjcf"), lambda: export_text(s, "urdf"),
                 lambda: build_model(s), lambda: validate(s, task, out_dir=tmp_path / "v"),
                 lambda: fly_with_failure(s, task, "rotor"),
                 lambda: save_structure(s, tmp_path / "s.urdf")):  # fmt: skip
        with pytest.raises(ValueError) as info:
            door()
        text = str(info.value)
        assert text.startswith(f"module type {name!r}: inertia") and "\n" not in text, text
    assert not (tmp_path / "v").exists() and not (tmp_path / "s.urdf").exists()
    assert json.loads(export_text(s, "json"))["n_modules"] == 3  # JSON needs no simulator


@pytest.mark.parametrize("command", ["export", "validate"])
def test_the_command_line_refuses_such_a_type_with_exit_2(command, tmp_path, monkeypatch, capsys):
    from modquad_gym.cli import main

    point = ModuleType.from_tilts(TILTS, name="flat", inertia=np.zeros((3, 3)))
    monkeypatch.setitem(STOCK_TYPES, "flat", point)  # what --modules flat finds
    task = tmp_path / "t.json"
    task.write_text(json.dumps({"wrenches": [[0, 0, 1.0, 0, 0, 0]]}))
    out = tmp_path / ("s.xml" if command == "export" else "v")
    argv = {"export": ["export", "--cells", "[[0,0]]", "--modules", "flat", "--out", str(out)],
            "validate": ["validate", "--task", str(task), "--modules", "flat", "--out",
                         str(out)]}[command]  # fmt: skip
    assert main(argv) == 2
    err = capsys.readouterr().err.strip()
    assert re.fullmatch(r"modquad: error: --modules: module type 'flat': inertia .*", err), err
    assert not out.exists()


def test_the_mjcf_page_says_what_the_file_holds():
    """docs/export.md said "one box per module with its mass"; the boxes are massless and the
    body's explicit inertial holds the mass and inertia."""
    from modquad_gym.sim.export import mjcf_text

    s = mq.Structure(L3)
    body = ET.fromstring(mjcf_text(s).split("\n", 1)[1]).find(".//body[@name='structure']")
    assert float(body.find("inertial").get("mass")) == pytest.approx(s.mass, rel=1e-6)
    boxes = [g for g in body.findall("geom") if g.get("name", "").startswith("module")]
    assert len(boxes) == 3 and all(float(g.get("mass")) == 0 for g in boxes)
    page = (Path(__file__).resolve().parents[1] / "docs" / "export.md").read_text()
    mjcf = " ".join(page.split("## MJCF (MuJoCo)")[1].split("```")[0].split())
    assert "one massless box per module" in mjcf and "with its mass" not in mjcf
    assert "explicit `<inertial>` holds the structure's mass" in mjcf


def test_the_heaviest_widest_modules_write_finite_numbers():
    """Module masses near 1e307 kg overflowed a structure's inertia (the JSON would hold NaN);
    masses are now at most MAX_MASS, where the longest line of the widest modules stays
    finite in every writer."""
    from modquad_gym.geometry.cells import MAX_MODULES
    from modquad_gym.geometry.module import MAX_MASS
    from modquad_gym.proofcheck_format import MAX_LENGTH

    with pytest.raises(ValueError, match=r"^mass must be <= 1e\+12, got 1e\+307$"):
        mq.TModule(side=MAX_LENGTH, mass=1e307)
    module = mq.TModule(side=MAX_LENGTH, mass=MAX_MASS)
    s = mq.Structure([(i, 0) for i in range(MAX_MODULES)], module=module)
    assert np.isfinite(s.mass) and np.all(np.isfinite(s.inertia))
    data = json.loads(export_text(s, "json"))
    assert np.all(np.isfinite(data["inertia"]))
