"""One interface for every way of answering a task: the registered methods and outside agents.

A :class:`Solver` maps a :class:`~modquad_gym.search.SearchProblem` (or a task, made into one
with the solver's budget, palette and fault) to a :class:`~modquad_gym.search.SearchResult`
(structure, module count, status, configurations evaluated, oracle calls, seconds, ...), so
the command line, the benchmark and the tests treat all methods alike.

* :mod:`.factory`: :func:`make_solver`, the one factory, reading
  :data:`modquad_gym.methods.REGISTRY`, and the solvers of the searches and learned methods;
* :mod:`.outside`: someone else's agent (``package.module:Name``), the problem it is handed and
  the counted :class:`Evaluator` it decides structures with;
* :mod:`.answers`: an agent's answer rebuilt as plain data (integer cells, the tier's own
  types) and the deep copy of each task it is handed.
"""

from modquad_gym.solvers.factory import (
    LEARNED,
    METHOD_HELP,
    METHODS,
    LearnedSolver,
    MethodSolver,
    SearchSolver,
    Solver,
    guided_options,
    learned_options,
    make_solver,
)
from modquad_gym.solvers.outside import (
    Evaluator,
    ExternalSolver,
    admissible,
    conform,
    load_solver,
)

__all__ = [
    "LEARNED",
    "METHODS",
    "METHOD_HELP",
    "Evaluator",
    "ExternalSolver",
    "LearnedSolver",
    "MethodSolver",
    "SearchSolver",
    "Solver",
    "admissible",
    "conform",
    "guided_options",
    "learned_options",
    "load_solver",
    "make_solver",
]
