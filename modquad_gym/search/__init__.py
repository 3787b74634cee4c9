"""Searches for the smallest structure whose feasible wrenches contain a task (paper Sec. V).

* :mod:`.problem`: :class:`SearchProblem`, the validated arguments every search shares;
* :mod:`.exhaustive`: the certified exhaustive search and the whole minimal level;
* :mod:`.anytime`: the default search, to 128 modules within a time limit: an incumbent improved
  by local moves (:mod:`.moves`) and a proved lower bound, certified when they meet; its
  progress line (:mod:`.progress`);
* :mod:`.typed`: its pairs of shapes and type assignments (several types, or self-weight);
* :mod:`.levels`: the size of each level and its progress bar;
* :mod:`.centrosymmetric`: the paper's heuristic (Algorithm 2), bounded by time and memory;
* :mod:`.baselines`: greedy and random; :mod:`.beam` and :mod:`.genetic` (operators in
  :mod:`.chromosomes`): the field's heuristics at scale; :mod:`.heuristic`: what they share;
* :mod:`.bounds`: exact lower bounds (force, count, level) that rule out whole levels;
* :mod:`.partial`: searching only the structures that contain a partial one (``start=``);
* :mod:`.checker` and :mod:`.supports`: deciding a task against many structures.

Every returned structure is re-verified by the exact DAQP LP oracle, independently of the path
that found it. Counts follow the paper: ``evaluated`` is the number of configurations whose
feasibility against the task was decided; ``oracle_calls`` the number of wrench-structure tests
(a rejection by a cached separating direction counts as one). Every result carries a proved
``lower_bound`` on the module count and is ``certified`` when its answer meets it
(:mod:`.result`). This package never imports Ray: a caller that wants a level split over
workers passes an engine (:class:`modquad_gym.core.distributed.Engine`).
"""

from modquad_gym.search.anytime import anytime_search
from modquad_gym.search.baselines import greedy_search, random_search
from modquad_gym.search.beam import beam_search
from modquad_gym.search.bounds import bound_levels, force_lower_bound, level_bounds
from modquad_gym.search.centrosymmetric import centrosymmetric_search
from modquad_gym.search.checker import TaskChecker
from modquad_gym.search.exhaustive import (
    exhaustive_search,
    optimal_level,
    optimal_structures,
    scan_chunks,
)
from modquad_gym.search.genetic import genetic_search
from modquad_gym.search.levels import Optima
from modquad_gym.search.milp import milp_search
from modquad_gym.search.problem import SearchProblem
from modquad_gym.search.result import SearchResult, Status, verified

SEARCHES = {
    "exhaustive": exhaustive_search,
    "centrosymmetric": centrosymmetric_search,
    "greedy": greedy_search,
    "random": random_search,
    "anytime": anytime_search,
    "beam": beam_search,
    "genetic": genetic_search,
    "milp": milp_search,
}
"""The searches by name (the CLI's ``--method``)."""

__all__ = [
    "SEARCHES",
    "Optima",
    "SearchProblem",
    "SearchResult",
    "Status",
    "TaskChecker",
    "anytime_search",
    "beam_search",
    "bound_levels",
    "centrosymmetric_search",
    "exhaustive_search",
    "force_lower_bound",
    "genetic_search",
    "greedy_search",
    "level_bounds",
    "optimal_level",
    "optimal_structures",
    "random_search",
    "scan_chunks",
    "verified",
]
