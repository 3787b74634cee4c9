"""The anytime search: the default of ``modquad solve``, answering up to 128 modules within a time
limit the way a MIP solver does, with an incumbent and a proved lower bound.

1. **Bounds** (instant, :func:`.bounds.bound_levels`): the force, count and level bounds
   (docs/search.md) rule out whole levels.
2. **Exact levels** (:class:`~.exact_levels.ExactLevels`): the levels from the bound upward are
   decided exactly, in the exhaustive search's canonical order, as long as they fit (up to 16
   modules; for several types up to :data:`~.typed.MAX_PAIRS` pairs a level) and for at most
   :data:`EXACT_SHARE` of the time at first. A level decided to its end with no feasible
   structure is refuted: the bound rises past it. A feasible structure found there is the
   exhaustive search's answer (the first in canonical order of the minimal level): certified.
3. **Incumbent** (:class:`Incumbents`): compact shapes (:mod:`.moves`) of increasing size up
   to n_max until one is feasible, then local moves: drop a module while the rest stays
   feasible; when none can go, look for a feasible structure of one module fewer by moving
   modules (and changing their types) to reduce the number of task wrenches it misses (with a
   fault, whose checks cost much, for half the time left at most).
4. With the time left, the exact levels go on from where they stopped, raising the bound.
5. **Portfolio** (:mod:`.portfolio`): the field's heuristics (and the learned designer when a
   caller adds it) produce incumbents too: in this process with the time the local moves leave,
   or, with an ``engine`` of Ray workers, beside steps 2-4 after a first :data:`QUICK_SECONDS` of
   exact levels (a task those decide at once never starts Ray), each stopping once an incumbent
   meets the bound. The clock stops while Ray starts: like the import, Ray's start (seconds on
   a small machine) is not the search's time, and the result's ``ray_start_seconds`` says how
   long it took; Ray stops after the result is built (hold the engine in a ``with`` block to
   keep it up across searches). The clock stops too while kernels compile (once, on a cold
   cache): every deadline is a time on the search clock
   (:func:`~modquad_gym.core.compile_clock.now`).

It stops at the time limit, or as soon as the bound meets the incumbent; when that happens at a
level the exact scan can decide, the level is scanned for its first feasible structure so that
the answer is the exhaustive search's. Every answer is verified by the exact LP oracle;
``lower_bound`` is the largest proved bound, ``certified`` is True when they meet. Each rise of
the bound and each smaller incumbent is an event of the result's ``history``
(:class:`~.result.Improvement`: seconds, bound, incumbent, which step found it); with
``progress=True`` the latest is shown on stderr (:mod:`.progress`).
"""

from __future__ import annotations

from modquad_gym.core.compile_clock import now
from modquad_gym.geometry.cells import packed_key
from modquad_gym.geometry.polyominoes import DEFAULT_CHUNK
from modquad_gym.geometry.structure import Structure
from modquad_gym.oracle.faults import DecisionInterruptedError
from modquad_gym.search.bounds import bound_levels, bound_proof
from modquad_gym.search.exact_levels import ExactLevels
from modquad_gym.search.moves import compact_shapes, relocations, removable
from modquad_gym.search.options import check_chunk, seeded_rng
from modquad_gym.search.portfolio import HEURISTICS, Producers, run_in_turn
from modquad_gym.search.problem import (
    DEFAULT_TIME_LIMIT,
    MAX_MODULES,
    SearchProblem,
    check_time_limit,
    search_entry,
)
from modquad_gym.search.progress import progress_line
from modquad_gym.search.result import SearchResult, SearchRun

EXACT_SHARE = 0.5
"""Share of the time limit the exact levels get before an incumbent is built."""

QUICK_SECONDS = 1.0
"""The exact levels get this long (at most) before incumbent producers start on workers."""

REPAIR_MOVES = 48
"""Moves tried per step of the repair search before it settles for a sideways move."""


class Incumbents:
    """The best verified structure found so far and the local moves that improve it. A candidate
    is (cells, types): cells a tuple of (x, y), types a tuple of palette indices (cached by its
    :func:`~modquad_gym.geometry.cells.packed_key`, compact bytes up to translation)."""

    def __init__(self, run: SearchRun, seed: int | None, deadline: float) -> None:
        self.run = run
        self.problem = run.problem
        self.rng = seeded_rng(seed)
        self.deadline = deadline
        self.best: tuple | None = None
        self.bound = 1  # the proved lower bound, kept up to date by the search
        self.producers: Producers | None = None
        self._missed: dict = {}

    def settled(self, bound: int | None = None) -> bool:
        """Whether the incumbent meets the proved bound (``bound``, else the last one known),
        after taking what the producers on workers found meanwhile."""
        if bound is not None:
            self.bound = max(self.bound, bound)
        if self.producers is not None:
            self.producers.poll()
        return self.best is not None and len(self.best[0]) <= self.bound

    def out_of_time(self) -> bool:
        return now() >= self.deadline or self.settled()

    def _take(self, cand, source: str) -> None:
        """``cand`` becomes the incumbent (an event of the run's history) when it is smaller."""
        if self.best is None or len(cand[0]) < len(self.best[0]):
            self.best = cand
            self.run.improve(source, n_modules=len(cand[0]))

    def offer(self, structure: Structure, source: str) -> None:
        """A structure found by a producer: the incumbent when it is smaller and feasible."""
        digests = [m.digest for m in self.problem.palette]
        cand = (tuple(structure.cells), tuple(digests.index(m.digest) for m in structure.modules))
        if (self.best is None or len(cand[0]) < len(self.best[0])) and self.feasible(cand):
            self._take(cand, source)

    def structure(self, cand) -> Structure:
        cells, types = cand
        palette = self.problem.palette
        if len(palette) == 1:
            return Structure.from_trusted(tuple(cells), palette[0])
        return Structure.from_trusted(tuple(cells), modules=tuple(palette[t] for t in types))

    def missed(self, cand) -> int:
        """How many task wrenches the candidate cannot exert (exact decisions; cached)."""
        key = packed_key(*cand)
        if key not in self._missed:
            _, W, ok = self.run.decide(self.structure(cand))
            self._missed[key] = int(len(W) - ok.sum())
        return self._missed[key]

    def feasible(self, cand) -> bool:
        """Exact, screened first by the checker's separating directions."""
        key = packed_key(*cand)
        if key in self._missed:
            return self._missed[key] == 0
        ok = self.run.checker.check(self.structure(cand))
        if ok:
            self._missed[key] = 0
        return ok

    def first(self, lower: int) -> bool:
        """The smallest compact shape (each palette type throughout) of lower..n_max modules
        that is feasible becomes the incumbent; when none is, the n_max-module shapes that
        miss the fewest wrenches are repaired by moves. False when nothing feasible is found
        in time."""
        K, n_max = len(self.problem.palette), self.problem.n_max
        for n in range(lower, n_max + 1):
            for cells in compact_shapes(n):
                for t in range(K):
                    if self.out_of_time():
                        return False
                    if self.feasible((cells, (t,) * n)):
                        self._take((cells, (t,) * n), "compact")
                        return True
        shapes = [(c, (t,) * n_max) for c in compact_shapes(n_max) for t in range(K)]
        shapes.sort(key=self.missed)
        for cand in shapes:
            found = self._descend(cand, patience=4 * n_max)
            if found is not None:
                self._take(found, "moves")
            if found is not None or self.out_of_time():
                break
        return self.best is not None

    def improve(self, lower: int) -> None:
        """Shrink the incumbent by local moves until it meets ``lower`` or time runs out."""
        while self.best is not None and len(self.best[0]) > lower and not self.out_of_time():
            smaller = self._drop(self.best) or self._repair(self.best)
            if smaller is None:
                return
            self._take(smaller, "moves")

    def _without(self, cand, i: int):
        cells, types = cand
        return cells[:i] + cells[i + 1 :], types[:i] + types[i + 1 :]

    def _drop(self, cand):
        """A feasible structure of one module fewer, or None."""
        for i in removable(cand[0]):
            if self.out_of_time():
                return None
            smaller = self._without(cand, i)
            if self.feasible(smaller):
                return smaller
        return None

    def _repair(self, cand):
        """One module fewer, then moves that reduce the wrenches missed, to zero (or None)."""
        starts = []
        for i in removable(cand[0]):
            if self.out_of_time():
                return None
            smaller = self._without(cand, i)
            starts.append((self.missed(smaller), i, smaller))
        starts.sort(key=lambda s: (s[0], s[1]))
        for _, _, start in starts[:3]:
            found = self._descend(start)
            if found is not None or self.out_of_time():
                return found
        return None

    def _descend(self, cand, patience: int = 12):
        """Local search on structures of one size, minimising the wrenches missed: take the
        first of up to :data:`REPAIR_MOVES` random moves that misses fewer, else a move that
        misses as many (at most ``patience`` in a row); the feasible structure or None."""
        current, missed, flat = cand, self.missed(cand), 0
        seen = {packed_key(*current)}
        while missed and flat <= patience and not self.out_of_time():
            moves = self._moves(current)
            self.rng.shuffle(moves)
            sideways = None
            for move in moves[:REPAIR_MOVES]:
                if self.out_of_time():
                    return None
                m = self.missed(move)
                if m < missed:
                    current, missed, flat = move, m, 0
                    break
                if m == missed and sideways is None and packed_key(*move) not in seen:
                    sideways = move
            else:
                if sideways is None:
                    return None
                current, flat = sideways, flat + 1
            seen.add(packed_key(*current))
        return current if missed == 0 else None

    def _moves(self, cand) -> list:
        """Relocations of one module, and (several types) changes of one module's type."""
        cells, types = cand
        out = [(cells[:i] + (c,) + cells[i + 1 :], types) for i, c in relocations(cells)]
        for k in range(1, len(self.problem.palette)):
            for i in range(len(cells)):
                t = (types[i] + k) % len(self.problem.palette)
                out.append((cells, types[:i] + (t,) + types[i + 1 :]))
        return out


@search_entry("anytime")
def anytime_search(
    problem: SearchProblem,
    *,
    time_limit: float = DEFAULT_TIME_LIMIT,
    seed: int | None = 0,
    chunk: int = DEFAULT_CHUNK,
    progress: bool = False,
    engine=None,
    producers=None,
) -> SearchResult:
    """The smallest structure found for ``task`` within ``time_limit`` seconds, with a proved
    lower bound (module docstring). Up to :data:`MAX_MODULES` modules; the task's arguments as
    for :func:`~.exhaustive.exhaustive_search`, whose answer it returns whenever the exact
    levels reach the minimum in time; ``seed`` seeds the local moves and the producers;
    ``progress`` shows the incumbent and the bound on stderr as they improve. ``engine`` (a
    :class:`~modquad_gym.core.distributed.Engine` with Ray workers) runs the incumbent
    producers in parallel; ``producers`` replaces :data:`~.portfolio.HEURISTICS`
    (:mod:`.portfolio`)."""
    time_limit = check_time_limit(time_limit)
    chunk = check_chunk(chunk)
    producers = HEURISTICS if producers is None else tuple(producers)
    run = SearchRun("anytime", problem)
    with progress_line(run, progress):
        return _search(run, time_limit, seed, chunk, engine, producers)


def _search(run: SearchRun, time_limit: float, seed, chunk: int, engine, producers) -> SearchResult:
    """The steps of :func:`anytime_search` (module docstring)."""
    problem, run.time_limit = run.problem, time_limit  # finish raises a bound past n_max
    lower = bound_levels(problem)
    run.check_budget(MAX_MODULES, lower)  # refused before any work or output
    run.improve("bounds", lower_bound=lower)
    if lower > problem.n_max:
        return run.finish(None, lower, proof=bound_proof(problem))
    reserve = problem.verify_reserve(time_limit)  # the final verification by the exact LP
    deadline = run.t0 + time_limit - reserve
    run.checker.deadline, run.verify_deadline = deadline, run.t0 + time_limit
    share = run.t0 + EXACT_SHARE * (time_limit - reserve)
    exact, incumbents = ExactLevels(run, lower, chunk), Incumbents(run, seed, deadline)
    parallel = engine is not None and getattr(engine, "use_ray", False) and bool(producers)
    try:  # a fault decision cut by the deadline proves and refutes nothing: stop with the best
        found = exact.advance(min(share, run.t0 + QUICK_SECONDS) if parallel else share)
        if found is None and exact.n <= problem.n_max:
            if not parallel:
                return _steps(run, exact, incumbents, share, deadline, producers, seed)
            with engine:  # up until the result is built: Ray's stop is not the search's time
                deadline, share = _pause_for_ray(run, engine, incumbents, deadline, share)
                with Producers(run, engine, producers, incumbents.offer, deadline, seed) as w:
                    incumbents.producers = w
                    try:
                        return _steps(run, exact, incumbents, share, deadline, producers, seed)
                    except DecisionInterruptedError:
                        return _best(run, exact, incumbents)
    except DecisionInterruptedError:
        return _best(run, exact, incumbents)
    if found is not None:
        run.improve("exact", found.n_modules, found.n_modules)
        return run.finish(found, found.n_modules)
    return run.finish(None, exact.n)  # every level refuted


def _pause_for_ray(
    run: SearchRun, engine, incumbents: Incumbents, deadline: float, share: float
) -> tuple[float, float]:
    """Start ``engine``'s Ray with the search's clock stopped: like its import, Ray's start is
    not the search's time, so the clock's start and every deadline the search holds move past
    it (the producers' deadline is taken from the moved one; the result says how long it
    took); the moved (deadline, share)."""
    before = now()
    engine.start()
    took = now() - before
    run.ray_start_seconds += took
    run.t0 += took
    run.checker.deadline += took
    run.verify_deadline += took
    incumbents.deadline += took
    return deadline + took, share + took


def _steps(run, exact, incumbents, share, deadline, producers, seed) -> SearchResult:
    """Steps 2-5 of the module docstring, once the quick exact levels did not answer."""
    found = None
    if incumbents.producers is not None:  # the exact levels' share, beside the producers
        found = exact.advance(share, settled=incumbents.settled)
    if found is None and exact.n <= run.problem.n_max and not incumbents.settled(exact.n):
        half = (now() + deadline) / 2  # with a fault: half the time left at most
        incumbents.deadline = half if run.problem.fault else deadline
        if incumbents.first(exact.n):
            incumbents.improve(exact.n)
        incumbents.deadline = deadline
        size = len(incumbents.best[0]) if incumbents.best is not None else run.problem.n_max + 1
        found = exact.advance(deadline, stop_at=size, settled=incumbents.settled)
        if found is None and exact.n == size and exact.fits(size):
            found = exact.first_of(size, deadline)  # the exhaustive search's own answer
    if found is not None:
        run.improve("exact", found.n_modules, found.n_modules)
        return run.finish(found, found.n_modules)
    if exact.n > run.problem.n_max and incumbents.best is None:
        return run.finish(None, exact.n)  # every level refuted
    incumbents.bound = max(incumbents.bound, exact.n)
    if incumbents.producers is not None:
        incumbents.producers.wait(incumbents.settled, deadline)
    else:
        run_in_turn(run, producers, incumbents.offer, incumbents.settled, deadline, seed)
    return _best(run, exact, incumbents)


def _best(run: SearchRun, exact: ExactLevels, incumbents: Incumbents) -> SearchResult:
    """The incumbent (if any) and the bound the exact levels proved."""
    best = incumbents.structure(incumbents.best) if incumbents.best is not None else None
    size = best.n_modules if best is not None else run.problem.n_max + 1
    return run.finish(best, min(exact.n, size))
