"""What a search's result says of its progress and its answer: :class:`Improvement` (one event
of its history) and :class:`Status` (what the answer proves)."""

from __future__ import annotations

import enum
from typing import NamedTuple


class Improvement(NamedTuple):
    """One event of a search's history: ``seconds`` after it started, the proved bound and the
    incumbent's module count (None before the first structure) became these, by ``source``
    (the anytime search: ``bounds``, ``exact``, ``compact``, ``moves``, ``beam``, ``genetic``)."""

    seconds: float
    lower_bound: int
    n_modules: int | None
    source: str

    def to_dict(self) -> dict:
        return {**self._asdict(), "seconds": round(self.seconds, 3)}


class Status(str, enum.Enum):
    """What a result proves, for a program to branch on (a string enum: ``status == "optimal"``
    holds; JSON writes its value)."""

    OPTIMAL = "optimal"
    """A structure was found and proved minimal (``n_modules == lower_bound``)."""
    FEASIBLE = "feasible"
    """A structure was found; a smaller one may exist (``lower_bound < n_modules``)."""
    INFEASIBLE = "infeasible"
    """Proved: no structure of at most ``n_max`` modules satisfies the task."""
    NO_ANSWER = "no answer"
    """No structure found and none ruled out for every size up to ``n_max`` (a heuristic, or a
    time limit reached)."""

    def __str__(self) -> str:
        return self.value
