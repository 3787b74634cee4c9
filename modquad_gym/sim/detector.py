"""A failure detector on what the vehicle senses: a momentum observer of the unexplained wrench.

The vehicle measures its velocity v (world frame, from its state estimator) and its body rate
omega (gyro), both with Gaussian noise (:class:`SensorNoise`), and knows what it commands: the
thrusts u, hence the wrench A u, and the load it holds. A generalized-momentum observer (De Luca
and Mattone's residual, standard in robot fault detection) turns these into the wrench the model
does not explain, low-pass filtered with bandwidth K (1/s):

    p = [m v ; J omega],   r_k = K (p_k - p_0 - sum_i (predicted_i + r_i) dt),

predicted = [R A_f u + load + m g ; A_t u + load torque (body) - omega x J omega]. Intact, r is
sensor noise; when rotors S stop, r tends to the thrust they no longer give, -A_S u_S (body
frame). The detector declares a failure when the residual exceeds both ``threshold`` (force and
torque scaled by one rotor's full thrust and its torque at the longest arm) and ``z`` times its
noise (K times the momentum's measurement noise, per component: a heavier structure's force
residual is noisier) for ``persistence`` control steps in a row, and names the failure set S
whose missing wrench -A_S u_S points most nearly along the residual (u the commanded thrusts;
the direction, since the filtered residual is still rising). The allocator then switches to A
without S (:class:`~modquad_gym.sim.failure.Failure`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class SensorNoise:
    """Standard deviations of the measured velocity (m/s) and body rate (rad/s) per control
    step, and the seed of their noise."""

    velocity: float = 0.001
    rate: float = 0.002
    seed: int = 0


@dataclass(frozen=True)
class DetectorConfig:
    """The observer's bandwidth (1/s); the residual must exceed ``threshold`` (a fraction of
    one rotor's full thrust, or of its torque at the longest arm) and ``z`` times its own noise
    (in some component) for ``persistence`` control steps in a row."""

    bandwidth: float = 60.0
    threshold: float = 0.1
    z: float = 4.0
    persistence: int = 6


class FailureDetector:
    """The residual observer and its decision for one flight (one control step per
    :meth:`update`).

    Args:
        A: the (6, m) configuration matrix (body frame, about the origin of {S}).
        mass, J: the body's mass (kg) and inertia (3, 3) about the origin of {S}.
        f_max: per-rotor thrust limit.
        candidates: the failure sets it may name (column sets of A).
        dt: the control period (s).
        config, noise: :class:`DetectorConfig`, :class:`SensorNoise`.
        com: the body's centre of mass in {S} (3,) when a payload moves it off the origin
            (the momenta are the COM's; velocities are measured at the origin).
    """

    def __init__(self, A, mass, J, f_max, candidates, dt, config=None, noise=None,
                 com=None) -> None:  # fmt: skip
        self.A = np.asarray(A, dtype=float)
        self.mass, self.dt = float(mass), float(dt)
        self.com = np.zeros(3) if com is None else np.asarray(com, dtype=float)
        c = self.com  # the inertia about the COM (parallel axis back from the origin)
        self.J = np.asarray(J, dtype=float) - self.mass * (c @ c * np.eye(3) - np.outer(c, c))
        self.candidates = [np.asarray(S, dtype=int) for S in candidates]
        self.config = config or DetectorConfig()
        self.noise = noise or SensorNoise()
        self.rng = np.random.default_rng(self.noise.seed)
        self.scale = np.array([f_max] * 3 + [f_max * _arm(self.A)] * 3)  # one rotor's
        # the residual's noise per component: K times the momentum's measurement noise
        K = self.config.bandwidth
        force = np.full(3, self.mass * self.noise.velocity)
        self.sigma = K * np.concatenate([force, np.linalg.norm(self.J, axis=1) * self.noise.rate])
        self.r = np.zeros(6)
        self._integral = np.zeros(6)
        self._p0: np.ndarray | None = None
        self._over = 0
        self.detected: tuple[float, np.ndarray] | None = None  # (time, failure set)
        self.peak = 0.0  # the largest scaled residual seen before a detection

    def sense(self, v: np.ndarray, omega: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The noisy measurements of the true velocity and body rate."""
        return (v + self.rng.normal(0.0, self.noise.velocity, 3),
                omega + self.rng.normal(0.0, self.noise.rate, 3))  # fmt: skip

    def update(self, t, R, v, omega, u, load_world, gravity) -> tuple[float, np.ndarray] | None:
        """One control step: true state (R body-to-world, v, omega), commanded thrusts u, the
        load (6,) applied in the world frame and the gravity vector; returns the detection
        (time, failure set) once made."""
        if self.detected is not None:
            return self.detected
        v_m, w_m = self.sense(v, omega)
        v_com = v_m + R @ np.cross(w_m, self.com)
        p = np.concatenate([self.mass * v_com, self.J @ w_m])
        if self._p0 is None:
            self._p0 = p
        wrench = self.A @ u
        force = R @ wrench[:3] + load_world[:3] + self.mass * gravity
        about_com = wrench[3:] - np.cross(self.com, wrench[:3])
        torque = about_com + R.T @ load_world[3:] - np.cross(w_m, self.J @ w_m)
        predicted = np.concatenate([force, torque])
        self.r = self.config.bandwidth * (p - self._p0 - self._integral)
        self._integral += (predicted + self.r) * self.dt
        body = np.concatenate([R.T @ self.r[:3], self.r[3:]])
        size = float(np.abs(body / self.scale).max())
        z = float(np.abs(body / np.maximum(self.sigma, 1e-12)).max())
        over = size > self.config.threshold and z > self.config.z
        self._over = self._over + 1 if over else 0
        if self._over < self.config.persistence:
            self.peak = max(self.peak, size)
            return None
        self.detected = (t, self._isolate(body, u))
        return self.detected

    def _isolate(self, residual: np.ndarray, u: np.ndarray) -> np.ndarray:
        """The failure set whose missing wrench d_S = -A_S u_S best explains the residual up to
        a positive factor (the observer's filter has not reached the full step yet): the least
        angle between the scaled residual and the scaled d_S."""
        r = residual / self.scale
        best, score = self.candidates[0], -np.inf
        for S in self.candidates:
            d = -(self.A[:, S] @ u[S]) / self.scale
            norm = float(np.linalg.norm(d))
            cos = float(r @ d) / (norm * float(np.linalg.norm(r))) if norm > 0 else -np.inf
            if cos > score:
                best, score = S, cos
        return best


def _arm(A: np.ndarray) -> float:
    """A typical lever arm (m): the largest torque per unit thrust of a column."""
    return float(np.linalg.norm(A[3:], axis=0).max()) or 1.0


def make_detector(detector, plant, kind: str, dt: float, com=None) -> FailureDetector | None:
    """The :class:`FailureDetector` of a flight of ``plant`` (what the controller knows: A,
    mass, inertia, f_max) for ``detector`` (None: none; a :class:`DetectorConfig`, or a
    (config, :class:`SensorNoise`) pair); it may name any failure of kind ``kind``; ``com``
    the body's centre of mass in {S} (a payload's offset)."""
    if detector is None:
        return None
    from modquad_gym.oracle.faults import FAULTS, failure_sets

    config, noise = detector if isinstance(detector, tuple) else (detector, None)
    m = plant.A.shape[1]
    sets = failure_sets(m, kind if kind in FAULTS else "rotor")
    return FailureDetector(plant.A, plant.mass, plant.J, plant.f_max, sets, dt,
                           config if isinstance(config, DetectorConfig) else None,
                           noise if isinstance(noise, SensorNoise) else None, com)  # fmt: skip
