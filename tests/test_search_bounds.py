"""The search problem value, proved lower bounds and certificates, and searches from a partial
structure (``start=``), each against brute force on small cases."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import modquad_gym as mq
from modquad_gym.geometry.module import GRAVITY, palette
from modquad_gym.geometry.structure import free_neighbours, structure_levels
from modquad_gym.search import (
    SEARCHES,
    SearchProblem,
    SearchResult,
    bound_levels,
    exhaustive_search,
)
from modquad_gym.search.partial import make_partial

T = palette("t45,t45m,flat")


def random_cells(n, rng):
    cells = [(0, 0)]
    while len(cells) < n:
        options = free_neighbours(cells)
        cells.append(options[int(rng.integers(len(options)))])
    return cells


def planted(cells, t, rng, modules=None, scale=1.0):
    s = mq.Structure(cells, modules=modules) if modules else mq.Structure(cells)
    A = s.configuration_matrix()
    U = rng.uniform(0, 1, (t, A.shape[1]))
    on = rng.uniform(size=U.shape) < 0.8
    U[on] = rng.integers(0, 2, int(on.sum()))
    return scale * (A @ U.T).T


def task_of(seed):
    """A small task: planted in a random structure, scaled (so that some are infeasible), or
    torque-heavy (where the level bounds work)."""
    rng = np.random.default_rng(seed)
    n = int(rng.integers(1, 6))
    W = planted(random_cells(n, rng), int(rng.integers(1, 12)), rng, scale=rng.choice([1, 1.3]))
    if rng.uniform() < 0.3:
        W[:, 3:] *= 2.5
    return W


# --------------------------------------------------------------------------- the problem value
def test_problem_is_built_once_and_validated():
    p = SearchProblem.build([[0, 0, 2.0, 0, 0, 0]], n_max=5, modules=T)
    assert p.palette == tuple(T) and p.typed and p.kind == "total" and p.n_max == 5
    assert not p.shape_only and p.with_n_max(9).n_max == 9
    one = SearchProblem.build(mq.TaskRequirement([[0, 0, 2.0, 0, 0, 0]], f_max=2.0))
    assert one.f_max == 2.0 and one.shape_only and not one.typed
    with pytest.raises(AttributeError):
        one.n_max = 3  # frozen
    for bad, match in [
        (dict(n_max=0), "n_max"),
        (dict(f_max=-1.0), "f_max"),
        (dict(kind="inside"), "kind"),
        (dict(module=T[0], modules=T), "not both"),
        (dict(modules=T + T[:1]), "is listed twice"),  # as --modules refuses a repeat
        (dict(modules="t45,bogus"), "unknown module type 'bogus'"),
        (dict(modules=5), "list of ModuleType"),
    ]:
        with pytest.raises(ValueError, match=match):
            SearchProblem.build([[0, 0, 2.0, 0, 0, 0]], **bad)
    with pytest.raises(ValueError, match="wrench"):
        SearchProblem.build(np.zeros((2, 5)))


def test_result_certified_follows_the_lower_bound():
    s = mq.Structure([(0, 0), (1, 0)])
    common = dict(evaluated=1, oracle_calls=1, seconds=0.0, method="m", n_max=4)
    assert SearchResult(s, 2, certified=None, lower_bound=2, **common).certified
    assert not SearchResult(s, 2, certified=None, lower_bound=1, **common).certified
    assert SearchResult(s, 2, certified=True, **common).lower_bound == 2  # what it meant
    assert SearchResult(None, None, certified=True, **common).lower_bound == 5
    assert SearchResult(s, 2, certified=False, **common).lower_bound == 1
    with pytest.raises(ValueError, match="certified"):
        SearchResult(s, 2, certified=True, lower_bound=1, **common)
    with pytest.raises(ValueError, match="exceeds"):
        SearchResult(s, 2, certified=None, lower_bound=3, **common)
    assert SearchResult(s, 2, certified=None, lower_bound=2, **common).to_dict()["lower_bound"] == 2


# --------------------------------------------------------------------------- lower bounds
@settings(max_examples=50, deadline=None)
@given(st.integers(0, 10**6))
def test_no_lower_bound_exceeds_the_certified_optimum(seed):
    """Every search's bound (and bound_levels) <= the exhaustive search's certified optimum,
    or where no structure of up to n_max works, its bound (the strongest proved:
    tests/test_bounds_oracle_rule.py checks it against the oracle's smallest structure), on 50
    small tasks per run (a fresh draw each run)."""
    W = task_of(seed)
    exact = exhaustive_search(W, n_max=6)
    top = exact.lower_bound
    assert exact.certified and exact.n_modules in (None, top) and top >= (exact.n_modules or 7)
    assert bound_levels(SearchProblem.build(W, n_max=6)) <= top
    for name, search in SEARCHES.items():
        if name == "milp":  # a program per level: its own hypothesis test (tests/test_milp.py)
            continue
        r = search(W, n_max=6)
        assert r.lower_bound <= top, name
        assert r.certified == (r.n_modules == r.lower_bound if r.structure else r.lower_bound > 6)
        if r.certified:
            assert (r.n_modules, r.lower_bound) == (exact.n_modules, top), name


@settings(max_examples=40, deadline=None)
@given(st.integers(0, 10**6), st.sampled_from(["total", "external"]))
def test_typed_lower_bounds_never_exceed_the_typed_optimum(seed, kind):
    rng = np.random.default_rng(seed)
    n = int(rng.integers(1, 4))
    types = [T[int(k)] for k in rng.integers(0, 3, n)]
    cells = random_cells(n, rng)
    W = planted(cells, 6, rng, modules=types, scale=float(rng.choice([1.0, 1.4])))
    if kind == "external":  # the planted structure carries its own weight
        W[:, 2] -= mq.Structure(cells, modules=types).mass * GRAVITY
    exact = exhaustive_search(W, n_max=4, modules=T, kind=kind)
    top = exact.lower_bound  # the optimum, else the strongest bound proved (as above)
    assert exact.n_modules in (None, top) and top >= (exact.n_modules or 5)
    assert bound_levels(SearchProblem.build(W, 4, modules=T, kind=kind)) <= top
    for name in ("greedy", "random", "centrosymmetric"):
        assert SEARCHES[name](W, n_max=4, modules=T, kind=kind).lower_bound <= top


# --------------------------------------------------------------------------- start=
def brute_force_minimum(W, start_cells, n_max, modules=None, start_types=None):
    """The smallest feasible structure containing a translate of the start (cells, and types
    where given), by enumerating every structure and every type assignment."""
    import itertools

    start = set(start_cells)
    for n, level in enumerate(structure_levels(n_max), start=1):
        for key in level:
            anchors = [(a[0] - start_cells[0][0], a[1] - start_cells[0][1]) for a in key]
            hits = [t for t in anchors if all((x + t[0], y + t[1]) in set(key) for x, y in start)]
            if not hits:
                continue
            for types in itertools.product(modules or [None], repeat=n):
                if start_types is not None:
                    index = dict(zip(key, types))
                    if not any(
                        all(
                            index[(x + t[0], y + t[1])] is m
                            for (x, y), m in zip(start_cells, start_types)
                        )
                        for t in hits
                    ):
                        continue
                s = mq.Structure(key, modules=types) if modules else mq.Structure(key)
                if mq.feasible(s.configuration_matrix(), W, method="scipy").all():
                    return n
    return None


@pytest.mark.parametrize("seed", range(12))
def test_start_gives_the_minimum_containing_the_partial_structure(seed):
    rng = np.random.default_rng(seed)
    W = planted(random_cells(int(rng.integers(2, 5)), rng), 6, rng)
    start = random_cells(int(rng.integers(1, 4)), rng)
    r = exhaustive_search(W, n_max=5, start=start)
    assert r.n_modules == brute_force_minimum(W, start, 5)
    # the bound is the task's, proved by the exact bounds; the minimum containing start is not
    assert r.lower_bound == bound_levels(SearchProblem(W, n_max=5))
    assert r.certified == (r.lower_bound == r.n_modules if r.structure else r.lower_bound > 5)
    if r.structure is not None:
        part = make_partial(start, (mq.TModule(),), False, 5)
        assert part.mask(np.array(r.structure.cells)[None])[0]
        plain = exhaustive_search(W, n_max=5)
        assert r.n_modules >= plain.n_modules  # a constraint never helps
    assert (
        exhaustive_search(W, n_max=5, start=[(0, 0)]).n_modules
        == exhaustive_search(W, n_max=5).n_modules
    )  # every structure contains one module


@pytest.mark.parametrize("seed", range(4))
def test_typed_start_keeps_its_module_types(seed):
    rng = np.random.default_rng(50 + seed)
    cells = random_cells(3, rng)
    types = [T[int(k)] for k in rng.integers(0, 3, 3)]
    W = planted(cells, 6, rng, modules=types)
    start = mq.Structure(cells[:2], modules=types[:2])
    r = exhaustive_search(W, n_max=3, modules=T, start=start)
    assert r.n_modules == brute_force_minimum(W, cells[:2], 3, T, types[:2])
    loose = exhaustive_search(W, n_max=3, modules=T, start=cells[:2])  # types free
    assert loose.n_modules <= r.n_modules


def test_bad_start_is_refused():
    W = [[0, 0, 2.0, 0, 0, 0]]
    with pytest.raises(ValueError, match="start"):
        exhaustive_search(W, start=[(0, 0), (2, 0)])  # not connected
    with pytest.raises(ValueError, match="start"):
        exhaustive_search(W, start=mq.Structure([(0, 0)], module=T[2]))  # not the T-module
    with pytest.raises(ValueError, match=r"^start has 3 cells, more than n_max=2$"):
        exhaustive_search(W, n_max=2, start=[(0, 0), (1, 0), (2, 0)])
