"""Dynamic tasks: mass and inertia, trajectories, Newton-Euler wrenches against MuJoCo's inverse
dynamics, motions, task files and their one-line errors."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

import modquad_gym as mq
from modquad_gym import dynamics as dy
from modquad_gym.dynamics import quaternions as quat
from modquad_gym.geometry.inertia import inertia_vectors, to_tensor, to_vector
from modquad_gym.geometry.module import STOCK_TYPES, box_inertia, check_inertia
from modquad_gym.tasks import TaskFileError, load_task

mujoco = pytest.importorskip("mujoco")

MIXED = [STOCK_TYPES["t45"], mq.ModuleType.from_tilts((0.0,) * 4, name="heavy", mass=0.5)]


def _f(x) -> str:
    return " ".join(repr(float(v)) for v in np.ravel(x))


def _module_bodies_xml(structure: mq.Structure, payload: dy.Payload | None = None) -> str:
    """A free body made of one welded child body per module (its mass and inertia at its
    centre) and a point-mass payload: MuJoCo composes them, independently of our sums."""
    bodies = []
    for c, m in zip(structure.module_centres, structure.modules):
        J = m.inertia
        full = _f([J[0, 0], J[1, 1], J[2, 2], J[0, 1], J[0, 2], J[1, 2]])
        bodies.append(
            f'<body pos="{_f(c)}"><inertial pos="0 0 0" mass="{m.mass!r}" '
            f'fullinertia="{full}"/></body>'
        )
    if payload is not None:
        bodies.append(
            f'<body pos="{_f(payload.offset)}"><inertial pos="0 0 0" mass="{payload.mass!r}" '
            'diaginertia="0 0 0"/></body>'
        )
    return (
        f'<mujoco><option gravity="0 0 {-mq.GRAVITY!r}"/><worldbody><body name="s">'
        f"<freejoint/>{''.join(bodies)}</body></worldbody></mujoco>"
    )


def _mj_inverse(model, trajectory: dy.Trajectory) -> np.ndarray:
    """MuJoCo's inverse dynamics of the free body along the trajectory, as {S} wrenches."""
    data = mujoco.MjData(model)
    out = np.zeros((trajectory.n_samples, 6))
    for k in range(trajectory.n_samples):
        data.qpos[:3] = trajectory.position[k]
        data.qpos[3:7] = trajectory.quaternion[k]
        data.qvel[:3] = trajectory.velocity[k]
        data.qvel[3:6] = trajectory.angular_velocity[k]
        data.qacc[:3] = trajectory.acceleration[k]
        data.qacc[3:6] = trajectory.angular_acceleration[k]
        mujoco.mj_inverse(model, data)
        R = data.xmat[1].reshape(3, 3)
        out[k] = np.concatenate([R.T @ data.qfrc_inverse[:3], data.qfrc_inverse[3:6]])
    return out


def _tumbling(seed: int = 0, k: int = 121) -> dy.Trajectory:
    """A trajectory that moves and turns about every axis (derivatives by splines)."""
    rng = np.random.default_rng(seed)
    t = np.linspace(0.0, 3.0, k)
    a, f = rng.uniform(0.2, 1.0, (2, 6))
    pos = np.c_[a[0] * np.sin(f[0] * t), a[1] * np.cos(f[1] * t), a[2] * t**2]
    roll, pitch, yaw = (a[3 + i] * np.sin(f[3 + i] * t + i) for i in range(3))
    q = quat.multiply(
        quat.about_z(yaw),
        quat.multiply(
            np.c_[np.cos(pitch / 2), 0 * t, np.sin(pitch / 2), 0 * t],
            np.c_[np.cos(roll / 2), np.sin(roll / 2), 0 * t, 0 * t],
        ),
    )
    return dy.Trajectory(t, pos, q)


# --- mass and inertia -------------------------------------------------------------------------
def test_module_inertia_is_muJoCo_box():
    m = mq.TModule()
    xml = (
        '<mujoco><worldbody><body><freejoint/><geom type="box" size="0.2 0.2 0.025" '
        f'mass="{m.mass!r}"/></body></worldbody></mujoco>'
    )
    model = mujoco.MjModel.from_xml_string(xml)
    np.testing.assert_allclose(np.diag(m.inertia), model.body_inertia[1], rtol=1e-12)
    np.testing.assert_allclose(m.inertia, np.diag([4.0625e-3, 4.0625e-3, 8.0e-3]), rtol=1e-12)


@pytest.mark.parametrize("cells", [[(0, 0)], [(0, 0), (1, 0), (1, 1), (3, 1), (2, 1)]])
@pytest.mark.parametrize("mixed", [False, True])
def test_structure_inertia_matches_mujoco_composition(cells, mixed):
    mods = [MIXED[i % 2] for i in range(len(cells))] if mixed else None
    s = mq.Structure(cells, modules=mods) if mixed else mq.Structure(cells)
    model = mujoco.MjModel.from_xml_string(_module_bodies_xml(s))
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    M = np.zeros((6, 6))
    mujoco.mj_fullM(model, data, M)
    assert M[0, 0] == pytest.approx(s.mass, rel=1e-12)
    np.testing.assert_allclose(M[:3, 3:], 0.0, atol=1e-12)  # the COM is the {S} origin
    np.testing.assert_allclose(M[3:, 3:], s.inertia, rtol=1e-12, atol=1e-15)
    cells_arr = np.asarray(s.cells)[None]
    types = s.type_indices[None] if mixed else np.zeros((1, len(cells)), int)
    palette = list(s.palette)
    mass, j = inertia_vectors(cells_arr, types, palette)
    assert mass[0] == pytest.approx(s.mass)
    np.testing.assert_allclose(to_tensor(j[0]), s.inertia, atol=1e-15)
    np.testing.assert_allclose(to_vector(s.inertia), j[0], atol=1e-15)


def test_inertia_checks_and_digest():
    assert mq.TModule().digest == "1de7bbc12a969bb5"  # a box inertia adds nothing to it
    J = np.diag([0.01, 0.02, 0.025])
    custom = mq.ModuleType.from_tilts((0.5, -0.5, 0.5, -0.5), inertia=J)
    assert custom.digest != mq.ModuleType.from_tilts((0.5, -0.5, 0.5, -0.5)).digest
    np.testing.assert_array_equal(custom.inertia, J)
    same_box = mq.ModuleType.from_tilts((0.5,) * 4, inertia=box_inertia(0.3, 0.4, 0.4, 0.05))
    assert same_box.digest == mq.ModuleType.from_tilts((0.5,) * 4).digest
    with pytest.raises(ValueError, match="symmetric"):
        check_inertia([[1, 0.5, 0], [0, 1, 0], [0, 0, 1]])
    with pytest.raises(ValueError, match="principal moments"):
        check_inertia(np.diag([1.0, 1.0, 3.0]))
    with pytest.raises(ValueError, match="inertia must be a finite"):
        mq.ModuleType.from_tilts((0.0,) * 4, inertia=np.eye(2))
    with pytest.raises(ValueError, match="height"):
        mq.ModuleType.from_tilts((0.0,) * 4, height=-1.0)


def test_sim_model_carries_the_structure_inertia():
    from modquad_gym.sim import build_model
    from modquad_gym.sim.hover.linearization import body_inertia

    s = mq.Structure([(0, 0), (1, 0), (1, 1)], modules=[MIXED[0], MIXED[1], MIXED[0]])
    sim = build_model(s, 2.0)
    assert sim.mass == pytest.approx(s.mass, rel=1e-14)
    np.testing.assert_allclose(body_inertia(sim), s.inertia, rtol=1e-12, atol=1e-15)


# --- required wrenches = MuJoCo's inverse dynamics ----------------------------------------------
@pytest.mark.parametrize(
    "cells, mixed, payload",
    [
        ([(0, 0)], False, None),
        ([(0, 0), (1, 0), (1, 1), (2, 1)], False, dy.Payload(0.5, (0.1, -0.05, -0.2))),
        ([(0, 0), (0, 1), (1, 1), (-1, 1), (0, 2)], True, dy.Payload(0.8, (0.0, 0.3, 0.1))),
    ],
)
def test_required_wrenches_equal_mj_inverse(cells, mixed, payload):
    mods = [MIXED[i % 2] for i in range(len(cells))] if mixed else None
    s = mq.Structure(cells, modules=mods) if mixed else mq.Structure(cells)
    traj = _tumbling(seed=len(cells))
    W = mq.required_wrenches(s, traj, payload)
    ref = _mj_inverse(mujoco.MjModel.from_xml_string(_module_bodies_xml(s, payload)), traj)
    rel = np.abs(W - ref).max() / np.abs(ref).max()
    assert rel <= 1e-9
    # the same through the simulation model of modquad_gym.sim (no payload there)
    if payload is None:
        from modquad_gym.sim import build_model

        ref2 = _mj_inverse(build_model(s, 2.0).model, traj)
        assert np.abs(W - ref2).max() <= 1e-9 * np.abs(ref2).max()


def test_linear_wrench_model_is_exact():
    s = mq.Structure([(0, 0), (1, 0), (1, 1)], modules=[MIXED[1], MIXED[0], MIXED[0]])
    traj = _tumbling(seed=3, k=61)
    pay = dy.Payload(0.4, (0.1, 0.0, -0.1))
    exerted = np.random.default_rng(0).normal(size=(61, 6))
    task = dy.DynamicTask(traj, pay, exerted, f_max=3.0)
    assert task.wrench_model.uses_inertia
    np.testing.assert_allclose(
        task.rotor_wrenches(s), mq.required_wrenches(s, traj, pay) + exerted, atol=1e-12
    )
    level = dy.circle(speed=2.0)
    assert not level.wrench_model.uses_inertia
    with pytest.raises(ValueError, match="inertia"):
        task.wrench_model.at(s.mass)


def test_hover_wrench_is_the_weight():
    s = mq.Structure([(0, 0), (1, 0)])
    task = dy.hover(payload=dy.Payload(0.5, (0.1, 0.0, 0.0)))
    W = task.rotor_wrenches(s)
    g = mq.GRAVITY
    np.testing.assert_allclose(W[:, 2], (s.mass + 0.5) * g)
    np.testing.assert_allclose(W[:, 4], -0.1 * 0.5 * g)  # r x f: (0.1, 0, 0) x (0, 0, m g)
    np.testing.assert_allclose(W[:, [0, 1, 3, 5]], 0.0, atol=1e-15)


# --- trajectories -------------------------------------------------------------------------------
def test_spline_derivatives_are_accurate():
    t = np.linspace(0, 2 * math.pi, 200)
    pos = np.c_[np.cos(t), np.sin(t), 0 * t]
    traj = mq.Trajectory(t, pos)
    np.testing.assert_allclose(traj.acceleration, -pos, atol=1e-5)
    np.testing.assert_allclose(traj.velocity, np.c_[-np.sin(t), np.cos(t), 0 * t], atol=1e-6)
    assert traj.derivative_error["acceleration"] < dy.trajectory.DEFAULT_ACCURACY
    yaw = 0.3 * t**2
    turning = mq.Trajectory(t, pos, quat.about_z(yaw))
    np.testing.assert_allclose(turning.angular_velocity[:, 2], 0.6 * t, atol=1e-5)
    np.testing.assert_allclose(turning.angular_acceleration[:, 2], 0.6, atol=1e-3)
    np.testing.assert_allclose(turning.angular_velocity[:, :2], 0.0, atol=1e-9)


@pytest.mark.parametrize("motion", ["line", "circle", "figure-eight", "push"])
def test_motions_closed_forms_agree_with_splines(motion):
    task = dy.MOTIONS[motion]()
    traj = task.trajectory
    again = mq.Trajectory(traj.t, traj.position)
    np.testing.assert_allclose(again.velocity, traj.velocity, atol=2e-4)
    np.testing.assert_allclose(again.acceleration, traj.acceleration, atol=5e-3)
    np.testing.assert_allclose(traj.velocity[[0, -1]], 0.0, atol=1e-12)  # rest to rest


def test_motion_parameters_hold():
    line = dy.line(distance=2.0, max_acceleration=1.5, rate=1000)
    assert np.abs(line.trajectory.acceleration).max() == pytest.approx(1.5, rel=1e-5)
    assert line.trajectory.position[-1, 0] == pytest.approx(2.0)
    c = dy.circle(radius=1.5, speed=2.0)
    v = np.linalg.norm(c.trajectory.velocity, axis=1)
    a = np.linalg.norm(c.trajectory.acceleration, axis=1)
    assert v.max() == pytest.approx(2.0)
    assert a[np.argmax(v)] == pytest.approx(2.0**2 / 1.5, rel=1e-9)
    turning = dy.circle(heading="tangent")
    assert turning.wrench_model.uses_inertia
    p = dy.push(force=3.0)
    assert p.exerted[:, 0].max() == pytest.approx(3.0)
    assert np.all(p.exerted[:, 1:] == 0)
    fig = dy.figure_eight(size=1.0, speed=1.2)
    assert np.linalg.norm(fig.trajectory.velocity, axis=1).max() == pytest.approx(1.2, rel=1e-4)


@pytest.mark.parametrize(
    "kwargs, message",
    [
        ({"t": [0.0, 1.0, 0.5], "position": np.zeros((3, 3))}, r"^t: not increasing at sample 3"),
        ({"t": [0.0, math.nan], "position": np.zeros((2, 3))}, r"^t: sample 2 is nan"),
        (
            {"t": [0, 1, 2], "position": [[0, 0, 0], [0, math.nan, 0], [0, 0, 0]]},
            r"^position: sample 2 holds nan",
        ),
        (
            {"t": [0, 1], "position": np.zeros((2, 3)), "quaternion": [[1, 0, 0, 0], [1, 1, 0, 0]]},
            r"^quaternion: sample 2 has norm 1.414",
        ),
        ({"t": [0, 1], "position": np.zeros((3, 3))}, r"^position must have shape \(2, 3\)"),
        (
            {"t": np.arange(1_000_000.0), "position": np.zeros((1, 3))},
            r"^t: 1,000,000 samples, more than the 100,000 allowed",
        ),
        (
            {"t": [0, 1], "position": np.zeros((2, 3)), "velocity": np.zeros((2, 2))},
            r"^velocity must have shape",
        ),
    ],
)
def test_trajectory_errors_name_the_field(kwargs, message):
    with pytest.raises(ValueError, match=message) as info:
        mq.Trajectory(**kwargs)
    assert "\n" not in str(info.value)


def test_coarse_sampling_is_refused():
    t = np.linspace(0, 2 * math.pi, 12)
    with pytest.raises(ValueError, match=r"^acceleration: sampling too coarse"):
        mq.Trajectory(t, np.c_[np.cos(3 * t), np.sin(3 * t), 0 * t])
    # giving the acceleration skips the estimate
    acc = -9 * np.c_[np.cos(3 * t), np.sin(3 * t), 0 * t]
    vel = 3 * np.c_[-np.sin(3 * t), np.cos(3 * t), 0 * t]
    mq.Trajectory(t, np.c_[np.cos(3 * t), np.sin(3 * t), 0 * t], velocity=vel, acceleration=acc)


def test_smoothing_splines_tame_noise():
    rng = np.random.default_rng(0)
    t = np.linspace(0, 4, 401)
    truth = np.c_[np.sin(t), np.cos(t), 0.1 * t]
    noisy = truth + rng.normal(scale=1e-4, size=truth.shape)
    smooth = mq.Trajectory(t, noisy, smoothing=1e-4, accuracy=1.0)
    inner = slice(40, -40)
    err = np.abs(smooth.acceleration[inner] + np.c_[np.sin(t), np.cos(t), 0 * t][inner]).max()
    assert err < 0.1


def test_at_interpolates_the_reference():
    task = dy.circle(speed=1.5)
    traj = task.trajectory
    mid = (traj.t[:-1] + traj.t[1:]) / 2
    ref = traj.at(mid[::7])
    assert ref["position"].shape == (len(mid[::7]), 3)
    np.testing.assert_allclose(traj.at(traj.t)["acceleration"], traj.acceleration, atol=1e-12)


# --- task files ---------------------------------------------------------------------------------
def test_dynamic_task_file_round_trip(tmp_path):
    task = dy.figure_eight(payload=dy.Payload(0.3, (0.0, 0.0, -0.1)), name="eight")
    path = task.save(tmp_path / "eight.json")
    back = load_task(path)
    assert isinstance(back, dy.DynamicTask) and back.name == "eight"
    s = mq.Structure([(0, 0), (1, 0), (0, 1), (1, 1)])
    np.testing.assert_array_equal(back.rotor_wrenches(s), task.rotor_wrenches(s))
    minimal = tmp_path / "minimal.json"
    t = np.linspace(0, 2, 201)
    minimal.write_text(
        json.dumps({"trajectory": {"t": t.tolist(), "position": np.c_[t, 0 * t, 0 * t].tolist()}})
    )
    m = load_task(minimal)
    assert m.f_max == 1.0 and m.payload is None and m.name == "minimal"
    np.testing.assert_allclose(m.trajectory.velocity[:, 0], 1.0, atol=1e-9)


@pytest.mark.parametrize(
    "data, message",
    [
        (
            {"trajectory": {"t": [0, 1], "position": [[0, 0, 0]] * 2}, "speed": 1},
            r"speed: unknown key in a dynamic task",
        ),
        (
            {"trajectory": {"t": [0, 1], "position": [[0, 0, 0]] * 2, "jerk": []}},
            r"trajectory\.jerk: unknown key",
        ),
        (
            {"trajectory": {"t": [1, 0], "position": [[0, 0, 0]] * 2}},
            r"trajectory\.t: not increasing at sample 2",
        ),
        ({"trajectory": {"position": [[0, 0, 0]] * 2}}, r"trajectory\.t: missing"),
        (
            {"trajectory": {"t": [0, 1], "position": [[0, 0, 0]] * 2}, "payload": {"mass": -1}},
            r"payload\.mass must be >= 0",
        ),
        (
            {
                "trajectory": {"t": [0, 1], "position": [[0, 0, 0]] * 2},
                "payload": {"offset": [0, 0, 0]},
            },
            r"payload\.mass: missing",
        ),
        (
            {"trajectory": {"t": [0, 1], "position": [[0, 0, 0]] * 2}, "exerted": [[0] * 6]},
            r"exerted must have shape \(2, 6\)",
        ),
        (
            {"trajectory": {"t": [0, 1], "position": [[0, 0, 0]] * 2}, "f_max": -2},
            r": f_max must be positive, got -2$",
        ),
    ],
)
def test_bad_dynamic_task_files(tmp_path, data, message):
    path = tmp_path / "bad.json"
    path.write_text(json.dumps(data))
    with pytest.raises(TaskFileError, match=message) as info:
        load_task(path)
    assert str(path) in str(info.value) and "\n" not in str(info.value)


def test_lift_check_names_the_field():
    t45 = [STOCK_TYPES["t45"]]
    assert dy.check_liftable(dy.hover(payload=1.0), t45) >= 1
    heavy = dy.hover(payload=1000.0)
    with pytest.raises(ValueError, match=r"^payload\.mass: 1000 kg is more than any structure"):
        dy.check_liftable(heavy, t45)
    weak = dy.hover(f_max=1.0)  # 4 x 1 N at 45 degrees lift 2.83 N < 2.94 N of one module
    with pytest.raises(ValueError, match=r"^f_max: 1 N per rotor cannot fly"):
        dy.check_liftable(weak, t45)
    # the bound is exact for a flat module hovering: n modules lift n (4 f_max - m g)
    flat = [STOCK_TYPES["flat"]]
    task = dy.hover(payload=2.0)
    n = dy.check_liftable(task, flat)
    assert n == math.ceil(2.0 * mq.GRAVITY / (4 * 2.0 - 0.3 * mq.GRAVITY))
