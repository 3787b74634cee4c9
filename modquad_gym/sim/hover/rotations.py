"""Small rotation helpers for the hover loop: skew matrices, cross products, angle and log map.

Written out rather than taken from ``scipy.spatial.transform.Rotation``: they run at every
control step, where one scipy call costs about 75-90 us against about 10 us here (a 3 x 3
matrix, no orthonormalisation); tests/test_rotations.py checks them against scipy.
"""

from __future__ import annotations

import math

import numpy as np


def vee_skew(M: np.ndarray) -> np.ndarray:
    """The vector of the skew-symmetric part ``(M - M^T) / 2`` of a 3x3 matrix (the inverse of
    :func:`skew`); for a rotation by angle a about axis n, ``sin(a) n``."""
    return 0.5 * np.array([M[2, 1] - M[1, 2], M[0, 2] - M[2, 0], M[1, 0] - M[0, 1]])


def skew(a: np.ndarray) -> np.ndarray:
    """[a]x, so that [a]x b = a x b."""
    return np.array([[0.0, -a[2], a[1]], [a[2], 0.0, -a[0]], [-a[1], a[0], 0.0]])


def cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """a x b for 3-vectors (np.cross is slow for one pair inside the control loop)."""
    return np.array(
        [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]
    )


def rotation_angle(R: np.ndarray) -> float:
    """Angle (rad) of the rotation R, robust near 0 and pi."""
    s = np.linalg.norm(vee_skew(R))  # sin(angle) times the axis
    c = 0.5 * (np.trace(R) - 1.0)
    return float(math.atan2(s, c))


def rotation_vector(R: np.ndarray) -> np.ndarray:
    """The rotation vector (axis times angle, the log map) of R; exact below pi."""
    s = vee_skew(R)  # sin(angle) times the axis
    sn = float(np.linalg.norm(s))
    if sn < 1e-12:
        return s
    return s * (math.atan2(sn, 0.5 * (np.trace(R) - 1.0)) / sn)
