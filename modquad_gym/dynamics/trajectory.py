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
``omega = 2 Im(q* dq/dt)`` and ``alpha = 2 Im(q* d2q/dt2)``; the angular acceleration from the
spline of the body rates when those are given (with or without quaternions).

Sampling too coarse for the derivatives is refused: where the spline's derivative changes by
more than ``accuracy`` (m/s^2 for the acceleration, rad/s^2 for the angular acceleration) when
the spline is fitted again on every other sample (or, with few samples, with a fit of lower
order), the trajectory is a ValueError naming the field (:mod:`.splines`). With 2 samples the
motion between them is taken as uniform (no acceleration): there is nothing to estimate.

Given derivatives are checked against the splines of the samples (velocity and acceleration
against the positions', body rates and angular acceleration against the quaternions'): one
that differs by more than ``accuracy`` plus :data:`~.splines.AGREEMENT` times the spline's
estimated error is refused, naming the field and the sample. This is a check of order of
magnitude (a unit slip: times in milliseconds), not of accuracy: within it, given derivatives
are used as they are. Without quaternions, given body rates are taken as they are (the level
default attitude does not imply them).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from modquad_gym.dynamics import quaternions as quat
from modquad_gym.dynamics.samples import (  # noqa: F401 (MAX_SAMPLES, UNIT_TOL: read here too)
    MAX_SAMPLES,
    UNIT_TOL,
    check_quaternions,
    check_times,
    sample_array,
)
from modquad_gym.dynamics.splines import check_coarse, check_given, estimated_error, spline

DEFAULT_ACCURACY = 0.05
"""Default accuracy of spline-derived accelerations: 0.05 m/s^2 (0.5 % of g) and 0.05 rad/s^2."""

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


class Trajectory:
    """A sampled motion of the structure frame {S} and its derivatives (module docstring).

    Args:
        t: (k,) sample times in seconds, strictly increasing, 2 <= k <= :data:`MAX_SAMPLES`.
        position: (k, 3) positions of the {S} origin in the world, metres.
        quaternion: (k, 4) unit quaternions (w, x, y, z), world <- body; default level.
        velocity: (k, 3) world frame; computed by splines when not given, else checked
            against them (module docstring).
        acceleration: (k, 3) world frame; likewise.
        angular_velocity: (k, 3) body frame; from the quaternions' spline when not given (zero
            without quaternions); given with quaternions, checked against it; given without,
            taken as is.
        angular_acceleration: (k, 3) body frame; from the quaternions' spline, or from the
            given ``angular_velocity``'s (zero without either); given with quaternions,
            checked against their spline; given without, taken as is.
        accuracy: largest accepted estimated error of a spline-derived acceleration (m/s^2)
            or angular acceleration (rad/s^2); with :data:`~.splines.AGREEMENT`, how far a
            given derivative may be from the spline's (in its own unit).
        smoothing: None (interpolating quintic splines) or the ``lam`` of cubic smoothing
            splines for noisy samples.

    Raises:
        ValueError: one line naming the field and the 1-based sample: wrong shape or row
            length, NaN or infinity, times not increasing, a quaternion of norm other than 1,
            too many samples, sampling too coarse for ``accuracy``, a given derivative that
            disagrees with the samples
            (:class:`~.splines.DerivativeMismatchError`, both values named).
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
        self.position = sample_array(position, "position", k, 3)
        given = {"t", "position"}
        checked = {}
        for name, value in (
            ("velocity", velocity),
            ("acceleration", acceleration),
            ("angular_velocity", angular_velocity),
            ("angular_acceleration", angular_acceleration),
        ):
            if value is not None:
                checked[name] = sample_array(value, name, k, 3)
                given.add(name)
        if quaternion is None:
            self.quaternion = np.tile(quat.IDENTITY, (k, 1))
        else:
            self.quaternion = check_quaternions(quaternion, k)
            given.add("quaternion")
        self.given = tuple(f for f in FIELDS if f in given)
        self.accuracy, self.smoothing = accuracy, smoothing
        self.derivative_error = {}
        with np.errstate(all="ignore"):  # a non-finite derivative is refused below, by name
            self._linear(checked)
            self._angular(checked, quaternion is not None)
        self._check_derived()
        for name in FIELDS[1:]:
            getattr(self, name).setflags(write=False)
        self.t.setflags(write=False)

    def _linear(self, given: dict) -> None:
        """Velocity and acceleration: given ones checked against the position spline's,
        missing ones derived (module docstring)."""
        t, p, acc, sm = self.t, self.position, self.accuracy, self.smoothing
        fit = spline(t, p, sm)
        v, a = fit(t, 1), fit(t, 2)
        for name, implied, order, unit in (
            ("velocity", v, 1, "m/s"),
            ("acceleration", a, 2, "m/s^2"),
        ):
            if name in given:
                err = estimated_error(t, p, implied, order, sm)
                check_given(t, given[name], implied, err, acc, name, unit, "positions")
        self.velocity = given.get("velocity", v)
        if "acceleration" in given:
            self.acceleration = given["acceleration"]
        elif "velocity" in given:
            self.acceleration = spline(t, self.velocity, sm)(t, 1)
            self.derivative_error["acceleration"] = check_coarse(
                t, self.velocity, self.acceleration, 1, acc, "acceleration", "m/s^2", sm
            )
        else:
            self.acceleration = a
            self.derivative_error["acceleration"] = check_coarse(
                t, p, a, 2, acc, "acceleration", "m/s^2", sm
            )

    def _angular(self, given: dict, turns: bool) -> None:
        """Body rates and angular acceleration: with quaternions, given ones checked against
        the quaternion spline's and missing ones derived from it; given rates (with or without
        quaternions) give the angular acceleration by their own spline; else zero."""
        t, q, acc, sm = self.t, self.quaternion, self.accuracy, self.smoothing
        zero = np.zeros((len(t), 3))
        if turns:
            qc, fit = quat.conjugate(q), spline(t, q, sm)
            w, al = (2.0 * quat.multiply(qc, fit(t, nu))[:, 1:] for nu in (1, 2))
            for name, implied, order, unit in (
                ("angular_velocity", w, 1, "rad/s"),
                ("angular_acceleration", al, 2, "rad/s^2"),
            ):
                if name in given:
                    err = estimated_error(t, q, fit(t, order), order, sm)
                    err = None if err is None else 2.0 * err  # omega, alpha: 2 Im(q* q')
                    check_given(t, given[name], implied, err, acc, name, unit, "quaternions")
        self.angular_velocity = given.get("angular_velocity", w if turns else zero)
        if "angular_acceleration" in given:
            self.angular_acceleration = given["angular_acceleration"]
            return
        field, unit = "angular_acceleration", "rad/s^2"
        if "angular_velocity" in given:
            w = self.angular_velocity
            self.angular_acceleration = spline(t, w, sm)(t, 1)
            err = check_coarse(t, w, self.angular_acceleration, 1, acc, field, unit, sm)
        elif turns:
            self.angular_acceleration = al
            err = check_coarse(t, q, fit(t, 2), 2, acc, field, unit, sm, scale=2.0)
        else:  # level throughout, no rates given
            self.angular_acceleration = zero.copy()
            return
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

    @classmethod
    def resampled(cls, fields: dict[str, np.ndarray]) -> Trajectory:
        """A trajectory holding ``fields`` (each of :data:`FIELDS`, as :meth:`at` returns them,
        ``t`` increasing) as they are: nothing derived, nothing checked. For a resampling of a
        trajectory already checked (a controller's reference at its own rate), whose cubic
        interpolations of each field need not agree with the splines of the positions."""
        self = cls.__new__(cls)
        for f in FIELDS:
            setattr(self, f, np.array(fields[f], dtype=float))
        self.quaternion = check_quaternions(self.quaternion, len(self.t))  # as __init__ does
        for f in FIELDS:
            getattr(self, f).setflags(write=False)
        self.given, self.derivative_error = FIELDS, {}
        self.accuracy, self.smoothing = DEFAULT_ACCURACY, None
        return self

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
            accuracy=self.accuracy,
            smoothing=self.smoothing,
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
