"""What an outside agent hands in and gets, read as plain data.

The scorer never trusts the objects an agent returns: an answer is rebuilt from the integer
cells and module types its :class:`~modquad_gym.geometry.Structure` holds (read through the
base class, so a subclass that claims another module count or matrix changes nothing) on the
scorer's own palette, before the budget check, the verification and the count. The problem an
agent is handed is a deep copy under a neutral name (:func:`handed`): an agent that edits it
edits its own copy, never the task the scorer verifies with.
"""

from __future__ import annotations

import copy
import math
import numbers
from typing import Any

import numpy as np

from modquad_gym.geometry.module import ModuleType
from modquad_gym.geometry.structure import Structure
from modquad_gym.search.problem import SearchProblem

_CELLS = Structure.cells  # the slots' own descriptors: a subclass's properties are not read
_MODULE = Structure.module
_MIXED = Structure._mixed
_DIGEST = ModuleType.digest.fget


class NotAllowedError(ValueError):
    """An answer beyond the budget or of a module type not allowed: a failure, not an error."""


def _allowed(module: Any, palette: list, index: dict[str, int]) -> ModuleType:
    """The palette's own type that ``module`` names (the same object, or one whose rotor data,
    side, drag ratio and mass hash alike); NotAllowedError naming it otherwise."""
    for m in palette:
        if m is module:
            return m
    try:
        k = index.get(_DIGEST(module)) if isinstance(module, ModuleType) else None
    except (TypeError, ValueError, AttributeError):
        k = None
    if k is None:
        names = ", ".join(m.name for m in palette)
        raise NotAllowedError(f"module type {getattr(module, 'name', module)!r} is not allowed "
                         f"here (types: {names})")  # fmt: skip
    return palette[k]


def rebuilt(answer: Any, palette: list) -> Structure:
    """``answer`` (a Structure, or a list of (x, y) cells of ``palette[0]``) as a plain
    :class:`Structure` of integer cells and ``palette``'s own types. Its cells and types are read
    from the base class's fields, never through the answer's own methods or properties.
    NotAllowedError for a type off ``palette``; ValueError for cells that are not a structure."""
    index = {_DIGEST(m): k for k, m in enumerate(palette)}
    if not isinstance(answer, Structure):
        cells = answer.tolist() if isinstance(answer, np.ndarray) else list(answer)
        return Structure(cells, modules=[palette[0]] * len(cells))
    cells = list(_CELLS.__get__(answer, Structure))
    mixed = _MIXED.__get__(answer, Structure)
    types = list(mixed) if mixed is not None else [_MODULE.__get__(answer, Structure)] * len(cells)
    if len(types) != len(cells):
        raise ValueError(f"{len(types)} module types for {len(cells)} cells")
    return Structure(cells, modules=[_allowed(m, palette, index) for m in types])


def decided_before(structure: Structure, decided: Any) -> bool:
    """Is ``structure`` (plain, :func:`rebuilt`) among the structures ``decided`` (an
    evaluator's, on the agent's copies of the types), up to translation? Types compare by
    digest, since the copies are other objects."""
    digests: dict[int, str] = {}

    def signature(s: Structure) -> tuple:
        types = s.modules
        for m in types:
            if id(m) not in digests:
                digests[id(m)] = _DIGEST(m)
        x0, y0 = min(x for x, _ in s.cells), min(y for _, y in s.cells)
        return tuple(sorted((x - x0, y - y0, digests[id(m)]) for (x, y), m in zip(s.cells, types)))

    mine = signature(structure)
    return any(len(s.cells) == len(structure.cells) and signature(s) == mine for s in decided)


def conform(structure: Any, n_max: int, modules: list) -> Structure:
    """``structure`` (a Structure, or a list of (x, y) cells of ``modules[0]``) rebuilt on the
    allowed ``modules`` (:func:`rebuilt`); NotAllowedError (a ValueError) names a structure beyond
    ``n_max`` modules or a type not allowed."""
    s = rebuilt(structure, list(modules))
    if s.n_modules > n_max:
        raise NotAllowedError(f"{s.n_modules} modules exceed this tier's n_max = {n_max}")
    return s


def admissible(structure: Structure | None, n_max: int, modules=None) -> bool:
    """Is ``structure`` within the budget (at most ``n_max`` modules, counted from its cells)
    and made of the allowed module types (``modules``; default one type, ``TModule()``)? None
    is not."""
    if structure is None:
        return False
    try:
        conform(structure, n_max, list(modules) if modules else [Structure([(0, 0)]).module])
    except NotAllowedError:
        return False
    return True


def handed(problem: SearchProblem, name: str) -> SearchProblem:
    """What an agent is handed: a deep copy of ``problem`` (its own arrays and module types)
    whose task is named ``name`` (not the suite's key, which names the task in the installed
    suite files) and carries no ``meta`` (a held-out task's optimum and planted cells)."""
    meta = getattr(problem.task, "meta", None)
    memo = {} if meta is None else {id(meta): {}}  # the meta is copied as an empty dict
    given = copy.deepcopy(problem, memo)
    if hasattr(given.task, "name"):
        object.__setattr__(given.task, "name", name)
    return given


def reported_count(source: Any, attribute: str, agent: str) -> int:
    """An agent's own count ``attribute`` (``evaluated`` or ``oracle_calls``) of ``source``
    (its SearchResult or itself): 0 when it reports none, else a whole number; ValueError
    naming the agent, the attribute and the value for one that is not (a string, NaN, 2.5)."""
    value = getattr(source, attribute, 0)
    if value is None:
        return 0
    ok = isinstance(value, numbers.Real) and not isinstance(value, bool)
    if ok and math.isfinite(float(value)) and float(value).is_integer():
        return int(value)
    raise ValueError(f"solver {agent!r} reports {attribute} = {value!r}: not a count (a whole "
                     "number of configurations or oracle calls)")  # fmt: skip
