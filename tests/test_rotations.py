"""Rotation helpers against references: the export's quaternion, matrix and URDF roll-pitch-yaw
(scipy's ``Rotation``) against the closed forms they replaced, and the hover loop's hand-written
angle and log map (kept for speed) against scipy, near 0 and near a half turn too."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from modquad_gym.sim.export import _rpy, quaternion_matrix, rotor_quaternion
from modquad_gym.sim.hover.rotations import rotation_angle, rotation_vector


def closed_form_quaternion(d) -> np.ndarray:
    """The shortest arc e3 -> d as the export computed it before scipy: (1 + d_z, -d_y, d_x, 0)."""
    d = np.asarray(d, dtype=float) / np.linalg.norm(d)
    if d[2] < -1.0 + 1e-12:
        return np.array([0.0, 1.0, 0.0, 0.0])
    q = np.array([1.0 + d[2], -d[1], d[0], 0.0])
    return q / np.linalg.norm(q)


def closed_form_matrix(q) -> np.ndarray:
    w, x, y, z = q
    return np.array([
        [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
        [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
        [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
    ])  # fmt: skip


def closed_form_rpy(R) -> tuple[float, float, float]:
    pitch = math.asin(max(-1.0, min(1.0, -R[2, 0])))
    return math.atan2(R[2, 1], R[2, 2]), pitch, math.atan2(R[1, 0], R[0, 0])


def directions() -> np.ndarray:
    rng = np.random.default_rng(0)
    d = rng.normal(size=(200, 3))
    edges = [[0, 0, 1], [0, 0, -1], [1e-9, 0, -1], [0, 1e-7, -1], [1, 0, 0], [0, -1, 0],
             [1, 0, 1e-12], [0.5, 0.5, -0.7071]]  # fmt: skip
    d = np.vstack([d, edges])
    return d / np.linalg.norm(d, axis=1, keepdims=True)


def test_export_quaternions_matrices_and_rpy_match_the_closed_forms():
    for d in directions():
        q = rotor_quaternion(d)
        near_down = 1e-7 if d[2] < -0.999 else 1e-14  # 1 + d_z cancels in the closed form
        np.testing.assert_allclose(q, closed_form_quaternion(d), atol=near_down)
        R = quaternion_matrix(q)
        np.testing.assert_allclose(R, closed_form_matrix(q), atol=1e-14)
        np.testing.assert_allclose(R[:, 2], d, atol=near_down)
        if abs(R[2, 0]) < 1 - 1e-9:  # off gimbal lock, roll and yaw are unique
            np.testing.assert_allclose(_rpy(R), closed_form_rpy(R), atol=1e-12)
        # either way the angles rebuild the matrix: R = Rz(yaw) Ry(pitch) Rx(roll)
        np.testing.assert_allclose(Rotation.from_euler("xyz", _rpy(R)).as_matrix(), R, atol=1e-12)


def rotations() -> list[np.ndarray]:
    rng = np.random.default_rng(1)
    vectors = [rng.normal(size=3) for _ in range(200)]
    axis = np.array([1.0, 2.0, -0.5]) / np.linalg.norm([1.0, 2.0, -0.5])
    vectors += [axis * a for a in (0.0, 1e-14, 1e-9, 1e-4, math.pi - 1e-4, math.pi - 1e-9)]
    vectors = [v if np.linalg.norm(v) < math.pi else v / np.linalg.norm(v) * 3.0 for v in vectors]
    return [Rotation.from_rotvec(v).as_matrix() for v in vectors]


def test_hover_angle_and_log_map_match_scipy():
    for R in rotations():
        reference = Rotation.from_matrix(R)
        assert rotation_angle(R) == pytest.approx(reference.magnitude(), abs=1e-12)
        angle = reference.magnitude()
        tol = 1e-12 if angle < math.pi - 1e-3 else 1e-4  # the log map is ill-posed at pi
        np.testing.assert_allclose(rotation_vector(R), reference.as_rotvec(), atol=tol)
