"""The mixed-integer program an operations-research user would write, solved by HiGHS
(:func:`scipy.optimize.milp`): a peer of the searches and, through its LP relaxation, a bound.

For a module count n (and, with module types of different masses, the count of each mass
class, hence the total mass M) the program is linear (proofs: ``docs/search.md``, "The MILP
peer"):

* **Window**: binary ``z[c, t]`` (cell c holds a module of palette type t) over the cells
  ``(x, y)``, ``x, y >= 0``, ``x + y <= n - 1``: every n-cell polyomino has exactly one
  translate there with a cell in column 0 and a cell in row 0 (its bounding box w x h has
  w + h <= n + 1), and a structure's wrenches about its centre of mass do not change under
  translation, so the window loses no structure. ``sum z = n`` (per mass class), at most one
  type per cell, a cell of column 0 occupied, every occupied cell next to another (n > 1).
* **Connectivity**: a single-commodity flow from a root cell (binary ``y[c]``: one root, the
  first occupied cell of row 0) brings one unit to every other occupied cell along edges between
  occupied neighbours (capacity n - 1).
* **Wrenches**: per task wrench i, thrusts ``v[i, c, t, j]`` (units of f_max) with
  ``v <= hi z[c, t]`` and the wrench met: force rows ``sum_k d_k v_k = F_i``, torque rows
  ``sum_k (p_k x d_k + s_k c_tau d_k) v_k - c x F_i = tau_i`` with p_k the rotor positions in
  the window and ``c = sum m_t z[c, t] p_c / M`` the centre of mass: linear once M is fixed.
  ``external`` tasks add the weight M g to F_z; dynamic tasks give ``base_i + M s_i`` and,
  when their torques depend on the inertia about the centre of mass, ``P_i j``, with j linear
  in ``z`` and in products ``z[a] z[b]`` of two cells (exact McCormick rows for binaries).
* **Tolerance**: the rows are the oracle's rule (:mod:`modquad_gym.oracle.tolerance`: thrusts in
  [-TOL f_max / 2, (1 + TOL / 2) f_max], a wrench off the range of A by RESIDUAL_TOL) widened by
  :data:`~.milp_program.MARGIN` (and the thrusts' lower bound not tied to occupancy), so that
  HiGHS's own tolerances never cut off a structure the oracle accepts: the program holds every
  structure the exact oracle accepts. What it returns is decided again by the oracle; a rejected
  structure adds the wrenches it misses to the program (only the task's extreme wrenches enter
  at first: fewer wrench rows, a larger feasible set) or, when they are in it already, a cut
  excluding that one structure; then the program is solved again.

:func:`milp_search` decides levels upward from the proved lower bound: a level whose program is
infeasible is refuted (no structure of n modules works); the first level with a verified
structure is the optimum (certified). :func:`milp_lower_bound` rules levels out by the LP
relaxation (``z``, ``y`` in [0, 1]): it holds every point of the program, so when it is
infeasible no structure of n modules works. ``fault=`` is refused (the fault-tolerant program
needs a copy of every thrust per failure).
"""

from __future__ import annotations

from modquad_gym.core.compile_clock import now
from modquad_gym.geometry.structure import Structure
from modquad_gym.search import milp_worker
from modquad_gym.search.bounds import bound_levels
from modquad_gym.search.heuristic import Deadline, impossible_result
from modquad_gym.search.problem import (
    DEFAULT_TIME_LIMIT,
    MAX_MODULES,
    SearchProblem,
    search_entry,
)
from modquad_gym.search.result import SearchResult, SearchRun

MAX_ROUNDS = 200
"""Most candidates one level's program may return (each rejected one adds wrenches or a cut)
before the level is left undecided."""


def check_supported(problem: SearchProblem) -> None:
    """ValueError (one line, naming it) for what the program does not take."""
    if problem.fault is not None:
        raise ValueError(
            f"fault={problem.fault!r}: the milp search does not take fault= (the "
            "fault-tolerant program needs a copy of every thrust per failure); use another search"
        )


# ---------------------------------------------------------------------------- bound and search
def milp_lower_bound(
    problem: SearchProblem, n_max: int | None = None, *, start: int = 1, time_limit: float = 60.0
) -> int:
    """The first module count from ``start`` up to ``n_max`` (default the problem's) that the LP
    relaxation does not rule out, ``n_max + 1`` when it rules out every one. Proved: no
    structure of ``start`` up to that count minus one modules satisfies the task
    (docs/search.md); ``start`` must itself be a proved bound (default 1). A count whose
    relaxation is undecided within ``time_limit`` seconds (or too large to build) ends the
    scan there. Count vectors the exact count and level bounds exclude are skipped."""
    t0 = now()  # scipy's first import counts against the limit
    milp_worker.start()  # in the main thread: its boot overlaps scipy's import here
    from modquad_gym.search import milp_program as program  # scipy: on first use

    check_supported(problem)
    n_max = problem.n_max if n_max is None else n_max
    n = start
    while n <= n_max:
        left = time_limit - (now() - t0)
        if left <= 0 or program.relaxation_feasible(problem, n, left) is not False:
            return n
        n += 1
    return n


@search_entry("milp")
def milp_search(problem: SearchProblem, *, time_limit: float = DEFAULT_TIME_LIMIT) -> SearchResult:
    """The smallest structure for ``task`` by the mixed-integer program (module docstring),
    level by level from the proved lower bound (the exact bounds, then the LP relaxation):
    certified when it finishes within ``time_limit`` seconds, else no structure and the first
    level it did not refute as the proved bound. The limit holds even where HiGHS overruns its
    own, and a Ctrl-C or SIGTERM ends it at once: in the main thread (elsewhere, a program of more
    than :data:`~.milp_program.IN_PROCESS_NONZEROS` nonzeros) HiGHS runs in a worker process
    killed :data:`~.milp_worker.GRACE` (0.5) s past the deadline or at an interrupt (its first
    start, about 0.5 s, and scipy's first import count against the limit). Up to
    :data:`MAX_MODULES` modules; the task's arguments as for
    :func:`~.exhaustive.exhaustive_search`; ``fault=`` is refused."""
    check_supported(problem)
    run = SearchRun("milp", problem)
    deadline = Deadline(run, time_limit)
    if (done := impossible_result(run, MAX_MODULES)) is not None:
        return done
    lower = bound_levels(problem)
    if lower > problem.n_max:
        return run.finish(None, lower, proof=f"exact bounds rule out every level up to {lower - 1}")
    left = deadline.at - now()
    lower = milp_lower_bound(problem, start=lower, time_limit=left)
    if lower > problem.n_max:
        proof = f"LP relaxation rules out every level up to {problem.n_max}"
        return run.finish(None, lower, proof=proof)
    n = lower
    while n <= problem.n_max:
        outcome = decide_level(run, n, deadline)
        if isinstance(outcome, Structure):
            return run.finish(outcome, n)
        if outcome is None:  # undecided: every level below n is refuted
            break
        n += 1
    return run.finish(None, n)


def decide_level(run: SearchRun, n: int, deadline: Deadline) -> Structure | bool | None:
    """A structure of level n the exact oracle accepts, False when the program proves that
    none exists, None when undecided (the deadline, a program too large, too many rounds)."""
    from modquad_gym.search import milp_program as program  # scipy: on first use

    problem = run.problem
    for group in program.level_groups(problem, n):
        demand = program.Demand.of(problem, group.mass)
        prog = program.LevelProgram(problem, n, group, demand, rows=demand.extreme_rows())
        for _ in range(MAX_ROUNDS):
            left = deadline.at - now()
            if left <= 0 or prog.nonzeros(len(prog.rows)) > program.MAX_NONZEROS:
                return None
            res = prog.solve(relax=False, seconds=left)
            if res.status == program.INFEASIBLE:
                break  # this group is refuted
            if res.status != 0 or res.x is None:
                return None
            cells, types = prog.occupied(res.x)
            s = prog.structure(cells, types)
            if s is None:
                prog.cuts.append(cells)
                continue
            _, _, ok = run.decide(s)
            if ok.all():
                return s
            missed = set(demand.of_sample[~ok].tolist()) - set(prog.rows)
            if missed:
                prog.rows.extend(sorted(missed))
            else:
                prog.cuts.append(cells)
        else:
            return None
    return False
