"""The anytime search's exact scan (:mod:`.anytime`, step 2): the levels from the bound upward
decided in the exhaustive search's canonical order, resumable at any chunk, so the search can
stop at a deadline and go on later from where it stopped."""

from __future__ import annotations

from modquad_gym.core.compile_clock import now
from modquad_gym.geometry.polyominoes import DEFAULT_CHUNK, PolyominoStream
from modquad_gym.geometry.structure import Structure, normalise
from modquad_gym.search.bounds import allowed_counts, level_excluded
from modquad_gym.search.levels import level_size
from modquad_gym.search.problem import EXACT_MODULES, FAULT_BLOCK
from modquad_gym.search.result import SearchRun
from modquad_gym.search.typed import MAX_PAIRS, assignments, level_pairs, typed_structure


class ExactLevels:
    """The exact scan of levels ``first``, ``first + 1``, ... in the exhaustive search's order,
    resumable at any chunk: :meth:`advance` works until a deadline (a time on the search clock,
    :func:`~modquad_gym.core.compile_clock.now`)."""

    def __init__(self, run: SearchRun, first: int, chunk: int = DEFAULT_CHUNK) -> None:
        self.run, self.problem, self.chunk, self._steps = run, run.problem, chunk, None
        self.n = first  # every level below is refuted

    def fits(self, n: int) -> bool:
        """Can level n be decided exactly (its size within the exhaustive search's reach)?"""
        p = self.problem
        if n > min(p.n_max, EXACT_MODULES):
            return False
        if p.shape_only:
            return True
        size = level_size(n)  # None past the tabulated counts: far beyond MAX_PAIRS
        return size is not None and size * len(p.palette) ** n <= MAX_PAIRS

    def advance(
        self, deadline: float, stop_at: int | None = None, settled=lambda _n: False
    ) -> Structure | None:
        """Decide levels until a feasible structure is found (returned: the first of the
        minimal level), the deadline passes, level ``stop_at`` is reached, ``settled(bound)``
        (an incumbent meets the bound) or no level fits."""
        while self.fits(self.n) and (stop_at is None or self.n < stop_at):
            if now() >= deadline or settled(self.n):
                return None
            if self._steps is None:
                self._steps = self._level(self.n)
            for found in self._steps:
                if found is not None:
                    return found
                if now() >= deadline or settled(self.n):
                    return None
            self.n += 1
            self._steps = None
            self.run.improve("exact", lower_bound=self.n)
        return None

    def first_of(self, n: int, deadline: float) -> Structure | None:
        """The first feasible structure of level n (every level below refuted), or None when
        the deadline passes first."""
        self.n, self._steps = n, None
        return self.advance(deadline, stop_at=n + 1)

    def _level(self, n: int):
        """Generator over level n: None after each chunk, then the first feasible structure."""
        p, run = self.problem, self.run
        if p.shape_only:
            if level_excluded(p.wrenches, p.f_max, p.module, n, p.fault):
                return
            chunk = self.chunk if p.fault is None else min(self.chunk, FAULT_BLOCK)
            for cells in PolyominoStream(n, chunk):
                i = run.checker.first_feasible(cells)
                if i is not None:
                    yield Structure.from_trusted(normalise(map(tuple, cells[i].tolist())), p.module)
                    return
                yield None
            return
        allowed, _ = allowed_counts(p, n)
        if not allowed.any():
            return
        for pair in level_pairs(run, n, assignments(n, allowed)):
            if pair is not None:
                yield typed_structure(p, pair)
                return
            yield None
