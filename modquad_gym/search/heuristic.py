"""What the heuristic searches share (centrosymmetric, greedy, random, beam, genetic).

* :func:`impossible_result`: the answer at once when the exact bounds rule out every size;
* :func:`heuristic_result`: a heuristic's answer with the lower bound the exact bounds prove
  (:func:`.bounds.bound_levels`), so it is certified when it meets it;
* :class:`Deadline`: the time limit, less a reserve for the final verification by the LP;
* :class:`Scores`: exact scores of candidate structures, cached up to translation.

A *candidate* is a translation-normalised tuple of ``((x, y), type index)`` pairs sorted by
cell (:func:`~modquad_gym.geometry.cells.normalise_typed` with palette indices): the one
encoding of the beam and the genetic search, for one type (every index 0) and palettes alike.
"""

from __future__ import annotations

from collections.abc import Iterable

import numpy as np

from modquad_gym.core.compile_clock import now
from modquad_gym.geometry.cells import Cell, normalise_typed, packed_key
from modquad_gym.geometry.structure import Structure
from modquad_gym.search.bounds import (
    NO_SIZE,
    bound_levels,
    first_possible_level,
    force_lower_bound,
)
from modquad_gym.search.problem import check_time_limit
from modquad_gym.search.result import SearchResult, SearchRun

Candidate = tuple[tuple[Cell, int], ...]


def impossible_result(run: SearchRun, limit: int) -> SearchResult | None:
    """The result at once when the force (or count) bound rules out every size up to n_max;
    else None, after refusing an n_max beyond ``limit`` (the method's reach)."""
    p = run.problem
    none_left = p.n_max + 1
    if p.shape_only:
        n_lb = force_lower_bound(p.wrenches, p.module, p.f_max, p.fault)
        if n_lb == NO_SIZE:
            proof = "force bound: no number of modules can exert the task's forces"
            return run.finish(None, none_left, proof=proof)
        if n_lb > p.n_max:
            return run.finish(None, none_left, proof=f"force bound: needs at least {n_lb} modules")
    else:
        n_lb, proof = first_possible_level(p)
        if proof:
            return run.finish(None, none_left, proof=proof)
    run.check_budget(limit, n_lb)
    return None


def heuristic_result(
    run: SearchRun, structure: Structure | None, bound: int | None = None
) -> SearchResult:
    """The result of a heuristic with the lower bound the exact bounds prove
    (:func:`.bounds.bound_levels`; ``bound``: the search's own call of it, not made twice)."""
    bound = bound_levels(run.problem) if bound is None else bound
    proof = ""
    if structure is None and bound > run.problem.n_max:
        proof = f"exact bounds rule out every level up to {run.problem.n_max}"
    return run.finish(structure, bound, proof=proof)


class Deadline:
    """``time_limit`` seconds (checked: (0, one day]) from the run's start, less a reserve
    (:meth:`~.problem.SearchProblem.verify_reserve`) for the final verification by the exact
    LP. With ``interrupt`` the run's fault decisions stop there too (a search that asks it
    catches :class:`~modquad_gym.oracle.faults.DecisionInterruptedError`). ``at`` is a time on
    the search clock (:func:`~modquad_gym.core.compile_clock.now`), which stands still while
    kernels compile: a cold cache changes no answer."""

    def __init__(self, run: SearchRun, time_limit: object, interrupt: bool = False) -> None:
        self.time_limit = check_time_limit(time_limit)
        reserve = run.problem.verify_reserve(self.time_limit)
        self.at = run.t0 + self.time_limit - reserve
        run.time_limit = self.time_limit  # the bound of an infeasible answer keeps it too
        if interrupt:
            run.checker.deadline, run.verify_deadline = self.at, run.t0 + self.time_limit

    def passed(self) -> bool:
        return now() >= self.at


def candidate(cells: Iterable[Cell], types: Iterable[int]) -> Candidate:
    """The candidate of cells and palette indices (translation-normalised, sorted by cell)."""
    return normalise_typed(cells, types)


class Scores:
    """Exact scores of candidates of one run, cached: ``(missed, share, tie)`` with ``missed``
    the task wrenches the structure cannot exert and ``share`` the fraction it can (exact
    decisions, :meth:`~modquad_gym.oracle.Zonotope.decide_certified`), and ``tie`` a cheap
    continuous tie-breaker: the mean over the wrenches of 1 - gamma_ls clipped to [-1, 1],
    gamma_ls the largest rotor deviation from half thrust (in units of f_max / 2) of the
    minimum-norm allocation. 1 - gamma_ls is a lower bound of the oracle's margin (1 - gamma,
    :func:`~modquad_gym.oracle.margin`, which takes an LP per wrench): larger when the
    structure carries the task with evenly loaded rotors, -1 off its range. Each new candidate
    counts as one configuration evaluated and ``t`` oracle calls; the cache keys are compact
    bytes (a 64-module candidate takes about 0.8 kB)."""

    def __init__(self, run: SearchRun) -> None:
        self.run = run
        self.problem = run.problem
        self.cache: dict[bytes, tuple[int, float, float]] = {}

    def structure(self, cand: Candidate) -> Structure:
        palette = self.problem.palette
        cells = tuple(c for c, _ in cand)
        if len(palette) == 1:
            return Structure.from_trusted(cells, palette[0])
        return Structure.from_trusted(cells, modules=tuple(palette[t] for _, t in cand))

    def score(self, cand: Candidate) -> tuple[int, float, float]:
        key = packed_key((c for c, _ in cand), (t for _, t in cand))
        if key not in self.cache:
            z, W, ok = self.run.decide(self.structure(cand))
            R, off = z.reduce(W)
            gamma = np.abs(R @ z.P.T).max(axis=1)
            tie = np.where(off, -1.0, np.clip(1.0 - gamma, -1.0, 1.0))
            self.cache[key] = (int(len(W) - ok.sum()), float(ok.mean()), float(tie.mean()))
        return self.cache[key]

    def feasible(self, cand: Candidate) -> bool:
        return self.score(cand)[0] == 0
