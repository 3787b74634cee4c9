"""The statistics of the reports over seeds, as rliable defines them (Agarwal et al. 2021): the
interquartile mean and its stratified percentile-bootstrap interval.

An interval needs at least two values in every stratum: with one there is nothing to resample,
and :func:`interval` gives the point with NaN bounds, which the reports print as ``n/a (1
seed)`` (or run, or task) and judge no goal on. With two the percentile interval is the range
of the two values, far below its nominal 95 % coverage (``python -m
benchmarks.interval_coverage`` measures it).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence

import numpy as np
from scipy import stats


def iqm(scores: np.ndarray) -> float:
    """Interquartile mean: the mean of the middle 50 % (25 % trimmed at each end)."""
    return float(stats.trim_mean(np.ravel(scores), 0.25))


def mean(scores: np.ndarray) -> float:
    """The mean, as a float (:func:`interval` bootstraps it in one pass)."""
    return float(np.mean(scores))


def _iqm_rows(a: np.ndarray) -> np.ndarray:
    """:func:`iqm` of each row of ``a`` (finite floats): scipy's steps (a partition, the mean
    of the middle) on each row, without its checks at each of a bootstrap's 2,000 calls."""
    low = int(0.25 * a.shape[-1])
    high = a.shape[-1] - low
    return np.mean(np.partition(a, (low, high - 1), axis=-1)[..., low:high], axis=-1)


def _mean_rows(a: np.ndarray) -> np.ndarray:
    return np.mean(a, axis=-1)


ROWS = {iqm: _iqm_rows, mean: _mean_rows, np.mean: _mean_rows}
"""Aggregates :func:`interval` computes for every resample at once (each row as the aggregate
computes it alone, so the same floats); any other is called once per resample."""


def checked_columns(columns: Sequence[np.ndarray]) -> list[np.ndarray]:
    """``columns`` as float arrays; ValueError naming the 1-based column (and value) for no
    column, an empty column or a value that is NaN or infinite."""
    cols = [np.ravel(np.asarray(c, dtype=float)) for c in columns]
    if not cols:
        raise ValueError("columns: no column of scores")
    for i, c in enumerate(cols, start=1):
        if not c.size:
            raise ValueError(f"columns: column {i} of {len(cols)} holds no value")
        bad = np.flatnonzero(~np.isfinite(c))
        if bad.size:
            raise ValueError(f"columns: column {i} of {len(cols)}: value {bad[0] + 1} is "
                             f"{c[bad[0]]} (every score must be a finite number)")  # fmt: skip
    return cols


def interval(
    columns: Sequence[np.ndarray],
    aggregate: Callable[[np.ndarray], float],
    reps: int = 2000,
    seed: int = 0,
) -> tuple[float, float, float]:
    """(point, low, high): ``aggregate`` of the pooled columns (one column of per-seed scores
    per stratum) with its 95 % percentile bootstrap interval, each column resampled on its own
    (stratified). A column of one value: (point, NaN, NaN), no interval (:func:`no_interval`).
    Bad input (:func:`checked_columns`): a ValueError naming the column."""
    cols = checked_columns(columns)
    point = aggregate(np.concatenate(cols))
    if any(c.size < 2 for c in cols):  # nothing to resample: no interval
        return point, math.nan, math.nan
    if all(np.ptp(c) == 0 for c in cols):  # nothing varies: the interval is the point
        return point, point, point
    rows = ROWS.get(aggregate)
    if rows is None:
        statistic = lambda *cs: aggregate(np.concatenate(cs))  # noqa: E731
    else:  # the same resamples as for one call each, so the same interval, 10 times faster
        statistic = lambda *cs, axis=-1: rows(np.concatenate(cs, axis=-1))  # noqa: E731
    res = stats.bootstrap(
        cols,
        statistic,
        n_resamples=reps,
        vectorized=rows is not None,
        paired=False,
        confidence_level=0.95,
        method="percentile",
        random_state=np.random.default_rng(seed),
    )
    return point, float(res.confidence_interval.low), float(res.confidence_interval.high)


def no_interval(v: tuple[float, float, float]) -> bool:
    """Whether an :func:`interval` has no bounds (a stratum of one value)."""
    return math.isnan(v[1]) or math.isnan(v[2])
