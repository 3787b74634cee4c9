"""What an agent benchmark run yields: one :class:`Row` per (method, task) and the per-method
summary over the goals' scope (:mod:`.agents` makes the rows, :mod:`.agents_report` writes them),
and what meets a goal (:func:`config_limit`, :func:`share_limit`; the goals are the tier's,
:attr:`.tiers.Tier.goals`)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass
class Row:
    """One method on one task; ``cells`` the answer's [x, y] each ([x, y, k] on a tier of several
    module types, k the index of the cell's type in the tier's palette), None without one."""

    suite: str
    task: str
    optimum: int | None
    method: str
    success: bool
    n_modules: int | None
    evaluated: int
    oracle_calls: int
    seconds: float
    cells: list | None

    @property
    def gap(self) -> int | None:
        if self.n_modules is None or self.optimum is None:
            return None
        return self.n_modules - self.optimum

    @property
    def optimal(self) -> bool:
        return self.success and self.gap == 0

    def as_csv(self) -> dict:
        return {
            "suite": self.suite, "task": self.task, "optimum": self.optimum,
            "method": self.method, "success": int(self.success), "n_modules": self.n_modules,
            "gap": self.gap, "optimal": int(self.optimal), "evaluated": self.evaluated,
            "oracle_calls": self.oracle_calls, "seconds": f"{self.seconds:.5f}",
            "cells": ";".join(",".join(map(str, c)) for c in self.cells) if self.cells else "",
        }  # fmt: skip


ANSWERS_ONLY = frozenset({"milp"})
"""Methods whose configurations evaluated count only the structures they hand the exact oracle
(milp: each answer of its mixed-integer program, usually one; the program's own work is not
a configuration): the agent report marks their count, and ranks the best other search by
seconds, not configurations."""


def summarise(rows: list[Row], methods: list[str], n_max: int) -> list[dict]:
    """Per method, over the tasks whose optimum is <= n_max (the goals' scope)."""
    out = []
    for m in methods:
        rs = [r for r in rows if r.method == m and r.optimum is not None and r.optimum <= n_max]
        if not rs:
            continue
        solved = [r for r in rs if r.success]
        out.append({
            "method": m,
            "tasks": len(rs),
            "success_rate": len(solved) / len(rs),
            "mean_modules": float(np.mean([r.n_modules for r in solved])) if solved else None,
            "optimal_share": sum(r.optimal for r in rs) / len(rs),
            "mean_gap": float(np.mean([r.gap for r in solved])) if solved else None,
            "mean_evaluated": float(np.mean([r.evaluated for r in rs])),
            "mean_oracle_calls": float(np.mean([r.oracle_calls for r in rs])),
            "mean_seconds": float(np.mean([r.seconds for r in rs])),
        })  # fmt: skip
    return out


def config_limit(goal: float | str | None, searches: dict[str, float]) -> tuple[float | None, str]:
    """(most configurations per task that meet ``goal``, the goal in words) given each search's
    configurations per task: ``goal`` a share of the exhaustive search's, a search's name (fewer
    than it), or None (fewer than every search but random and those of :data:`ANSWERS_ONLY`,
    whose count is not of the same kind); (None, why) when not decidable."""
    if isinstance(goal, float):
        if "exhaustive" not in searches:
            return None, "exhaustive not run"
        limit = goal * searches["exhaustive"]
        return limit, f"<= {100 * goal:.0f} % of exhaustive, {limit:.1f}"
    left_out = ("random", *sorted(ANSWERS_ONLY))
    rivals = {m: e for m, e in searches.items()
              if m == goal or (goal is None and m not in left_out)}  # fmt: skip
    if not rivals:
        return None, f"{goal or 'no search'} not run"
    best = min(rivals, key=rivals.get)
    less = rivals[best] - 1e-9  # strictly fewer
    return less, f"< {best}" + ("" if goal else f", the fewest but {' and '.join(left_out)}")


def share_limit(goal: float | str, shares: dict[str, float]) -> tuple[float | None, str]:
    """(least share that meets ``goal``, the goal in words) given each search's share of the
    metric: ``goal`` a share, or a search's name (at least its share); (None, why) when that
    search was not run."""
    if not isinstance(goal, str):
        return goal, f"{100 * goal:.0f} %"
    if goal not in shares:
        return None, f"{goal} not run"
    return shares[goal] - 1e-9, f">= {goal}'s {100 * shares[goal]:.1f} %"
