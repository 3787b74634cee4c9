"""What every search shares: reading the task, the result record, the final independent check."""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np

from ..module import ModuleType
from ..oracle import feasible
from ..structure import Key, Structure
from ..validation import check_f_max, check_int, check_wrenches
from .checker import TaskChecker

DEFAULT_MODULE = Structure([(0, 0)]).module


@dataclass
class SearchResult:
    """What a search found.

    Attributes:
        structure: the structure found (verified feasible), or None.
        n_modules: its module count, or None.
        evaluated: configurations evaluated (feasibility against the whole task decided).
        oracle_calls: wrench-structure membership tests made.
        seconds: wall time.
        certified: True when ``n_modules`` is proven minimal (exhaustive search), or when the
            search proved that no structure up to ``n_max`` modules is feasible.
        method: the search's name.
        n_max: the module budget searched.
        skipped_levels: module counts ruled out as a whole by exact bounds (force, level).
        proof: how infeasibility was proven without searching, when it was ("" otherwise).
    """

    structure: Structure | None
    n_modules: int | None
    evaluated: int
    oracle_calls: int
    seconds: float
    certified: bool
    method: str
    n_max: int
    skipped_levels: list[int] = field(default_factory=list)
    proof: str = ""

    @property
    def feasible(self) -> bool:
        return self.structure is not None

    def to_dict(self) -> dict:
        out = {
            "cells": [list(c) for c in self.structure.cells] if self.structure else None,
            "n_modules": self.n_modules,
            "evaluated": self.evaluated,
            "oracle_calls": self.oracle_calls,
            "feasible": self.feasible,
            "certified": self.certified,
            "seconds": self.seconds,
            "method": self.method,
            "n_max": self.n_max,
        }
        if self.proof:
            out["proof"] = self.proof
        return out


@dataclass
class Optima:
    """Every minimum-module structure of a task (:func:`~.exhaustive.optimal_level`).

    Attributes:
        n_modules: the certified minimum, or None when no structure up to n_max works.
        keys: every feasible structure of ``n_modules`` modules (cells up to translation), in
            canonical order.
        evaluated, oracle_calls, seconds: the work it took, as in :class:`SearchResult`.
        proof: how infeasibility was proven without searching, when it was ("" otherwise).
    """

    n_modules: int | None
    keys: list[Key]
    evaluated: int
    oracle_calls: int
    seconds: float
    proof: str = ""


class SearchRun:
    """One search in progress: the validated task, the module type, the shared checker and
    the clock. ``finish`` re-verifies the answer with the exact LP and builds the result."""

    def __init__(
        self,
        method: str,
        task,
        n_max: int,
        f_max: float | None,
        module: ModuleType | None,
        n_max_limit: int,
    ) -> None:
        self.t0 = time.perf_counter()
        self.method = method
        self.W, self.f_max = task_arrays(task, f_max)
        self.n_max = check_int(n_max, "n_max", low=1)
        self.module = module if module is not None else DEFAULT_MODULE
        self.n_max_limit = n_max_limit
        self.checker = TaskChecker(self.W, self.f_max, self.module)

    def check_budget(self, first_level: int) -> None:
        """Refuse before any work an n_max this method cannot reach in bounded time."""
        if self.n_max > self.n_max_limit and first_level <= self.n_max:
            raise ValueError(
                f"n_max={self.n_max} is beyond what the {self.method} search can finish: "
                f"at most {self.n_max_limit} modules (see `modquad solve --help`)"
            )

    def finish(
        self,
        structure: Structure | None,
        certified: bool,
        skipped: list[int] | tuple[int, ...] = (),
        proof: str = "",
    ) -> SearchResult:
        if (
            structure is not None
            and not feasible(
                structure.configuration_matrix(), self.W, self.f_max, method="daqp"
            ).all()
        ):
            raise RuntimeError(  # pragma: no cover - an oracle bug, never a silent success
                f"{self.method} search found {structure!r} but the exact LP rejects it"
            )
        return SearchResult(
            structure=structure,
            n_modules=structure.n_modules if structure is not None else None,
            evaluated=self.checker.evaluated,
            oracle_calls=self.checker.oracle_calls,
            seconds=time.perf_counter() - self.t0,
            certified=certified,
            method=self.method,
            n_max=self.n_max,
            skipped_levels=list(skipped),
            proof=proof,
        )


def task_arrays(task, f_max: float | None) -> tuple[np.ndarray, float]:
    """(W, f_max) from a (t, 6) array or anything with ``wrenches`` (and ``f_max``)."""
    if hasattr(task, "wrenches"):
        W = check_wrenches(task.wrenches, allow_empty=False)
        f = f_max if f_max is not None else getattr(task, "f_max", 1.0)
    else:
        W = check_wrenches(task, allow_empty=False)
        f = 1.0 if f_max is None else f_max
    return W, check_f_max(f)
