"""One seed's scores per suite (a row of ``seeds.csv``) and the statistics over seeds that the
seeds report prints: each seed's score pooled over the tier's held-out tasks (the suites
weighted by their task counts, as the leaderboard counts it), then the IQM and the mean over
the seeds, each with its 95 % percentile bootstrap interval over the seeds."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from modquad_gym.scoring.scores import Row
from modquad_gym.scoring.stats import interval, iqm, mean, no_interval


@dataclass
class SeedScore:
    """One seed's model with one method on one suite."""

    seed: str
    method: str
    suite: str
    tasks: int
    success: float
    optimal: float
    evaluated: float
    seconds: float
    modules: float | None = None
    """Mean module count over the solved tasks (None when none was solved)."""

    @classmethod
    def from_record(cls, r: dict) -> SeedScore:
        """The score of one record of a ``seeds.csv`` (:func:`~.seeds_report.write_report`;
        older files have no ``modules``), to re-draw its report."""
        return cls(r["seed"], r["method"], r["suite"], int(r["tasks"]), float(r["success"]),
                   float(r["optimal"]), float(r["evaluated"]), float(r["seconds"]),
                   float(r["modules"]) if r.get("modules") else None)  # fmt: skip

    @classmethod
    def of(cls, seed: str, method: str, suite: str, rows: list[Row]) -> SeedScore:
        solved = [r.n_modules for r in rows if r.success]
        return cls(
            seed,
            method,
            suite,
            len(rows),
            float(np.mean([r.success for r in rows])),
            float(np.mean([r.optimal for r in rows])),
            float(np.mean([r.evaluated for r in rows])),
            float(np.mean([r.seconds for r in rows])),
            float(np.mean(solved)) if solved else None,
        )


def seed_order(label: str) -> tuple[int, str]:
    """Sort key of seed labels: 2 before 10."""
    return len(label), label


def per_seed(
    scores: list[SeedScore], metric: str, method: str, suite: str | None = None
) -> np.ndarray:
    """Each seed's ``metric`` with ``method`` (in seed order): its mean over the tasks of every
    suite (``suite``: of that one), the suites weighted by their task counts."""
    mine = [s for s in scores if s.method == method and suite in (None, s.suite)]
    out = []
    for seed in sorted({s.seed for s in mine}, key=seed_order):
        rs = [s for s in mine if s.seed == seed]
        out.append(np.average([getattr(s, metric) for s in rs], weights=[s.tasks for s in rs]))
    return np.array(out, dtype=float)


def summary(scores: list[SeedScore], metric: str, method: str, suite: str | None = None) -> dict:
    """The seed count, and the IQM and the mean over seeds of :func:`per_seed`, each with its
    95 % bootstrap interval over the seeds (NaN bounds for one seed)."""
    values = per_seed(scores, metric, method, suite)
    return {
        "seeds": len(values),
        "iqm": interval([values], iqm),
        "mean": interval([values], mean),
    }


def ci_text(v: tuple[float, float, float], pct: bool) -> str:
    """``point [low, high]`` (a share in %); ``point n/a (1 seed)`` without an interval."""
    f = (lambda x: f"{100 * x:.1f} %") if pct else (lambda x: f"{x:.1f}")
    if no_interval(v):
        return f"{f(v[0])} n/a (1 seed)"
    return f"{f(v[0])} [{f(v[1])}, {f(v[2])}]"
