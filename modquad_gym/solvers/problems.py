"""What a solver was made with (budget, module types, fault) and the problem it is handed.

:func:`~modquad_gym.solvers.make_solver` checks these settings when the solver is made (as a
:class:`~modquad_gym.search.SearchProblem` checks them), and :func:`problem_for` makes the
problem of each task handed to ``solve``: a task becomes a problem with them; a problem is
used as it is, but one that says otherwise than a setting given to ``make_solver`` is refused,
as the search functions refuse ``n_max=`` beside a problem of another budget (both judge by
:func:`~modquad_gym.search.fields.says`), instead of one of the two being silently dropped.
"""

from __future__ import annotations

from typing import Any

from modquad_gym.core.validation import check_int
from modquad_gym.geometry.structure import Structure
from modquad_gym.oracle.failures import check_fault, check_fault_margin
from modquad_gym.search.fields import says
from modquad_gym.search.partial import check_size, make_partial
from modquad_gym.search.problem import DEFAULT_N_MAX, SearchProblem, as_problem, check_palette


def problem_settings(n_max: Any = DEFAULT_N_MAX, modules: Any = None, fault: Any = None,
                     fault_margin: Any = None) -> dict:  # fmt: skip
    """The settings checked (a ValueError naming the argument); ``n_max`` not given (the
    default, :data:`~modquad_gym.search.problem.DEFAULT_N_MAX`) stays told apart from a 7
    given, and ``fault_margin`` is kept only when given."""
    out: dict[str, Any] = {
        "n_max": n_max if n_max is DEFAULT_N_MAX else check_int(n_max, "n_max", low=1),
        "modules": None if modules is None else check_palette(None, modules),
        "fault": None if fault is None else check_fault(fault),
    }
    if fault_margin is not None:
        out["fault_margin"] = check_fault_margin(fault_margin, out["fault"])
    return out


def refuse_start(start: Any, settings: dict) -> None:
    """A search's ``start`` (well-formed: its option's check) against the settings given to
    :func:`~modquad_gym.solvers.make_solver`: more cells than the ``n_max`` given, or a module
    type outside the ``modules`` given, is refused when the solver is made, in the search's
    words (:func:`~modquad_gym.search.partial.make_partial`); against a setting not given, when
    a problem is solved (a SearchProblem handed to ``solve`` may say any)."""
    n_max = settings.get("n_max", DEFAULT_N_MAX)
    if n_max is not DEFAULT_N_MAX:
        check_size(start, n_max)
    if settings.get("modules") is not None:  # a typed problem: the types must be among them
        size = start.n_modules if isinstance(start, Structure) else len(start)
        make_partial(start, tuple(settings["modules"]), True, size)


def _names(types) -> str:
    return "[" + ", ".join(m.name for m in types) + "]"


def disagreement(problem: SearchProblem, settings: dict) -> tuple[str, str] | None:
    """(the setting given, what the problem says) for the first setting given (not None, not
    the default budget) that ``problem`` contradicts; None when it contradicts none."""
    n_max = settings.get("n_max", DEFAULT_N_MAX)
    if n_max is not DEFAULT_N_MAX and not says(problem, "n_max", n_max):
        return f"n_max={n_max}", f"n_max={problem.n_max}"
    modules = settings.get("modules")
    if modules is not None and not says(problem, "modules", modules):
        said = _names(problem.palette) if problem.typed else "None (one type)"
        return f"modules={_names(modules)}", f"modules={said}"
    fault = settings.get("fault")
    if fault is not None and not says(problem, "fault", fault):
        return f"fault={fault!r}", f"fault={problem.fault!r}"
    margin = settings.get("fault_margin")
    if margin is not None and not says(problem, "fault_margin", margin):
        return f"fault_margin={margin:g}", f"fault_margin={problem.fault_margin:g}"
    return None


def problem_for(task: Any, settings: dict) -> SearchProblem:
    """The problem of ``task`` for a solver made with ``settings`` (:func:`problem_settings`):
    ``task`` itself when it is a :class:`SearchProblem` that contradicts none of them (else a
    ValueError naming both values), else the problem of ``task`` with them."""
    if not isinstance(task, SearchProblem):
        return as_problem(task, **settings)
    clash = disagreement(task, settings)
    if clash is not None:
        raise ValueError(
            f"the solver was made with {clash[0]}, the SearchProblem it was given says "
            f"{clash[1]}: give it in one place (make_solver without it, or a problem that says "
            "the same)"
        )
    return task
