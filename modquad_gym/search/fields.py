"""The fields of a search problem given as keywords: the palette's check, and whether a keyword
says what a problem already says (a search handed a problem takes a keyword equal to the
problem's and refuses one that would change it; a solver's ``solve`` judges alike)."""

from __future__ import annotations

from collections.abc import Iterable, Sequence

from modquad_gym.core.validation import check_f_max, check_int
from modquad_gym.geometry.module import ModuleType, check_module
from modquad_gym.geometry.module import palette as read_palette
from modquad_gym.geometry.structure import Structure
from modquad_gym.oracle.failures import check_fault, check_fault_margin

DEFAULT_MODULE = Structure([(0, 0)]).module

MAX_TYPES = 127
"""Most module types in one palette (type indices are int8)."""


def check_palette(
    module: ModuleType | None, modules: Sequence[ModuleType] | None
) -> list[ModuleType]:
    """The module types of a search: ``[module]`` (default the T-module) or ``modules``, a list
    of ModuleType or what :func:`~modquad_gym.geometry.module.palette` reads (``"t45,flat"``,
    as ``--modules`` and the environments take). ValueError for both or neither being usable,
    a type given twice (one :attr:`~ModuleType.digest`: the same rotors, whatever its name, as
    ``--modules t45,t45`` is refused), or types of different sides or rotor counts."""
    if modules is None:
        return [DEFAULT_MODULE if module is None else check_module(module)]
    if module is not None:
        raise ValueError("give module= (one type) or modules= (a palette), not both")
    if isinstance(modules, ModuleType) or not isinstance(modules, Iterable):
        raise ValueError(
            "modules must be a list of ModuleType (see modquad_gym.geometry.module.palette)"
        )
    modules = list(modules) if not isinstance(modules, str) else read_palette(modules)
    if any(isinstance(m, str) for m in modules):
        modules = read_palette(modules)
    out: dict[str, ModuleType] = {}
    for i, m in enumerate(modules):
        if check_module(m, f"modules[{i}]").digest in out:
            first = out[m.digest].name
            same = "" if m.name == first else f" (as {m.name}: the same rotors)"
            raise ValueError(f"modules: {first} is listed twice{same}")
        out[m.digest] = m
    if not out:
        raise ValueError("modules: give at least one module type")
    palette = list(out.values())
    if len(palette) > MAX_TYPES:
        raise ValueError(f"modules: at most {MAX_TYPES} types, got {len(palette)}")
    if len({m.side for m in palette}) > 1:
        raise ValueError("modules: every type must have the same side (one docking grid)")
    if len({m.n_rotors for m in palette}) > 1:
        raise ValueError("modules: every type must have the same number of rotors")
    return palette


def says(problem, name: str, value: object) -> bool:
    """Whether ``problem`` (a :class:`~modquad_gym.search.SearchProblem`) already says
    ``name=value``: the value checked as the problem's own was, then compared (``modules`` by
    each type's rotors, in order; ``module`` only for a one-type problem). A value its check
    refuses says nothing (False)."""
    try:
        if name == "n_max":
            return check_int(value, "n_max", low=1) == problem.n_max
        if name == "f_max":
            return check_f_max(value) == problem.f_max
        if name in ("module", "modules"):
            mine = check_palette(value, None) if name == "module" else check_palette(None, value)
            theirs = [m.digest for m in problem.palette]
            return problem.typed == (name == "modules") and [m.digest for m in mine] == theirs
        if name == "kind":
            return value == problem.kind
        if name == "fault":
            return (None if value is None else check_fault(value)) == problem.fault
        if name == "fault_margin":
            return check_fault_margin(value, problem.fault) == problem.fault_margin
    except (TypeError, ValueError):
        return False
    raise ValueError(f"name: not a field of a SearchProblem, got {name!r}")
