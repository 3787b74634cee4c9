"""Splines through a trajectory's samples, the error of their derivatives, and the check of
derivatives given beside the samples (:class:`~modquad_gym.dynamics.trajectory.Trajectory`).

The error of a spline's derivative is estimated by fitting again on every other sample (the
last kept): for a quintic spline the half-sampled fit's error is about 2^4 = 16 times the full
fit's, so their difference overestimates the full fit's error. With too few samples to halve
(fewer than 12), the comparison is with a fit of lower order through all of them: a cubic
(5 to 11 samples), a quadratic (4), a line (3). Two samples fix no second derivative: the
line through them is taken as the motion (no acceleration), with no estimate to make.

A derivative given beside the samples is refused where it differs from the spline's by more
than ``accuracy + AGREEMENT x`` that estimate (:func:`check_given`): a test of order of
magnitude, not of accuracy. It catches a unit slip (times in milliseconds: the samples then
imply speeds 1,000 times lower and accelerations 10^6 times lower than given), not a small
error. Samples that alias their motion (fewer than about one sample per turn of a circle)
cannot be told from such a slip: both show a slow motion where the derivatives say a fast one,
and both are refused.
"""

from __future__ import annotations

import numpy as np

AGREEMENT = 10.0
"""A given derivative may differ from the spline's by ``accuracy`` plus this many times the
spline's estimated error. Measured by ``python -m benchmarks.derivative_agreement``: the exact
derivatives of ``modquad task motion``'s motions over a grid of every kind's options at 4 to
1,000 samples/s differ by at most 3.5 times (0.84 where each turn of the path spans 2 samples or
more), 400 ``MotionTasks`` draws by 0.12, the dynamic suite's 60 tasks by 0.08; every motion
written with its times in milliseconds by 3.1e6 times or more. Of 1,000 motions of options over
wide ranges, the 29 refused all had fewer than 0.87 samples per turn of their path."""

HALF_MIN = 7
"""Fewest samples a fit on every other sample may have (else a lower-order fit compares)."""


class DerivativeMismatchError(ValueError):
    """A given derivative that disagrees with its samples (:func:`check_given`): ``field``,
    ``sample`` (1-based), the values ``given`` and ``implied``, and the sample spacing
    ``step`` (s), so that a motion generator can name its own cause (its ``rate``)."""

    def __init__(self, message: str, field: str, sample: int, given, implied, step: float):
        super().__init__(message)
        self.field, self.sample, self.given, self.implied = field, sample, given, implied
        self.step = step


def spline(t: np.ndarray, y: np.ndarray, smoothing: float | None):
    """A spline through (t, y) (quintic, or lower for few samples), or a smoothing spline."""
    from scipy.interpolate import make_interp_spline, make_smoothing_spline

    if smoothing is not None and len(t) >= 5:
        return Stacked(
            [make_smoothing_spline(t, y[:, j], lam=smoothing) for j in range(y.shape[1])]
        )
    return make_interp_spline(t, y, k=min(5, len(t) - 1))


class Stacked:
    """Column splines evaluated together, like one vector-valued BSpline."""

    def __init__(self, parts: list) -> None:
        self.parts = parts

    def __call__(self, x: np.ndarray, nu: int = 0) -> np.ndarray:
        return np.stack([p(x, nu) for p in self.parts], axis=-1)


def estimate(
    t: np.ndarray, y: np.ndarray, order: int, smoothing: float | None
) -> np.ndarray | None:
    """The other fit's ``order``-th derivative at t, to compare with the full fit's: the fit on
    every other sample, or one of lower order through all samples (module docstring); None when
    no fit of lower order has that derivative (2 samples, order 2)."""
    from scipy.interpolate import make_interp_spline

    keep = np.arange(0, len(t), 2)
    if keep[-1] != len(t) - 1:
        keep = np.r_[keep, len(t) - 1]
    if len(keep) >= HALF_MIN:
        return spline(t[keep], y[keep], smoothing)(t, order)
    lower = min(3, len(t) - 2)
    if lower < order - 1:  # a line through 2 samples: its second derivative is 0 by fiat
        return None
    return make_interp_spline(t, y, k=lower)(t, order)


def estimated_error(
    t: np.ndarray, y: np.ndarray, full: np.ndarray, order: int, smoothing: float | None
) -> float | None:
    """The largest difference between ``full`` and the other fit's derivative
    (:func:`estimate`), or None when there is no estimate."""
    other = estimate(t, y, order, smoothing)
    return None if other is None else float(np.abs(other - full).max())


def check_coarse(
    t: np.ndarray,
    y: np.ndarray,
    full: np.ndarray,
    order: int,
    accuracy: float,
    field: str,
    unit: str,
    smoothing: float | None,
    scale: float = 1.0,
) -> float:
    """The estimated error of ``scale x full`` (``full`` the ``order``-th derivative of the fit
    through (t, y); 0 where none can be made), or a ValueError naming ``field`` when it exceeds
    ``accuracy``. A ``full`` that is not finite is left to the caller, which names it."""
    if not np.isfinite(full).all():
        return float("nan")
    err = estimated_error(t, y, full, order, smoothing)
    if err is None:  # 2 samples: uniform motion between them, by convention (nothing to estimate)
        return 0.0
    err *= scale
    if not err <= accuracy:
        raise ValueError(
            f"{field}: sampling too coarse for the requested accuracy ({accuracy:g} {unit}): "
            f"spline estimates change by {err:.3g} {unit} when every other sample is dropped "
            f"(or, with fewer than {2 * HALF_MIN - 2} samples, with a fit of lower order); "
            f"sample more densely (now every {np.median(np.diff(t)):.3g} s) or give {field}"
        )
    return err


def check_given(
    t: np.ndarray,
    given: np.ndarray,
    implied: np.ndarray,
    error: float | None,
    accuracy: float,
    field: str,
    unit: str,
    source: str,
) -> None:
    """A :class:`DerivativeMismatchError` at the first sample where ``given`` differs from the
    spline's ``implied`` (from ``source``, the samples it is fitted through) by more than
    ``accuracy + AGREEMENT x error`` in a component; nothing to check when ``error`` is None
    (no estimate: 2 samples and a second derivative)."""
    if error is None:
        return
    tol = accuracy + AGREEMENT * error
    with np.errstate(invalid="ignore"):
        bad = np.abs(given - implied).max(axis=1) > tol
    if not bad.any():
        return
    i = int(np.argmax(bad))
    step = float(np.median(np.diff(t)))

    def shown(row: np.ndarray) -> str:
        return "[" + ", ".join(f"{x + 0.0:.4g}" for x in row) + "]"  # + 0.0: no "-0"

    raise DerivativeMismatchError(
        f"{field}: sample {i + 1} is {shown(given[i])} {unit}, but the {source} imply "
        f"{shown(implied[i])} {unit} (the spline through them is within {error:.3g} {unit}; "
        f"accepted: {tol:.3g}): check the units (t in seconds) and the values, or sample more "
        f"densely than every {step:.3g} s",
        field,
        i + 1,
        given[i].copy(),
        implied[i].copy(),
        step,
    )
