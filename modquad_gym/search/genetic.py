"""A genetic algorithm over structure configurations, in the spirit of Su et al. ("Flight
Structure Optimization of Modular Reconfigurable UAVs", 2024), up to 128 modules.

* Encoding: a connected set of cells, each with a palette type (:data:`.heuristic.Candidate`).
* Population: ``population`` random connected structures (seeded), sizes uniform between the
  proved lower bound and ``n_max``, each grown one docking at a time with a random bias towards
  compact (cells with more occupied neighbours) or sprawling shapes.
* Fitness (smaller is better): the module count plus ``penalty`` times the share of task
  wrenches the structure cannot exert (exact decisions), plus a tie-breaker in [0, 0.1) from
  the mean clipped margin of the minimum-norm allocation (:class:`.heuristic.Scores`).
* Selection: ``elite`` best kept as they are; parents by tournaments of ``tournament``.
* Crossover (:mod:`.chromosomes`): the parents' cells aligned at their centres, cut by a random
  line through the centre, one side from each parent, then the largest connected piece.
* Mutations: dock a module at a free cell, remove a module whose removal keeps the structure
  connected, move one, or change one module's type.

It stops after ``generations`` generations, after ``stall`` generations without a better
fitness, at the time limit, or when the smallest feasible structure seen meets the proved lower
bound, and returns that structure (verified by the exact
LP) with the lower bound. A heuristic: certified only when it meets the bound. The same seed
gives the same answer on one machine (when the time limit does not cut it short).
"""

from __future__ import annotations

from contextlib import suppress

import numpy as np

from modquad_gym.core.validation import check_int, check_real
from modquad_gym.oracle.faults import DecisionInterruptedError
from modquad_gym.search.bounds import bound_levels
from modquad_gym.search.chromosomes import crossover, mutate, random_structure
from modquad_gym.search.heuristic import (
    Candidate,
    Deadline,
    Scores,
    heuristic_result,
    impossible_result,
)
from modquad_gym.search.options import count, non_negative, seeded_rng, share
from modquad_gym.search.problem import DEFAULT_TIME_LIMIT, MAX_MODULES, SearchProblem, search_entry
from modquad_gym.search.prune import pruned_search
from modquad_gym.search.result import SearchResult, SearchRun

DEFAULT_POPULATION = 24
DEFAULT_GENERATIONS = 1000
DEFAULT_STALL = 100
"""Generations without a better fitness in the population after which the search stops."""
DEFAULT_MUTATION_RATE = 0.9
DEFAULT_CROSSOVER_RATE = 0.5
DEFAULT_ELITE = 2
DEFAULT_TOURNAMENT = 3
MAX_POPULATION = 10_000
MAX_GENERATIONS = 10**7


class Fitness:
    """The fitness of candidates (module docstring) and the smallest feasible one seen."""

    def __init__(self, scores: Scores, penalty: float) -> None:
        self.scores = scores
        self.penalty = penalty
        self.best: Candidate | None = None

    def __call__(self, cand: Candidate) -> float:
        missed, share, tie = self.scores.score(cand)
        n = len(cand)
        if missed == 0 and (self.best is None or n < len(self.best)):
            self.best = cand
        return n + self.penalty * (1.0 - share) + 0.05 * (1.0 - tie)


def _options(population, generations, stall, mutation_rate, crossover_rate, elite, tournament,
             penalty):  # fmt: skip
    """The GA's settings, checked (a one-line ValueError naming the argument)."""
    pop = check_int(population, "population", low=2, high=MAX_POPULATION)
    return {
        "population": pop,
        "generations": check_int(generations, "generations", low=1, high=MAX_GENERATIONS),
        "stall": check_int(stall, "stall", low=1, high=MAX_GENERATIONS),
        "mutation_rate": check_real(mutation_rate, "mutation_rate", low=0.0, high=1.0),
        "crossover_rate": check_real(crossover_rate, "crossover_rate", low=0.0, high=1.0),
        "elite": check_int(elite, "elite", low=0, high=pop - 1),
        "tournament": check_int(tournament, "tournament", low=1, high=pop),
        "penalty": None if penalty is None else check_real(penalty, "penalty", low=0.0),
    }


@search_entry(
    "genetic",
    prune=pruned_search,
    options={
        "population": ("chromosomes per generation", count(2, MAX_POPULATION)),
        "generations": ("most generations", count(1, MAX_GENERATIONS)),
        "stall": ("generations without improvement before it stops", count(1, MAX_GENERATIONS)),
        "mutation_rate": ("probability of a mutation", share),
        "crossover_rate": ("probability of a crossover", share),
        "elite": ("best chromosomes kept unchanged (at most population - 1)", count(0)),
        "tournament": ("chromosomes per selection tournament (at most population)", count(1)),
        "penalty": ("fitness per unsatisfied wrench (None: the module budget)", non_negative),
    },
    relations=(("elite", "population", -1), ("tournament", "population", 0)),
)
def genetic_search(
    problem: SearchProblem,
    *,
    population: int = DEFAULT_POPULATION,
    generations: int = DEFAULT_GENERATIONS,
    stall: int = DEFAULT_STALL,
    mutation_rate: float = DEFAULT_MUTATION_RATE,
    crossover_rate: float = DEFAULT_CROSSOVER_RATE,
    elite: int = DEFAULT_ELITE,
    tournament: int = DEFAULT_TOURNAMENT,
    penalty: float | None = None,
    time_limit: float = DEFAULT_TIME_LIMIT,
    seed: int | None = 0,
) -> SearchResult:
    """The smallest feasible structure the GA sees for ``task`` (module docstring), or None,
    with the proved lower bound. ``penalty`` (default ``n_max``) weighs the share of wrenches
    missed against the module count; ``modules``, ``kind`` and ``f_max`` as for
    :func:`~.exhaustive.exhaustive_search`; ``seed`` seeds everything random."""
    run = SearchRun("genetic", problem)
    deadline = Deadline(run, time_limit, interrupt=True)
    opt = _options(population, generations, stall, mutation_rate, crossover_rate, elite,
                   tournament, penalty)  # fmt: skip
    rng = seeded_rng(seed)
    if (done := impossible_result(run, MAX_MODULES)) is not None:
        return done
    lower = bound_levels(problem)
    if lower > problem.n_max:  # the exact bounds rule out every level
        return heuristic_result(run, None, lower)
    scores = Scores(run)
    fitness = Fitness(scores, problem.n_max if opt["penalty"] is None else opt["penalty"])
    K, n_max = len(problem.palette), problem.n_max
    with suppress(DecisionInterruptedError):  # a cut fault decision scores nothing
        _evolve(fitness, rng, opt, K, lower, n_max, deadline)
    best = fitness.best
    return heuristic_result(run, None if best is None else scores.structure(best), lower)


def _evolve(fitness, rng, opt, K, lower, n_max, deadline) -> None:
    """The generations (their best in ``fitness.best``) until the deadline, a stall or the
    bound."""
    pop: list[Candidate] = []
    values: list = []
    for _ in range(opt["population"]):  # each scored as it is drawn: the clock between them
        if deadline.passed():
            return
        pop.append(random_structure(rng, int(rng.integers(lower, n_max + 1)), K))
        values.append(fitness(pop[-1]))
    record, since = min(values), 0
    for _ in range(opt["generations"]):
        if fitness.best is not None and len(fitness.best) <= lower or since >= opt["stall"]:
            return
        pop, values = _generation(pop, values, fitness, rng, opt, K, n_max, deadline)
        if deadline.passed():
            return
        since = 0 if min(values) < record else since + 1
        record = min(record, min(values))


def _generation(pop, values, fitness, rng, opt, K, n_max, deadline):
    """The next population: the elite, then children of tournament winners."""
    order = np.argsort(values, kind="stable")
    new = [pop[i] for i in order[: opt["elite"]]]
    new_values = [values[i] for i in order[: opt["elite"]]]

    def pick() -> Candidate:
        entrants = rng.integers(len(pop), size=opt["tournament"])
        return pop[min(entrants, key=lambda i: (values[i], i))]

    while len(new) < len(pop) and not deadline.passed():
        child = pick()
        if rng.random() < opt["crossover_rate"]:
            child = crossover(child, pick(), rng, n_max)
        if rng.random() < opt["mutation_rate"]:
            child = mutate(child, rng, K, n_max)
        new.append(child)
        new_values.append(fitness(child))
    return new, new_values
