"""What every search shares: reading the task, the result record, the final independent check."""

from __future__ import annotations

import math
import time
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from modquad_gym.core.validation import check_f_max, check_int, check_wrenches
from modquad_gym.geometry.module import ModuleType
from modquad_gym.geometry.structure import Key, Structure
from modquad_gym.oracle import check_task_scale, feasible
from modquad_gym.search.bounds import NO_SIZE, count_vectors, counts_possible, level_excluded
from modquad_gym.search.checker import TaskChecker
from modquad_gym.tasks import check_kind, rotor_wrenches

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
        palette: names of the module types searched when the search was given ``modules``
            (then ``to_dict`` lists each module's type); empty for a one-type search.
        kind: the task kind searched (``total`` or ``external``).
        skipped: (shape, type assignment) pairs ruled out by exact bounds without being
            evaluated (force and count bounds, level bounds), in the levels visited.
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
    palette: tuple[str, ...] = ()
    kind: str = "total"
    skipped: int = 0

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
        if self.palette:
            out["modules"] = (
                [m.name for m in self.structure.modules] if self.structure is not None else None
            )
        if self.kind != "total":
            out["kind"] = self.kind
        if self.proof:
            out["proof"] = self.proof
        return out


@dataclass
class Optima:
    """Every minimum-module structure of a task (:func:`~.exhaustive.optimal_level`).

    Attributes:
        n_modules: the certified minimum, or None when no structure up to n_max works.
        keys: every feasible structure of ``n_modules`` modules (cells up to translation), in
            canonical order (the first ``max_keys`` of them when that is given).
        evaluated, oracle_calls, seconds: the work it took, as in :class:`SearchResult`.
        proof: how infeasibility was proven without searching, when it was ("" otherwise).
        count: how many feasible structures the level holds (``len(keys)`` unless capped).
    """

    n_modules: int | None
    keys: list[Key]
    evaluated: int
    oracle_calls: int
    seconds: float
    proof: str = ""
    count: int = -1

    def __post_init__(self) -> None:
        if self.count < 0:
            self.count = len(self.keys)


class KeptKeys(list):
    """The first ``limit`` keys added (all when None) and how many were added (``total``):
    memory stays bounded when a level holds millions of feasible structures."""

    def __init__(self, limit: int | None = None) -> None:
        super().__init__()
        self.limit = limit
        self.total = 0

    def add(self, key: Key) -> None:
        self.total += 1
        if self.limit is None or len(self) < self.limit:
            self.append(key)


class SearchRun:
    """One search in progress: the validated task and kind, the module types, the shared
    checker and the clock. ``finish`` re-verifies the answer with the exact LP and builds the
    result.

    ``modules`` (a list of types, deduplicated by :attr:`ModuleType.digest`, first kept)
    searches over type assignments; ``module`` is the one-type search. ``kind`` overrides the
    task's own kind (a plain wrench array is ``total`` unless told)."""

    def __init__(
        self,
        method: str,
        task,
        n_max: int,
        f_max: float | None,
        module: ModuleType | None,
        n_max_limit: int,
        modules: Sequence[ModuleType] | None = None,
        kind: str | None = None,
    ) -> None:
        self.t0 = time.perf_counter()
        self.method = method
        self.W, self.f_max = task_arrays(task, f_max)
        check_task_scale(self.W, self.f_max)  # absurd values: one clear error, no overflow later
        self.kind = check_kind(kind if kind is not None else getattr(task, "kind", "total"))
        self.n_max = check_int(n_max, "n_max", low=1)
        self.palette = check_palette(module, modules)
        self.typed = modules is not None
        self.module = self.palette[0]
        self.n_max_limit = n_max_limit
        self.skipped = 0
        self.checker = TaskChecker(self.W, self.f_max, self.palette, self.kind)

    @property
    def homogeneous_total(self) -> bool:
        """One module type and a ``total`` task: the paper's search, unchanged."""
        return len(self.palette) == 1 and self.kind == "total"

    def rotor_wrenches(self, structure: Structure) -> np.ndarray:
        """What the rotors of ``structure`` must produce for the task."""
        return rotor_wrenches(self.W, self.kind, structure.mass)

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
                structure.configuration_matrix(),
                self.rotor_wrenches(structure),
                self.f_max,
                method="daqp",
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
            palette=tuple(m.name for m in self.palette) if self.typed else (),
            kind=self.kind,
            skipped=self.skipped,
        )


def check_palette(
    module: ModuleType | None, modules: Sequence[ModuleType] | None
) -> list[ModuleType]:
    """The module types of a search: ``[module]`` (default the T-module) or ``modules``
    without repeats (types with one :attr:`~ModuleType.digest` are one type; the first is
    kept). ValueError for both or neither being usable, or types of different sides."""
    if modules is None:
        if module is not None and not isinstance(module, ModuleType):
            raise ValueError(f"module must be a ModuleType, got {type(module).__name__}")
        return [module if module is not None else DEFAULT_MODULE]
    if module is not None:
        raise ValueError("give module= (one type) or modules= (a palette), not both")
    if isinstance(modules, (str, ModuleType)) or not isinstance(modules, Iterable):
        raise ValueError(
            "modules must be a list of ModuleType (see modquad_gym.geometry.module.palette)"
        )
    out: dict[str, ModuleType] = {}
    for i, m in enumerate(modules):
        if not isinstance(m, ModuleType):
            raise ValueError(f"modules[{i}] must be a ModuleType, got {type(m).__name__}")
        out.setdefault(m.digest, m)
    if not out:
        raise ValueError("modules: give at least one module type")
    palette = list(out.values())
    if len(palette) > 127:
        raise ValueError(f"modules: at most 127 types, got {len(palette)}")
    if len({m.side for m in palette}) > 1:
        raise ValueError("modules: every type must have the same side (one docking grid)")
    if len({m.n_rotors for m in palette}) > 1:
        raise ValueError("modules: every type must have the same number of rotors")
    return palette


def task_arrays(task, f_max: float | None) -> tuple[np.ndarray, float]:
    """(W, f_max) from a (t, 6) array or anything with ``wrenches`` (and ``f_max``)."""
    if hasattr(task, "wrenches"):
        W = check_wrenches(task.wrenches, allow_empty=False)
        f = f_max if f_max is not None else getattr(task, "f_max", 1.0)
    else:
        W = check_wrenches(task, allow_empty=False)
        f = 1.0 if f_max is None else f_max
    return W, check_f_max(f)


def allowed_counts(run: SearchRun, n: int) -> tuple[np.ndarray, int]:
    """(allowed, pairs skipped) for level n of a typed search: a bool array indexed by count
    vectors (one axis of length n + 1 per palette type) of the counts that the count bound and,
    for one type alone, the level bound leave; and how many (shape, assignment) pairs the
    others hold (fixed polyominoes of n cells times the multinomial of each count vector)."""
    from modquad_gym.geometry.polyominoes import A001168

    K = len(run.palette)
    counts = count_vectors(n, K)
    ok = counts_possible(run.W, run.palette, counts, run.f_max, run.kind)
    for i, c in enumerate(counts):
        if ok[i] and int(c.max()) == n:  # one type alone: the level bounds apply
            m = run.palette[int(np.argmax(c))]
            Wn = rotor_wrenches(run.W, run.kind, n * m.mass)
            if level_excluded(Wn, run.f_max, m, n):
                ok[i] = False
    allowed = np.zeros((n + 1,) * K, dtype=bool)
    allowed[tuple(counts.T)] = ok
    shapes = A001168[n - 1] if n <= len(A001168) else 0
    skipped = shapes * sum(_multinomial(c) for c, good in zip(counts, ok) if not good)
    return allowed, skipped


def first_possible_level(run: SearchRun) -> tuple[int, str]:
    """(the smallest module count the count bound leaves, "") or (NO_SIZE, proof) when it
    rules out every count up to n_max."""
    for n in range(1, run.n_max + 1):
        if counts_possible(
            run.W, run.palette, count_vectors(n, len(run.palette)), run.f_max, run.kind
        ).any():
            return n, ""
    lift = " and lift its own weight" if run.kind == "external" else ""
    return (
        NO_SIZE,
        f"count bound: no mix of up to {run.n_max} modules can exert the task's forces{lift}",
    )


def _multinomial(c: np.ndarray) -> int:
    out, total = 1, 0
    for k in c:
        total += int(k)
        out *= math.comb(total, int(k))
    return out


def verified(structure: Structure | None, task: Any) -> bool:
    """Does ``structure`` exert every wrench of ``task`` (a TaskRequirement; its own weight
    added for external tasks)? Decided by the exact DAQP LP oracle."""
    if structure is None:
        return False
    W = rotor_wrenches(task.wrenches, task.kind, structure.mass)
    return bool(feasible(structure.configuration_matrix(), W, task.f_max, method="daqp").all())
