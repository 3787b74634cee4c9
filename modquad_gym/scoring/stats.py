"""The statistics of the reports over seeds, as rliable defines them (Agarwal et al. 2021): the
interquartile mean and its stratified percentile-bootstrap interval."""

from __future__ import annotations

from collections.abc import Callable, Sequence

import numpy as np
from scipy import stats


def iqm(scores: np.ndarray) -> float:
    """Interquartile mean: the mean of the middle 50 % (25 % trimmed at each end)."""
    return float(stats.trim_mean(np.ravel(scores), 0.25))


def interval(
    columns: Sequence[np.ndarray],
    aggregate: Callable[[np.ndarray], float],
    reps: int = 2000,
    seed: int = 0,
) -> tuple[float, float, float]:
    """(point, low, high): ``aggregate`` of the pooled columns (one column of per-seed scores
    per suite) with its 95 % percentile bootstrap interval, each column resampled on its own
    (stratified by suite)."""
    cols = [np.asarray(c, dtype=float) for c in columns]
    point = aggregate(np.concatenate(cols))
    if all(np.ptp(c) == 0 for c in cols):  # nothing varies: the interval is the point
        return point, point, point
    res = stats.bootstrap(
        cols,
        lambda *cs: aggregate(np.concatenate(cs)),
        n_resamples=reps,
        vectorized=False,
        paired=False,
        confidence_level=0.95,
        method="percentile",
        random_state=np.random.default_rng(seed),
    )
    return point, float(res.confidence_interval.low), float(res.confidence_interval.high)
