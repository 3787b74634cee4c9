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

Two sets' missing wrenches can point almost the same way (noise then decides), so a decision is
checked: the observer restarts on the switch and the same test runs again. A right decision
leaves noise (the commands now match what the rotors give); a wrong one leaves the missing
thrust of the dead rotors still commanded, and the detector names the set not yet named that
best explains the residuals of all its decisions (:meth:`FailureDetector._isolate`), and the
allocator switches again.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from modquad_gym.core.validation import check_flag, check_int, check_real


@dataclass(frozen=True)
class SensorNoise:
    """Standard deviations of the measured velocity (m/s) and body rate (rad/s) per control
    step (finite, >= 0; 0: exact), and the seed of their noise (an integer >= 0). Anything
    else is a ValueError naming the field."""

    velocity: float = 0.001
    rate: float = 0.002
    seed: int = 0

    def __post_init__(self) -> None:
        for name in ("velocity", "rate"):
            value = check_real(getattr(self, name), f"SensorNoise.{name}", low=0.0)
            object.__setattr__(self, name, value)
        object.__setattr__(self, "seed", check_int(self.seed, "SensorNoise.seed", low=0))


@dataclass(frozen=True)
class DetectorConfig:
    """The observer's bandwidth (1/s); the residual must exceed ``threshold`` (a fraction of
    one rotor's full thrust, or of its torque at the longest arm) and ``z`` times its own noise
    (in some component) for ``persistence`` control steps in a row; with ``revise`` a decision
    the residual does not confirm is revised (:meth:`FailureDetector.update`; False: the first
    decision stands). Bandwidth, threshold and z are finite and > 0 (the bandwidth also at most
    one per control period, :class:`FailureDetector`), persistence an integer >= 1, revise a
    bool; anything else is a ValueError naming the field."""

    bandwidth: float = 60.0
    threshold: float = 0.1
    z: float = 4.0
    persistence: int = 6
    revise: bool = True

    def __post_init__(self) -> None:
        for name in ("bandwidth", "threshold", "z"):
            value = check_real(getattr(self, name), f"DetectorConfig.{name}", positive=True)
            object.__setattr__(self, name, value)
        persistence = check_int(self.persistence, "DetectorConfig.persistence", low=1)
        object.__setattr__(self, "persistence", persistence)
        object.__setattr__(self, "revise", check_flag(self.revise, "DetectorConfig.revise"))


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
        if self.config.bandwidth * self.dt > 1.0:  # past it the discrete residual overshoots
            raise ValueError(
                f"DetectorConfig.bandwidth must be at most 1 / control period = "
                f"{1.0 / self.dt:g} /s, got {self.config.bandwidth:g}"
            )
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
        self.decisions: list[tuple[float, np.ndarray]] = []  # (time, failure set) in order
        self._evidence: list[tuple[np.ndarray, np.ndarray]] = []  # (residual, u) per decision
        self.peak = 0.0  # the largest scaled residual seen before a detection

    def sense(self, v: np.ndarray, omega: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The noisy measurements of the true velocity and body rate."""
        return (v + self.rng.normal(0.0, self.noise.velocity, 3),
                omega + self.rng.normal(0.0, self.noise.rate, 3))  # fmt: skip

    def update(self, t, R, v, omega, u, load_world, gravity) -> tuple[float, np.ndarray] | None:
        """One control step: true state (R body-to-world, v, omega), commanded thrusts u, the
        load (6,) applied in the world frame and the gravity vector; returns a decision (time,
        failure set) at the step it is made, else None.

        After a decision the observer restarts (its residual from then on is what the commands
        on the rotors still believed working do not explain) and the same test runs again: a
        right decision leaves only noise, a wrong one leaves the dead rotors' missing thrust,
        and the detector names the set that best explains all its evidence (never one it
        already named, :meth:`_isolate`). Without ``config.revise`` it stops at its first
        decision."""
        if self.decisions and not self.config.revise:
            return None
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
            if not self.decisions:
                self.peak = max(self.peak, size)
            return None
        S = self._isolate(body, u)
        self._p0, self._integral, self._over = None, np.zeros(6), 0  # restart the observer
        if S is None:  # every set it may name is already named: nothing to revise to
            return None
        self.decisions.append((t, S))
        return self.decisions[-1]

    @property
    def detected(self) -> tuple[float, np.ndarray] | None:
        """The first decision's time and the failure set named last (None: no decision)."""
        if not self.decisions:
            return None
        return self.decisions[0][0], self.decisions[-1][1]

    def _isolate(self, residual: np.ndarray, u: np.ndarray) -> np.ndarray | None:
        """The failure set whose missing wrench best explains the residual of every decision
        so far, among the sets not yet named (None when there is none).

        At each decision i the scaled residual r_i should be a positive multiple of the scaled
        missing wrench d_i(S) = -A_S u_i[S] (the filter has not reached the full step; u_i the
        commands then, 0 on the rotors believed failed): the least-squares fit of r_i by such a
        multiple leaves ||r_i||^2 (1 - cos_i^2), cos_i the cosine between them. The score is
        the sum over the decisions of ||r_i||^2 cos_i |cos_i| (a cosine below 0 counts against,
        a set predicting no missing wrench scores 0): at the first decision the least angle,
        after a revision also the evidence of the earlier ones."""
        self._evidence.append((residual / self.scale, np.array(u, dtype=float)))
        named = {tuple(S) for _, S in self.decisions}
        best, score = None, -np.inf
        for S in self.candidates:
            if tuple(S) in named:
                continue
            total = 0.0
            for r, ui in self._evidence:
                d = -(self.A[:, S] @ ui[S]) / self.scale
                norm = float(np.linalg.norm(d))
                cos = float(r @ d) / (norm * float(np.linalg.norm(r))) if norm > 0 else 0.0
                total += float(r @ r) * cos * abs(cos)
            if best is None or total > score:
                best, score = S, total
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

    pair = detector if isinstance(detector, tuple) else (detector, SensorNoise())
    if len(pair) != 2 or not (
        isinstance(pair[0], DetectorConfig) and isinstance(pair[1], SensorNoise)
    ):
        raise ValueError(
            "detector must be a DetectorConfig or a (DetectorConfig, SensorNoise) pair, "
            f"got {detector!r}"
        )
    m = plant.A.shape[1]
    sets = failure_sets(m, kind if kind in FAULTS else "rotor")
    return FailureDetector(plant.A, plant.mass, plant.J, plant.f_max, sets, dt, *pair, com)
