"""The anytime search's incumbent producers: the field's heuristics (and whatever a caller adds,
e.g. the learned designer) turned loose on the task with the time left, feeding one incumbent.

A producer is a search entry of this package (``beam_search``, ...) or any picklable callable
``producer(problem, time_limit=..., seed=...)`` returning a :class:`~.result.SearchResult` or
None (it does not apply to this problem). Without workers they run one after the other in this
process once the local moves have stopped short of the bound (:func:`run_in_turn`); with an
engine that has Ray workers (``modquad solve --workers N``) they run as Ray tasks from the
start, beside the exact levels and the local moves, ``N - 1`` at a time (this process is the
N-th), and each result is offered to the incumbent as soon as it arrives (:class:`Producers`).
Either way the smallest verified structure is the answer and the bound is the proved one; with
workers the answer depends on timing, as any anytime answer does (a worker's own kernel
compilation, on a cold cache, stops its producer's clock but not this process's wait).
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from typing import Any

from modquad_gym.core.compile_clock import now
from modquad_gym.core.flight import launch
from modquad_gym.core.notes import note
from modquad_gym.search.baselines import greedy_search
from modquad_gym.search.beam import beam_search
from modquad_gym.search.genetic import genetic_search
from modquad_gym.search.problem import SearchProblem
from modquad_gym.search.result import SearchResult, SearchRun

HEURISTICS = (beam_search, genetic_search, greedy_search)
"""The producers of every anytime search, in the order they run."""

MIN_SECONDS = 1.0
"""A producer starts only with at least this many seconds left."""

POLL_SECONDS = 0.2
"""How often the exact levels and the local moves look for producers' results."""


def run_producer(
    producer: Any, problem: SearchProblem, time_limit: float, seed: int | None
) -> SearchResult | None:
    """``producer`` on ``problem`` for at most ``time_limit`` seconds (seeded where it takes a
    seed)."""
    options = getattr(producer, "options", None)
    if options is None:  # a caller's callable
        return producer(problem, time_limit=time_limit, seed=seed)
    kwargs: dict[str, Any] = {"time_limit": time_limit}
    if "seed" in options:
        kwargs["seed"] = seed
    return producer.solve(problem, **kwargs)


def produce(item: tuple) -> tuple[str, Any, int, int] | None:
    """One Ray task: ``(producer, problem, deadline, seed)`` run until ``deadline`` (wall-clock
    seconds, :func:`time.time`) -> (method, structure or None, evaluated, oracle calls); None
    when less than :data:`MIN_SECONDS` was left when it started or it does not apply."""
    producer, problem, deadline, seed = item
    left = deadline - time.time()
    if left < MIN_SECONDS:
        return None
    r = run_producer(producer, problem, left, seed)
    if r is None:
        return None
    return r.method, r.structure, r.evaluated, r.oracle_calls


def run_in_turn(
    run: SearchRun,
    producers: Sequence[Any],
    offer: Callable[[Any, str], None],
    settled: Callable[[], bool],
    deadline: float,
    seed: int | None,
) -> None:
    """Each producer in this process with the time left before ``deadline`` (on the search
    clock, :func:`~modquad_gym.core.compile_clock.now`), until ``settled()`` (the incumbent
    meets the bound); each structure found is offered as ``offer(structure, method)``; their
    work is counted as the run's."""
    for producer in producers:
        left = deadline - now()
        if left < MIN_SECONDS or settled():
            return
        r = run_producer(producer, run.problem, left, seed)
        if r is not None:
            _count(run, r.evaluated, r.oracle_calls)
            if r.structure is not None:
                offer(r.structure, r.method)


class Producers:
    """The producers as Ray tasks on ``engine`` (module docstring); use it as a context manager
    (what still runs at its end is cancelled)."""

    def __init__(
        self,
        run: SearchRun,
        engine: Any,
        producers: Sequence[Any],
        offer: Callable[[Any, str], None],
        deadline: float,
        seed: int | None,
    ) -> None:
        self.run = run
        self.offer = offer
        wall = time.time() + (deadline - now())
        items = [(p, run.problem, wall, seed) for p in producers]
        slots = max(1, int(engine.workers or engine.cluster_cpus()) - 1)
        self.flight = launch(engine, produce, items, in_flight=slots)
        self._next_poll = 0.0

    def poll(self, timeout: float = 0.0) -> None:
        """Offer what the producers finished (waiting up to ``timeout`` seconds for one); at
        most every :data:`POLL_SECONDS` when ``timeout`` is 0."""
        polled = time.perf_counter()
        if timeout <= 0 and polled < self._next_poll:
            return
        self._next_poll = polled + POLL_SECONDS
        for _, out in self.flight.ready(timeout):
            if out is None:
                continue
            if not isinstance(out, tuple):  # a Failed record: say so, the search goes on
                note(f"modquad: note: an incumbent producer failed: {out.error}", __name__)
                continue
            method, structure, evaluated, oracle_calls = out
            _count(self.run, evaluated, oracle_calls)
            if structure is not None:
                self.offer(structure, method)

    def wait(self, settled: Callable[[], bool], deadline: float) -> None:
        """Offer results as they come until every producer finished, ``settled()`` or
        ``deadline`` (on the search clock)."""
        self.poll(timeout=1e-3)
        while not self.flight.done and not settled():
            left = deadline - now()
            if left <= 0:
                return
            self.poll(timeout=min(left, 1.0))

    def __enter__(self) -> Producers:
        return self

    def __exit__(self, *exc: object) -> None:
        self.flight.close()


def _count(run: SearchRun, evaluated: int, oracle_calls: int) -> None:
    run.checker.evaluated += evaluated
    run.checker.oracle_calls += oracle_calls
