"""Dropping the modules an answer does not need: the post-pass of a constructive method.

A constructive method (greedy, beam, the learned single pass and its guided search) docks one
module at a time and never takes one back, so a module docked early can be redundant once
later ones are in (a torque-heavy task: an early module near the centre, later ones on long
arms). :func:`prune` removes such modules one at a time; :func:`pruned` applies it to a
method's result. A method takes it with ``prune=True`` (``--option prune=true``); it is off by
default, so every method's own answer stays what it was.
"""

from __future__ import annotations

import dataclasses
import inspect
from collections.abc import Callable

from modquad_gym.core.compile_clock import compile_seconds, now
from modquad_gym.geometry.structure import Structure
from modquad_gym.search.moves import removable
from modquad_gym.search.options import PRUNE_HELP  # noqa: F401 (its help, kept here)
from modquad_gym.search.problem import SearchProblem
from modquad_gym.search.result import SearchResult, SearchRun


def prune(
    run: SearchRun, structure: Structure, passed: Callable[[], bool], keep: frozenset = frozenset()
) -> Structure:
    """``structure`` less the modules it does not need: repeatedly the first module, in cell
    order, whose removal leaves the others connected and the problem satisfied (the run's
    exact decision, with its fault if any), until no removal does or ``passed()``; the modules
    at the cells ``keep`` (a search's ``start``) stay. Each structure tried counts as one
    evaluated configuration of ``run``."""
    cells, types = structure.cells, structure.modules
    while len(cells) > 1 and not passed():
        for i in (i for i in removable(cells) if cells[i] not in keep):
            smaller = Structure.from_trusted(cells[:i] + cells[i + 1 :],
                                             modules=types[:i] + types[i + 1 :])  # fmt: skip
            if run.decide(smaller)[2].all():
                cells, types = smaller.cells, smaller.modules
                break
            if passed():
                break
        else:
            break
    if len(cells) == structure.n_modules:
        return structure
    return Structure.from_trusted(cells, modules=types)


def pruned(
    result: SearchResult, problem: SearchProblem, time_limit: float | None, start=None
) -> SearchResult:
    """``result`` with its structure pruned (:func:`prune`; the modules of the search's
    ``start``, a Structure or cells, stay) for ``problem``, within what is left of
    ``time_limit`` seconds (None: no limit) after the method's own ``result.seconds``;
    the smaller structure verified by the exact LP as every answer is (should it fail there,
    the method's own answer stands). Counts and seconds add up; the lower bound is the
    method's, so the answer is certified when the pruned count meets it."""
    if result.structure is None or result.certified:
        return result
    keep = frozenset(tuple(c) for c in getattr(start, "cells", start or ()))
    run = SearchRun(result.method, problem)  # its clock leaves out compilation, as the method's
    deadline = run.t0 + time_limit - result.seconds if time_limit is not None else float("inf")
    smaller = prune(run, result.structure, lambda: now() >= deadline, keep)
    found = result.structure
    if smaller is not result.structure:
        found = run.finish(smaller, result.lower_bound).structure or result.structure
    return dataclasses.replace(
        result,
        structure=found,
        n_modules=found.n_modules,
        evaluated=result.evaluated + run.checker.evaluated,
        oracle_calls=result.oracle_calls + run.checker.oracle_calls,
        seconds=result.seconds + now() - run.t0,
        compile_seconds=result.compile_seconds + compile_seconds() - run.compiled,
        certified=found.n_modules == result.lower_bound,
    )


def pruned_search(solve: Callable, problem: SearchProblem, options: dict) -> SearchResult:
    """``solve(problem, **options)`` (a search's, :func:`~.problem.search_entry`), its answer
    :func:`pruned` within the search's time limit, the modules of its ``start`` kept."""
    start = options.get("start")
    if start is not None and not isinstance(start, Structure):
        options["start"] = start = list(start)  # read once: the search and the post-pass
    limit = options.get("time_limit", inspect.signature(solve).parameters["time_limit"].default)
    return pruned(solve(problem, **options), problem, limit, start)
