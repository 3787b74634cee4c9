"""Dynamic tasks by motion: hover with a payload, a straight line with an acceleration limit, a
circle, a figure-eight and a push (a contact force along a straight path).

Every motion starts and ends at rest at the origin's level (so it can be flown from a hover),
holds ``hold`` seconds of hover at both ends, and is sampled at ``rate`` Hz with its
derivatives given in closed form (no spline error). Moving along a path uses a smooth time law:
the path parameter's rate rises from 0 to its cruise value over ``ramp`` seconds with the
quintic smoothstep ``10 s^3 - 15 s^4 + 6 s^5`` (continuous acceleration and jerk), cruises, and
falls back the same way. Each function returns a :class:`~modquad_gym.dynamics.task.DynamicTask`
(:data:`MOTIONS` by name); its ``meta`` records the motion and its parameters.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

from modquad_gym.core.validation import check_real
from modquad_gym.dynamics import quaternions as quat
from modquad_gym.dynamics.splines import DerivativeMismatchError
from modquad_gym.dynamics.task import DynamicTask
from modquad_gym.dynamics.trajectory import MAX_SAMPLES, Trajectory
from modquad_gym.dynamics.wrenches import Payload

DEFAULT_F_MAX = 2.0
"""Rotor thrust limit of the motions, newtons: a 0.3 kg module's four 45-degree rotors then
lift 5.66 N against its 2.94 N weight (thrust-to-weight 1.9)."""

DEFAULT_RATE = 100.0
"""Samples per second."""

MIN_PHASE_INTERVALS = 4
"""Fewest sample intervals a phase of changing acceleration (a line's move, a ramp) spans: its
samples then show at least 85 % of its peak acceleration wherever they fall (2 intervals can
all fall where it is 0: a 2 m move of 0.011 s at 100 samples/s peaked at 2e-9 m/s^2)."""


class LongMotionError(ValueError):
    """A motion of more samples than a trajectory holds (:data:`MAX_SAMPLES`): ``lengths`` are
    the parameters that set how long it lasts, ``duration`` (s) and ``rate`` (samples/s) the
    numbers, ``samples`` their count as text. Its message names the lengths and ``rate``; the
    command line names, of these, the options that were typed."""

    def __init__(self, lengths: tuple[str, ...], duration: float, rate: float, samples: str):
        self.lengths, self.duration, self.rate, self.samples = lengths, duration, rate, samples
        super().__init__(
            f"{', '.join((*lengths, 'rate'))}: the motion lasts {duration:.6g} s, {samples} "
            f"samples at rate {rate:g} samples/s, more than the {MAX_SAMPLES:,} a trajectory "
            f"holds; shorten it (its length is set by {', '.join(lengths)}) or lower the rate"
        )


def sample_count(duration: float, rate: float, lengths: tuple[str, ...] = ("duration",)) -> int:
    """How many samples a motion of ``duration`` seconds at ``rate`` Hz has (at least 2), or a
    :class:`LongMotionError` naming ``lengths`` (the parameters that set the duration) and ``rate``
    when that is more than a trajectory holds
    (:data:`~modquad_gym.dynamics.trajectory.MAX_SAMPLES`): checked from the two numbers,
    before any sample is built."""
    with np.errstate(over="ignore"):
        span = float(np.float64(duration) * np.float64(rate))
    n = max(2, int(math.ceil(span - 1e-9)) + 1) if span < MAX_SAMPLES else math.inf
    if n > MAX_SAMPLES:
        raise LongMotionError(tuple(lengths), duration, rate, _count(span + 1))
    return n


def check_phase(what: str, seconds: float, rate: float) -> None:
    """A ValueError ``WHAT lasts ...`` (the caller names the parameter to blame) when a phase
    of ``seconds`` is shorter than :data:`MIN_PHASE_INTERVALS` sample intervals at ``rate``
    Hz."""
    if seconds * rate < MIN_PHASE_INTERVALS:
        raise ValueError(
            f"{what} lasts {seconds:.2g} s, shorter than {MIN_PHASE_INTERVALS} sample intervals at "
            f"rate {rate:g} samples/s ({MIN_PHASE_INTERVALS / rate:.2g} s): too short for its "
            "samples to show its acceleration"
        )


def _count(n: float) -> str:
    return f"{n:,.0f}" if n < 1e15 else f"{n:.3g}"


def _times(duration: float, rate: float, lengths: tuple[str, ...]) -> np.ndarray:
    return np.linspace(0.0, duration, sample_count(duration, rate, lengths))


def _time_law(t: np.ndarray, cruise: float, total: float, ramp: float) -> tuple:
    """(phi, phi', phi'') of a parameter going from 0 to ``total`` with cruise rate ``cruise``,
    ramping up and down over ``ramp`` seconds each (module docstring), starting at t = 0."""
    t_cruise = total / cruise - ramp
    if t_cruise < -1e-12:
        raise ValueError(
            f"ramp: {ramp:g} s of speeding up and slowing down is longer than the whole motion "
            f"at this speed; use a shorter ramp or a longer path"
        )
    t_cruise = max(t_cruise, 0.0)
    end = 2 * ramp + t_cruise
    x = np.clip(t, 0.0, end)
    phi, rate, acc = np.zeros_like(x), np.zeros_like(x), np.zeros_like(x)
    up = x < ramp
    down = x > ramp + t_cruise
    mid = ~up & ~down
    for mask, tau, sign in ((up, x / ramp, 1.0), (down, (end - x) / ramp, -1.0)):
        s = tau[mask]
        part = cruise * ramp * (2.5 * s**4 - 3 * s**5 + s**6)
        phi[mask] = part if sign > 0 else total - part
        rate[mask] = cruise * (10 * s**3 - 15 * s**4 + 6 * s**5)
        acc[mask] = sign * cruise * (30 * s**2 - 60 * s**3 + 30 * s**4) / ramp
    phi[mid] = cruise * ramp / 2 + cruise * (x[mid] - ramp)
    rate[mid] = cruise
    return phi, rate, acc, end


def _along(path: Callable, law: tuple) -> tuple:
    """Positions, velocities, accelerations of ``path(phi) -> (p, p', p'')`` under a time
    law (:func:`_time_law`)."""
    phi, rate, acc, _ = law
    p, dp, ddp = path(phi)
    v = dp * rate[:, None]
    a = ddp * (rate**2)[:, None] + dp * acc[:, None]
    return p, v, a


def _moved(path: Callable, cruise: float, total: float, ramp: float, hold: float, rate: float,
           lengths: tuple[str, ...]):  # fmt: skip
    """(t, time law, (p, v, a)) of a move along ``path`` (:func:`_along`, :func:`_time_law`),
    sampled at ``rate`` Hz with ``hold`` seconds of hover before and after (``lengths``: the
    parameters that set how long it lasts, named when it is too long to sample)."""
    end = _time_law(np.zeros(1), cruise, total, ramp)[3]
    try:
        check_phase("speeding up (the ramp)", ramp, rate)
    except ValueError as exc:
        raise ValueError(f"rate: {exc}; raise rate") from None
    t = _times(end + 2 * hold, rate, lengths)
    law = _time_law(t - hold, cruise, total, ramp)
    return t, law, _along(path, law)


def _task(
    t,
    p,
    v,
    a,
    name: str,
    meta: dict,
    f_max: float,
    payload,
    exerted=None,
    quaternion=None,
    omega=None,
    alpha=None,
) -> DynamicTask:
    payload = as_payload(payload)
    try:
        traj = Trajectory(t, p, quaternion, v, a, omega, alpha)
    except DerivativeMismatchError as exc:  # exact derivatives: the samples are too sparse
        raise ValueError(
            f"rate: samples every {exc.step:.3g} s are too sparse to show this motion (at "
            f"sample {exc.sample} its {exc.field} is {_row(exc.given)}, the spline through the "
            f"samples gives {_row(exc.implied)}); raise rate"
        ) from None
    if payload is not None and payload.mass > 0:
        meta = {**meta, "payload_kg": payload.mass}
    return DynamicTask(traj, payload, exerted, f_max, name, meta)


def _row(x: np.ndarray) -> str:
    return "[" + ", ".join(f"{v + 0.0:.3g}" for v in x) + "]"


def as_payload(payload: object) -> Payload | None:
    """``payload`` of a motion (None, a :class:`Payload`, a mass in kg, or (mass,) or (mass,
    offset)) as a Payload or None; else a ValueError naming ``payload``."""
    if payload is None or isinstance(payload, Payload):
        return payload
    if isinstance(payload, (tuple, list)):
        if not 1 <= len(payload) <= 2:
            raise ValueError(
                f"payload must be a Payload, a mass in kg or (mass, offset), got {len(payload)} "
                f"entries: {payload!r:.60}"
            )
        return Payload(*payload)
    return Payload(payload)


def _direction(direction: object, what: str, horizontal: bool = False) -> np.ndarray:
    """``direction`` as a unit (3,) vector, or a ValueError naming ``direction``."""
    from modquad_gym.core.validation import float_array, refuse_non_numbers

    refuse_non_numbers(direction, "direction", "entry")
    try:
        d = float_array(direction, "direction")
    except (TypeError, ValueError, OverflowError):
        d = np.full(1, np.nan)
    with np.errstate(all="ignore"):
        big = np.abs(d).max() if d.shape == (3,) else np.nan
        norm = np.linalg.norm(d)
        if not 0 < norm < np.inf:  # 1e200 or 1e-300 per entry: a direction all the same
            d, norm = d / big, np.linalg.norm(d / big)
    if d.shape != (3,) or not (np.isfinite(d).all() and 0 < norm < np.inf) or (horizontal and d[2]):
        raise ValueError(f"direction must be {what}, got {direction!r:.60}")
    return d / norm


def _checked(**values: float) -> dict:
    return {k: check_real(v, k, positive=True) for k, v in values.items()}


def hover(
    duration: float = 2.0,
    *,
    f_max: float = DEFAULT_F_MAX,
    payload=None,
    rate: float = DEFAULT_RATE,
    name: str = "hover",
) -> DynamicTask:
    """Hover in place for ``duration`` seconds (with a payload: ``payload`` a :class:`Payload`,
    a mass in kg, or (mass, offset)). ``duration`` spans at least one sample interval
    (``1 / rate``: two samples that far apart); shorter is a ValueError naming it."""
    c = _checked(duration=duration, rate=rate)
    if c["duration"] * c["rate"] < 1:  # 2 samples 1e-320 s apart: no motion to speak of
        raise ValueError(
            f"duration: {c['duration']:g} s is shorter than one sample interval at rate "
            f"{c['rate']:g} samples/s ({1 / c['rate']:.3g} s); lengthen it or raise rate"
        )
    t = _times(c["duration"], c["rate"], ("duration",))
    zero = np.zeros((len(t), 3))
    meta = {"motion": "hover", "duration": c["duration"]}
    return _task(t, zero, zero, zero, name, meta, f_max, payload)


def line(
    distance: float = 2.0,
    max_acceleration: float = 2.0,
    *,
    direction=(1.0, 0.0, 0.0),
    hold: float = 0.5,
    f_max: float = DEFAULT_F_MAX,
    payload=None,
    rate: float = DEFAULT_RATE,
    name: str = "line",
) -> DynamicTask:
    """A straight rest-to-rest move of ``distance`` metres along ``direction`` (world) whose
    acceleration peaks at exactly ``max_acceleration`` m/s^2: the minimum-jerk profile
    ``s = D (10 u^3 - 15 u^4 + 6 u^5)``, u = t / T, whose peak acceleration is
    ``10 / sqrt(3) D / T^2``."""
    c = _checked(distance=distance, max_acceleration=max_acceleration, rate=rate)
    hold = check_real(hold, "hold", low=0.0)
    d = _direction(direction, "a finite non-zero [x, y, z]")
    D = c["distance"]
    T = math.sqrt(10.0 / math.sqrt(3.0) * D / c["max_acceleration"])
    try:
        move = f"the move of distance {D:g} m at {c['max_acceleration']:g} m/s^2"
        check_phase(move, T, c["rate"])
    except ValueError as exc:
        raise ValueError(
            f"max_acceleration: {exc}; raise rate, lower max_acceleration or lengthen distance"
        ) from None
    t = _times(T + 2 * hold, c["rate"], ("distance", "max_acceleration", "hold"))
    u = np.clip((t - hold) / T, 0.0, 1.0)
    s = D * (10 * u**3 - 15 * u**4 + 6 * u**5)
    ds = D * (30 * u**2 - 60 * u**3 + 30 * u**4) / T
    dds = D * (60 * u - 180 * u**2 + 120 * u**3) / T**2
    meta = {
        "motion": "line",
        "distance": D,
        "max_acceleration": c["max_acceleration"],
        "seconds": T,
    }
    return _task(t, s[:, None] * d, ds[:, None] * d, dds[:, None] * d, name, meta, f_max, payload)


def circle(
    radius: float = 1.0,
    speed: float = 1.0,
    *,
    laps: float = 1.0,
    ramp: float = 1.0,
    hold: float = 0.5,
    heading: str = "fixed",
    f_max: float = DEFAULT_F_MAX,
    payload=None,
    rate: float = DEFAULT_RATE,
    name: str = "circle",
) -> DynamicTask:
    """``laps`` turns of a horizontal circle of ``radius`` m at cruise ``speed`` m/s
    (centripetal acceleration speed^2 / radius), counter-clockwise from the origin. ``heading``
    ``"fixed"`` keeps the attitude level and the heading constant; ``"tangent"`` turns the
    body about z with the path (yaw rate speed / radius: the inertia enters the wrenches): the
    yaw is the path's angle phi (the point at angle phi from the centre), so the body's +y axis
    points along the velocity and its +x axis away from the centre, and the centripetal
    acceleration is along body -x (the structure's nose, +x, is not along the velocity)."""
    c = _checked(radius=radius, speed=speed, laps=laps, ramp=ramp, rate=rate)
    hold = check_real(hold, "hold", low=0.0)
    if heading not in ("fixed", "tangent"):
        raise ValueError(f"heading must be 'fixed' or 'tangent', got {heading!r}")
    R = c["radius"]

    def path(phi):
        cs, sn, z = np.cos(phi), np.sin(phi), np.zeros_like(phi)
        return (R * np.c_[cs - 1, sn, z], R * np.c_[-sn, cs, z], R * np.c_[-cs, -sn, z])

    total = 2 * math.pi * c["laps"]
    lengths = ("radius", "speed", "laps", "ramp", "hold")
    t, law, (p, v, a) = _moved(path, c["speed"] / R, total, c["ramp"], hold, c["rate"], lengths)
    meta = {
        "motion": "circle",
        "radius": R,
        "speed": c["speed"],
        "laps": c["laps"],
        "heading": heading,
    }
    if heading == "fixed":
        return _task(t, p, v, a, name, meta, f_max, payload)
    phi, dphi, ddphi, _ = law
    zero = np.zeros_like(phi)
    q, w, al = quat.about_z(phi), np.c_[zero, zero, dphi], np.c_[zero, zero, ddphi]
    return _task(t, p, v, a, name, meta, f_max, payload, None, q, w, al)


def figure_eight(
    size: float = 1.0,
    speed: float = 1.0,
    *,
    laps: float = 1.0,
    ramp: float = 1.0,
    hold: float = 0.5,
    f_max: float = DEFAULT_F_MAX,
    payload=None,
    rate: float = DEFAULT_RATE,
    name: str = "figure-eight",
) -> DynamicTask:
    """``laps`` of the horizontal figure-eight (lemniscate of Gerono) ``x = A sin phi,
    y = A/2 sin 2 phi`` of half-width A = ``size`` m, whose speed peaks at ``speed`` m/s at the
    crossing (cruise rate speed / (A sqrt 2)); level attitude."""
    c = _checked(size=size, speed=speed, laps=laps, ramp=ramp, rate=rate)
    hold = check_real(hold, "hold", low=0.0)
    A = c["size"]

    def path(phi):
        z = np.zeros_like(phi)
        s1, c1, s2, c2 = np.sin(phi), np.cos(phi), np.sin(2 * phi), np.cos(2 * phi)
        return A * np.c_[s1, s2 / 2, z], A * np.c_[c1, c2, z], A * np.c_[-s1, -2 * s2, z]

    cruise = c["speed"] / (A * math.sqrt(2.0))
    total = 2 * math.pi * c["laps"]
    lengths = ("size", "speed", "laps", "ramp", "hold")
    t, _, (p, v, a) = _moved(path, cruise, total, c["ramp"], hold, c["rate"], lengths)
    meta = {"motion": "figure-eight", "size": A, "speed": c["speed"], "laps": c["laps"]}
    return _task(t, p, v, a, name, meta, f_max, payload)


def push(
    distance: float = 2.0,
    speed: float = 0.5,
    force: float = 2.0,
    *,
    direction=(1.0, 0.0, 0.0),
    ramp: float = 1.0,
    hold: float = 0.5,
    f_max: float = DEFAULT_F_MAX,
    payload=None,
    rate: float = DEFAULT_RATE,
    name: str = "push",
) -> DynamicTask:
    """Push an object ``distance`` metres along a horizontal ``direction`` at cruise ``speed``
    m/s against a contact force of ``force`` N (sliding friction): the structure exerts
    ``force`` along the direction, at its COM, rising and falling with the speed (quintic
    smoothstep of the speed fraction), as exerted wrenches in {S}."""
    c = _checked(distance=distance, speed=speed, force=force, ramp=ramp, rate=rate)
    hold = check_real(hold, "hold", low=0.0)
    d = _direction(direction, "a finite horizontal non-zero [x, y, 0]", horizontal=True)

    def path(s):
        return s[:, None] * d, np.ones_like(s)[:, None] * d, np.zeros((len(s), 3))

    lengths = ("distance", "speed", "ramp", "hold")
    t, law, (p, v, a) = _moved(path, c["speed"], c["distance"], c["ramp"], hold, c["rate"], lengths)
    exerted = np.zeros((len(t), 6))
    exerted[:, :3] = (c["force"] * law[1] / c["speed"])[:, None] * d  # level: {S} axes = world
    meta = {"motion": "push", "distance": c["distance"], "speed": c["speed"], "force": c["force"]}
    return _task(t, p, v, a, name, meta, f_max, payload, exerted)


MOTIONS: dict[str, Callable[..., DynamicTask]] = {
    "hover": hover,
    "line": line,
    "circle": circle,
    "figure-eight": figure_eight,
    "push": push,
}
"""The motions by name."""
