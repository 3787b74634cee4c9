"""A motion of the structure frame {S}: sampled poses and their derivatives (:class:`Trajectory`).

Samples: times ``t`` (k,) strictly increasing, in seconds; ``position`` (k, 3) of the {S} origin
(the structure's COM) in the world, metres; ``quaternion`` (k, 4) unit, (w, x, y, z), world <-
body (default level: (1, 0, 0, 0)). Derivatives: ``velocity`` and ``acceleration`` (k, 3) in the
world frame, ``angular_velocity`` and ``angular_acceleration`` (k, 3) in the body frame.

Derivatives not given are computed by splines through the samples: quintic interpolating
splines (the samples are taken as exact), or, with ``smoothing`` (a regularisation weight in
scipy's :func:`~scipy.interpolate.make_smoothing_spline`), cubic smoothing splines for noisy
samples. Velocity comes from the position spline (acceleration from the velocity's if that is
given, else from the position's second derivative); body rates from the quaternion spline,
``omega = 2 Im(q* dq/dt)`` and ``alpha = 2 Im(q* d2q/dt2)``.

Sampling too coarse for the derivatives is refused: the spline is fitted again on every other
sample, and where the two fits' second derivatives differ by more than ``accuracy`` (m/s^2 for
the acceleration, rad/s^2 for the angular acceleration) the trajectory is a ValueError naming
the field. For a quintic spline the half-sampled fit's error is about 2^4 = 16 times the full
fit's, so the difference overestimates the full fit's error: the test is conservative.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from modquad_gym.core.validation import float_array, refuse_bools
from modquad_gym.dynamics import quaternions as quat

MAX_SAMPLES = 100_000
"""Most samples in one trajectory (100 s at 1 kHz); more is refused before any work."""

DEFAULT_ACCURACY = 0.05
"""Default accuracy of spline-derived accelerations: 0.05 m/s^2 (0.5 % of g) and 0.05 rad/s^2."""

UNIT_TOL = 1e-6
"""How far a quaternion's norm may be from 1 (it is then normalised)."""

FIELDS = (
    "t",
    "position",
    "quaternion",
    "velocity",
    "acceleration",
    "angular_velocity",
    "angular_acceleration",
)
"""The fields of a trajectory, in order (the keys of its JSON object)."""


def _array(value: object, field: str, k: int | None, width: int) -> np.ndarray:
    """A float (k, width) copy of ``value``; errors name the field and the 1-based sample."""
    refuse_bools(value, field)
    arr = float_array(value, field, "an array of numbers")
    shape = (k if k is not None else "k", width)
    if arr.ndim != 2 or arr.shape[1] != width or (k is not None and arr.shape[0] != k):
        raise ValueError(f"{field} must have shape {shape} (one row per sample), got {arr.shape}")
    bad = ~np.isfinite(arr)
    if bad.any():
        row, col = np.argwhere(bad)[0]
        raise ValueError(f"{field}: sample {row + 1} holds {arr[row, col]} (must be finite)")
    return arr


def check_times(t: object) -> np.ndarray:
    """The sample times as a float (k,) array, k in [2, MAX_SAMPLES], finite and strictly
    increasing; else a ValueError naming ``t`` and the first bad sample (1-based)."""
    refuse_bools(t, "t")
    arr = float_array(t, "t", "a list of sample times in seconds")
    if arr.ndim != 1:
        raise ValueError(f"t must be a flat list of times, got shape {arr.shape}")
    if arr.size > MAX_SAMPLES:
        raise ValueError(f"t: {arr.size:,} samples, more than the {MAX_SAMPLES:,} allowed")
    if arr.size < 2:
        raise ValueError(f"t: a trajectory needs at least 2 samples, got {arr.size}")
    bad = ~np.isfinite(arr)
    if bad.any():
        i = int(np.argmax(bad))
        raise ValueError(f"t: sample {i + 1} is {arr[i]} (times must be finite)")
    step = np.diff(arr)
    if np.any(step <= 0):
        i = int(np.argmax(step <= 0))
        raise ValueError(
            f"t: not increasing at sample {i + 2} (t = {arr[i + 1]:g} s after {arr[i]:g} s)"
        )
    return arr


def check_quaternions(q: object, k: int) -> np.ndarray:
    """Unit (w, x, y, z) rows (normalised, signs made continuous); else a ValueError naming
    ``quaternion`` and the first sample whose norm is not 1 within :data:`UNIT_TOL`."""
    arr = _array(q, "quaternion", k, 4)
    norms = np.linalg.norm(arr, axis=1)
    bad = np.abs(norms - 1.0) > UNIT_TOL
    if bad.any():
        i = int(np.argmax(bad))
        raise ValueError(
            f"quaternion: sample {i + 1} has norm {norms[i]:.9g}, not 1 (unit quaternions "
            "w, x, y, z, world <- body)"
        )
    return quat.continuous(arr / norms[:, None])


def _spline(t: np.ndarray, y: np.ndarray, smoothing: float | None):
    """A spline through (t, y) (quintic, or lower for few samples), or a smoothing spline."""
    from scipy.interpolate import make_interp_spline, make_smoothing_spline

    if smoothing is not None and len(t) >= 5:
        return _Stacked(
            [make_smoothing_spline(t, y[:, j], lam=smoothing) for j in range(y.shape[1])]
        )
    return make_interp_spline(t, y, k=min(5, len(t) - 1))


class _Stacked:
    """Column splines evaluated together, like one vector-valued BSpline."""

    def __init__(self, parts: list) -> None:
        self.parts = parts

    def __call__(self, x: np.ndarray, nu: int = 0) -> np.ndarray:
        return np.stack([p(x, nu) for p in self.parts], axis=-1)


def _second_derivative_check(
    t: np.ndarray,
    y: np.ndarray,
    full: np.ndarray,
    order: int,
    accuracy: float,
    field: str,
    unit: str,
    smoothing: float | None,
) -> float:
    """Compare ``full`` (the ``order``-th derivative of the full fit at t) with the fit on every
    other sample; ValueError naming ``field`` if they differ by more than ``accuracy``."""
    keep = np.arange(0, len(t), 2)
    if keep[-1] != len(t) - 1:
        keep = np.r_[keep, len(t) - 1]
    if len(keep) >= 7:
        half = _spline(t[keep], y[keep], smoothing)(t, order)
    elif len(t) >= 4:  # too few samples to halve: compare with a cubic through all of them
        from scipy.interpolate import make_interp_spline

        half = make_interp_spline(t, y, k=3)(t, order)
    else:  # 2 or 3 samples: the line or parabola through them is all there is to know
        return 0.0
    err = float(np.abs(half - full).max())
    if err > accuracy:
        raise ValueError(
            f"{field}: sampling too coarse for the requested accuracy ({accuracy:g} {unit}): "
            f"spline estimates change by {err:.3g} {unit} when every other sample is dropped; "
            f"sample more densely (now every {np.median(np.diff(t)):.3g} s) or give {field}"
        )
    return err


class Trajectory:
    """A sampled motion of the structure frame {S} and its derivatives (module docstring).

    Args:
        t: (k,) sample times in seconds, strictly increasing, 2 <= k <= :data:`MAX_SAMPLES`.
        position: (k, 3) positions of the {S} origin in the world, metres.
        quaternion: (k, 4) unit quaternions (w, x, y, z), world <- body; default level.
        velocity: (k, 3) world frame; computed by splines when not given.
        acceleration: (k, 3) world frame; computed by splines when not given.
        angular_velocity: (k, 3) body frame; from the quaternions' spline when not given (zero
            for a level trajectory).
        angular_acceleration: (k, 3) body frame; likewise.
        accuracy: largest accepted estimated error of a spline-derived acceleration (m/s^2)
            or angular acceleration (rad/s^2).
        smoothing: None (interpolating quintic splines) or the ``lam`` of cubic smoothing
            splines for noisy samples.

    Raises:
        ValueError: one line naming the field and the 1-based sample: wrong shape, NaN or
            infinity, times not increasing, a quaternion of norm other than 1, too many
            samples, sampling too coarse for ``accuracy``.
    """

    def __init__(
        self,
        t: object,
        position: object,
        quaternion: object = None,
        velocity: object = None,
        acceleration: object = None,
        angular_velocity: object = None,
        angular_acceleration: object = None,
        *,
        accuracy: float = DEFAULT_ACCURACY,
        smoothing: float | None = None,
    ) -> None:
        from modquad_gym.core.validation import check_real

        accuracy = check_real(accuracy, "accuracy", positive=True)
        if smoothing is not None:
            smoothing = check_real(smoothing, "smoothing", low=0.0)
        self.t = check_times(t)
        k = len(self.t)
        self.position = _array(position, "position", k, 3)
        given = {"t", "position"}
        checked = {}
        for name, value in (
            ("velocity", velocity),
            ("acceleration", acceleration),
            ("angular_velocity", angular_velocity),
            ("angular_acceleration", angular_acceleration),
        ):
            if value is not None:
                checked[name] = _array(value, name, k, 3)
                given.add(name)
        if quaternion is None:
            self.quaternion = np.tile(quat.IDENTITY, (k, 1))
        else:
            self.quaternion = check_quaternions(quaternion, k)
            given.add("quaternion")
        self.given = tuple(f for f in FIELDS if f in given)
        self.derivative_error = {}
        with np.errstate(all="ignore"):  # a non-finite derivative is refused below, by name
            self._linear(checked, accuracy, smoothing)
            self._angular(checked, accuracy, smoothing, quaternion is not None)
        self._check_derived()
        for name in FIELDS[1:]:
            getattr(self, name).setflags(write=False)
        self.t.setflags(write=False)

    def _linear(self, given: dict, accuracy: float, smoothing: float | None) -> None:
        t, p = self.t, self.position
        spline = _spline(t, p, smoothing) if "velocity" not in given else None
        self.velocity = given["velocity"] if "velocity" in given else spline(t, 1)
        if "acceleration" in given:
            self.acceleration = given["acceleration"]
        elif "velocity" in given:
            self.acceleration = _spline(t, self.velocity, smoothing)(t, 1)
            self.derivative_error["acceleration"] = _second_derivative_check(
                t, self.velocity, self.acceleration, 1, accuracy, "acceleration", "m/s^2", smoothing
            )
        else:
            self.acceleration = spline(t, 2)
            self.derivative_error["acceleration"] = _second_derivative_check(
                t, p, self.acceleration, 2, accuracy, "acceleration", "m/s^2", smoothing
            )

    def _angular(self, given: dict, accuracy: float, smoothing: float | None, turns: bool) -> None:
        t, q = self.t, self.quaternion
        if not turns:  # level throughout: no rates unless given
            zero = np.zeros((len(t), 3))
            self.angular_velocity = given.get("angular_velocity", zero)
            self.angular_acceleration = given.get("angular_acceleration", zero.copy())
            return
        qc = quat.conjugate(q)
        if "angular_velocity" in given:
            self.angular_velocity = given["angular_velocity"]
        else:
            qs = _spline(t, q, smoothing)
            self.angular_velocity = 2.0 * quat.multiply(qc, qs(t, 1))[:, 1:]
        if "angular_acceleration" in given:
            self.angular_acceleration = given["angular_acceleration"]
            return
        if "angular_velocity" in given:
            w = self.angular_velocity
            self.angular_acceleration = _spline(t, w, smoothing)(t, 1)
            err = _second_derivative_check(
                t,
                w,
                self.angular_acceleration,
                1,
                accuracy,
                "angular_acceleration",
                "rad/s^2",
                smoothing,
            )
        else:
            self.angular_acceleration = 2.0 * quat.multiply(qc, qs(t, 2))[:, 1:]
            err = _second_derivative_check(
                t, q, qs(t, 2), 2, accuracy / 2.0, "angular_acceleration", "rad/s^2", smoothing
            )
        self.derivative_error["angular_acceleration"] = err

    def _check_derived(self) -> None:
        """A ValueError naming the first derivative the splines made non-finite (samples too
        close in time for floating point: steps of 1e-300 s, say), and its sample."""
        for name in FIELDS[3:]:
            arr = getattr(self, name)
            bad = ~np.isfinite(arr)
            if bad.any():
                i = int(np.argwhere(bad)[0, 0])
                raise ValueError(
                    f"{name}: not finite at sample {i + 1} when derived from the samples, which "
                    f"are as little as {np.diff(self.t).min():.3g} s apart (too close for the "
                    f"splines); space the samples further or give {name}"
                )

    # --- reading ----------------------------------------------------------------------------
    @property
    def n_samples(self) -> int:
        return len(self.t)

    def __len__(self) -> int:
        return len(self.t)

    @property
    def duration(self) -> float:
        """Seconds from the first sample to the last."""
        return float(self.t[-1] - self.t[0])

    def rotations(self) -> np.ndarray:
        """(k, 3, 3) rotation matrices world <- body."""
        return quat.to_matrix(self.quaternion)

    @property
    def is_level(self) -> bool:
        """True when the attitude never changes from level (no quaternion given or all
        identity) and no body rate was given."""
        return bool(
            np.all(self.quaternion == quat.IDENTITY)
            and not np.any(self.angular_velocity)
            and not np.any(self.angular_acceleration)
        )

    def at(self, times: object) -> dict[str, np.ndarray]:
        """Every field at arbitrary ``times`` within [t_0, t_end] (clipped), by cubic
        interpolation of each sampled field (quaternions renormalised): the reference a
        controller follows between samples. Returns a dict keyed by :data:`FIELDS`."""
        from scipy.interpolate import make_interp_spline

        x = np.clip(np.asarray(times, dtype=float), self.t[0], self.t[-1])
        if not hasattr(self, "_interp"):
            deg = min(3, len(self.t) - 1)
            self._interp = {
                f: make_interp_spline(self.t, getattr(self, f), k=deg) for f in FIELDS[1:]
            }
        out = {"t": x}
        for f, s in self._interp.items():
            out[f] = s(x)
        out["quaternion"] = (
            out["quaternion"] / np.linalg.norm(out["quaternion"], axis=-1)[..., None]
        )
        return out

    def shifted(self, offset: object) -> Trajectory:
        """The same motion translated by ``offset`` (3,) metres (derivatives unchanged)."""
        d = np.asarray(offset, dtype=float).reshape(3)
        return Trajectory(
            self.t,
            self.position + d,
            self.quaternion,
            self.velocity,
            self.acceleration,
            self.angular_velocity,
            self.angular_acceleration,
        )

    # --- dicts ------------------------------------------------------------------------------
    def to_dict(self, derivatives: bool = True) -> dict[str, Any]:
        """A JSON-ready dict: t and position, the quaternion when not level, and every
        derivative with ``derivatives`` (so that reading it back recomputes nothing), else
        only those that were given."""
        out: dict[str, Any] = {"t": self.t.tolist(), "position": self.position.tolist()}
        for f in FIELDS[2:]:
            if f in self.given or (derivatives and (f != "quaternion" or not self.is_level)):
                out[f] = getattr(self, f).tolist()
        return out

    @classmethod
    def from_dict(cls, data: object, where: str = "trajectory", **kwargs: Any) -> Trajectory:
        """From a dict of :data:`FIELDS` (only ``t`` and ``position`` required); errors name
        the field as ``trajectory.FIELD``; unknown keys are refused."""
        if not isinstance(data, dict):
            raise ValueError(f"{where} must be an object with 't' and 'position', got {data!r}")
        unknown = sorted(set(data) - set(FIELDS))
        if unknown:
            raise ValueError(f"{where}.{unknown[0]}: unknown key; known: {', '.join(FIELDS)}")
        for key in ("t", "position"):
            if key not in data:
                raise ValueError(f"{where}.{key}: missing (required)")
        try:
            return cls(**data, **kwargs)
        except ValueError as exc:
            raise ValueError(f"{where}.{exc}") from None

    def __repr__(self) -> str:
        return (
            f"Trajectory(samples={self.n_samples}, duration={self.duration:g} s, "
            f"given={list(self.given)})"
        )
