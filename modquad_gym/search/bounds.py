"""Exact lower bounds on the module count, computed before any structure is searched.

* Force bound: the force part of W does not depend on where modules sit, so for n modules of
  one type it is exactly n times the force zonotope Z_F of one module. A task force outside
  n * Z_F rules out every structure of n modules.
* Level bounds: for a fixed set of directions d in wrench space, h_n(d) = max over every n-module
  structure S of its support h_S(d) is task-independent. A task wrench with d . w > h_n(d) (widened
  by the oracle's tolerance) rules out the whole level n. h_n is computed once per (module type, n)
  by one pass over the level and cached on disk (``$MODQUAD_CACHE`` or the user's cache folder,
  e.g. ``~/.cache/modquad_gym``; a file is used only when its format and checksum match,
  :mod:`.bounds_cache`); the default T-module's bounds up to 14 modules ship with the package
  (regenerate: ``python -m benchmarks.level_bounds``). An upper bound of the widened support is
  used (max of each sum taken separately), so the test stays exact.
* Count bounds (mixed types, and tasks of kind ``external``): the force part of a structure with
  c_t modules of type t is the Minkowski sum of c_t copies of each type's force zonotope,
  whatever the shape, and its weight M g = sum_t c_t m_t g is fixed by the counts too. So a
  count vector c is ruled out, with every shape and every assignment of those counts, when a
  task force f (plus M g e_z for ``external`` tasks) has N . f above sum_t c_t h_t(N) (widened
  by the oracle's tolerance) for a facet normal N of the sum (a cross product of two rotor
  directions) or a coordinate axis. The level bounds apply to the counts of one type alone.
* Dynamic tasks (kind ``dynamic``: the rotors must produce ``base_i + M s_i + P_i j`` at each
  sample i, :mod:`.dynamic`) take the count-bound path of ``external`` tasks. Proof that the
  bounds stay valid although M grows with n: the force rows of a structure's wrenches are
  ``f_base_i + M s_i`` (P_i has torque rows only), fixed by the count vector through M, and its
  force set is the Minkowski sum above, fixed by the counts too; so a count vector whose
  demand ``max_i N . (f_base_i + M s_i)`` exceeds the widened support of that sum in N holds no
  feasible structure, whatever the shape (exact per count vector, for that vector's own M).
  The level bounds of one type alone use, for n modules of mass M = n m, the task values
  :class:`~.dynamic.DynamicValues` (exact without inertia terms, a lower bound of every
  n-module structure's value with them), so a level they exclude holds no feasible structure.
  No bound is assumed monotone in n: :func:`bound_levels` returns the first count not ruled
  out, below which every count is ruled out.

:func:`bound_levels` combines them for a :class:`~.problem.SearchProblem`: the smallest module
count none of them rules out, the lower bound every search reports before searching.
"""

from __future__ import annotations

import hashlib
import itertools
import math
import os
from functools import lru_cache
from importlib import resources
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from modquad_gym.core.validation import check_f_max, check_int, check_wrenches
from modquad_gym.geometry.module import ModuleType, check_module
from modquad_gym.geometry.polyominoes import A001168, PolyominoStream
from modquad_gym.oracle import RESIDUAL_TOL, TOL
from modquad_gym.oracle.failures import check_fault
from modquad_gym.oracle.tolerance import SUPPORT_SLACK
from modquad_gym.search.bounds_cache import read_cached, usable, write_cached
from modquad_gym.search.dynamic import DynamicValues, force_needs, off_range_grant

if TYPE_CHECKING:
    from modquad_gym.dynamics import LinearWrenches
    from modquad_gym.search.problem import SearchProblem

NO_SIZE = 10**9
"""What :func:`force_lower_bound` returns when no number of modules can exert the forces."""

COMPUTE_ON_DEMAND_UP_TO = 10
"""Level bounds are computed on the fly up to this many modules (a pass over at most 36,446
structures); larger levels use the shipped or cached bounds only."""


def force_lower_bound(
    W: np.ndarray, module: ModuleType, f_max: float = 1.0, fault: str | None = None
) -> int:
    """Smallest n such that every task force lies in n * Z_F, with Z_F the force zonotope of
    one module {sum_j u_j d_j} with thrusts u_j in the oracle's band [-TOL/2, 1 + TOL/2] f_max,
    up to the oracle's off-range allowance (:func:`off_range_allowance`). Exact: no structure of
    fewer modules can exert the task's forces by the oracle's rule, whatever its shape.
    :data:`NO_SIZE` if no n works. A bad argument is a ValueError naming it.

    With a ``fault`` the forces must stay within reach after any single failure: after a
    module fails, n - 1 modules' force set (so n >= the intact bound + 1); after a rotor fails,
    n Z_F less that rotor's force segment, whose support in a direction N is at most
    ``n h_1(N) - f_max max(0, N . d_j)`` for the rotor j of the module with the largest
    ``N . d_j`` (any rotor may fail, so a tolerant structure survives losing that one); after
    two rotors fail (``"rotor2"``), less the two largest of one module (a pair that may fail);
    after a module and a rotor of another (``"rotor+module"``), n - 1 modules' less that rotor's
    (for n >= 2; n = 1 is bounded as a module failure). A required fault margin only shrinks
    what is feasible: these bounds stay valid for it."""
    W, f_max, fault = check_wrenches(W), check_f_max(f_max), check_fault(fault, optional=True)
    dirs = check_module(module).directions
    normals = [
        np.cross(dirs[i], dirs[j]) for i in range(len(dirs)) for j in range(i + 1, len(dirs))
    ]
    normals = [n / np.linalg.norm(n) for n in normals if np.linalg.norm(n) > 1e-12]
    normals += [np.eye(3)[k] for k in range(3)]  # harmless extra directions for degenerate types
    N = np.array(normals + [-n for n in normals])
    ND = N @ dirs.T  # (k, r)
    h1 = np.maximum(ND, 0.0).sum(axis=1) * f_max  # support of one module's force set
    wide = h1 + 0.5 * TOL * f_max * np.abs(ND).sum(axis=1)  # ... with the oracle's thrust band
    proj = W[:, :3] @ N.T - off_range_allowance(W, f_max)[:, None]  # (t, k)
    if fault == "rotor":
        proj = proj + np.maximum(ND, 0.0).max(axis=1) * f_max
    elif fault == "rotor2":
        top = -np.sort(-np.maximum(ND, 0.0), axis=1)
        proj = proj + top[:, :2].sum(axis=1) * f_max
    elif fault == "module":
        proj = proj + h1
    elif fault == "rotor+module":  # a module, then the strongest rotor of another
        alone = proj + h1  # a single module has only itself to lose
        proj = proj + h1 + np.maximum(ND, 0.0).max(axis=1) * f_max
        if (alone <= wide).all():  # one module may do: bound it as a module failure
            proj = alone
    some = h1 > 1e-12 * f_max  # a direction one module's forces reach at all
    need = np.where(some, proj / np.where(some, wide, 1.0), np.where(proj > 0, np.inf, 0))
    worst = float(need.max())
    if not math.isfinite(worst) or worst > NO_SIZE:
        return NO_SIZE
    return max(1, math.ceil(worst - 1e-9))  # n modules reach n * wide: the oracle's rule


def force_normals(palette: list[ModuleType]) -> np.ndarray:
    """(k, 3) unit directions: +-(the cross products of every pair of rotor directions of the
    palette) and the +-coordinate axes. They hold every facet normal of any sum of the
    palette's force zonotopes (the extra axes keep the test valid for degenerate sums)."""
    dirs = np.vstack([m.directions for m in palette])
    dirs = np.unique(np.round(dirs, 12), axis=0)
    normals = [
        np.cross(dirs[i], dirs[j]) for i in range(len(dirs)) for j in range(i + 1, len(dirs))
    ]
    normals = [n / np.linalg.norm(n) for n in normals if np.linalg.norm(n) > 1e-12]
    normals += list(np.eye(3))
    N = np.array(normals + [-n for n in normals])
    return np.unique(np.round(N, 14), axis=0)


def count_vectors(n: int, k: int) -> np.ndarray:
    """(C, k) every way of choosing n modules from k types (counts), lexicographic."""
    if k == 1:
        return np.array([[n]])
    rows = [[c, *rest] for c in range(n, -1, -1) for rest in count_vectors(n - c, k - 1)]
    return np.array(rows, dtype=int).reshape(-1, k)


def counts_possible(
    model: LinearWrenches,
    palette: list[ModuleType],
    counts: np.ndarray,
    f_max: float = 1.0,
    fault: str | None = None,
) -> np.ndarray:
    """bool (C,): False where the count vector (row of ``counts``, one count per palette type)
    certainly cannot exert the task's forces, whatever the shape (module docstring), for the
    task's wrench ``model`` (each count vector's own mass: its weight, a dynamic task's
    inertial forces). Exact: a structure the oracle accepts always passes. With a ``fault``
    the capacity left after the worst single failure of a type present in the counts is used
    (a module's whole force support, or its strongest rotor's, or its two strongest rotors'
    in each direction; the mass stays)."""
    counts = np.atleast_2d(np.asarray(counts, dtype=float))
    N = force_normals(palette)  # (k, 3)
    proj = [N @ m.directions.T for m in palette]  # each (k, r)
    h = np.array([np.maximum(p, 0.0).sum(axis=1) for p in proj])  # (K, k)
    a = np.array([np.abs(p).sum(axis=1) for p in proj])  # (K, k)
    cap = counts @ (f_max * (h + 0.5 * TOL * a))  # (C, k) widened supports
    if fault is not None:
        if fault in ("module", "rotor+module"):  # (K, k): one module of each type (and for
            loss = f_max * h  # rotor+module no more: the rotor may be of any type, or none)
        elif fault == "rotor2":  # two rotors of one module of each type
            top = [-np.sort(-np.maximum(p, 0.0), axis=1)[:, :2].sum(axis=1) for p in proj]
            loss = f_max * np.array(top)
        else:
            loss = f_max * np.array([np.maximum(p, 0.0).max(axis=1) for p in proj])
        present = counts > 0  # (C, K)
        cap = cap - np.where(present[:, :, None], loss[None], 0.0).max(axis=1)
    if model.uses_mass:  # the demand of each count vector's own mass
        need = force_needs(model, N, counts @ np.array([m.mass for m in palette]))
    else:
        need = np.broadcast_to((model.base[:, :3] @ N.T).max(axis=0), cap.shape).copy()
    heaviest = float((counts @ np.array([m.mass for m in palette])).max()) if len(counts) else 0.0
    most = int(counts.sum(axis=1).max()) if len(counts) else 0  # modules, for the inertia terms
    slack = off_range_grant(model, palette, f_max, most, heaviest) + SUPPORT_SLACK
    return ~np.any(need > cap + slack, axis=1)


def level_directions() -> np.ndarray:
    """The fixed directions of the level bounds (unit rows, (104, 6)): every torque direction
    in {-1, 0, 1}^3 combined with a downward force weight in {0, 1/4, 1/2, 1} (a torque costs
    lift: the less lift a task has, the less torque any structure of n modules can add)."""
    rows = []
    for c in (0.0, 0.25, 0.5, 1.0):
        for t in itertools.product((-1.0, 0.0, 1.0), repeat=3):
            if any(t):
                rows.append([0.0, 0.0, -c, *t])
    D = np.array(rows)
    return D / np.linalg.norm(D, axis=1, keepdims=True)


def module_digest(module: ModuleType) -> str:
    """Names a module type's level bounds: a hash of its rotor data and the directions,
    rounded to 10 decimals so that machines differing in the last bits agree."""
    h = hashlib.sha256()
    for a in (module.columns, module.directions, np.array([module.side]), level_directions()):
        h.update(np.ascontiguousarray(np.round(a, 10) + 0.0, dtype=float).tobytes())
    return h.hexdigest()[:16]


def compute_level_bounds(module: ModuleType, n: int, fault: str | None = None) -> np.ndarray:
    """(2, P): max over level n of (sum_k max(0, d . a_k), sum_k |d . a_k|) per direction,
    per unit thrust, by one pass over the level. With a ``fault`` the first is what each
    structure keeps after its worst failure of that kind (:data:`.supports.LOSSES`): a
    structure tolerant to it exerts no wrench beyond that in d."""
    from modquad_gym.search import supports  # numba

    b, alpha, beta = supports.direction_terms([module], level_directions())
    out = np.zeros((2, b.shape[0]))
    masses = np.ones(1)
    lose = supports.LOSSES[fault]
    for cells in PolyominoStream(n, 1 << 16):
        types = np.zeros(cells.shape[:2], dtype=np.int8)
        supports.max_supports(cells, types, masses, float(module.side), b, alpha, beta, *out,
                              lose)  # fmt: skip
    return out


def _cache_dir() -> Path:
    """``$MODQUAD_CACHE``, else the user's cache folder (platformdirs: ``~/.cache/modquad_gym``
    on Linux, ``~/Library/Caches/modquad_gym`` on macOS, ``%LOCALAPPDATA%``'s on Windows)."""
    if os.environ.get("MODQUAD_CACHE"):
        return Path(os.environ["MODQUAD_CACHE"])
    import platformdirs

    return Path(platformdirs.user_cache_dir("modquad_gym", appauthor=False))


def _shipped(digest: str, n: int) -> np.ndarray | None:
    try:
        ref = resources.files("modquad_gym") / "data" / "level_bounds" / f"{digest}.npz"
        if not ref.is_file():
            return None
        with ref.open("rb") as fh, np.load(fh) as data:
            key = f"n{n}"
            found = data[key] if key in data.files else None
    except (OSError, ValueError):
        return None
    return found if usable(found, len(level_directions())) else None


@lru_cache(maxsize=256)
def _bounds(digest: str, module: ModuleType, n: int, fault: str | None) -> np.ndarray | None:
    shipped = _shipped(digest, n) if fault is None else None
    if shipped is not None:
        return shipped
    kind = "" if fault is None else f"_{fault}"
    path = _cache_dir() / f"level_bounds_{digest}{kind}_n{n}.npz"
    cached = read_cached(path, len(level_directions()))
    if cached is not None or n > COMPUTE_ON_DEMAND_UP_TO:
        return cached
    out = compute_level_bounds(module, n, fault)
    try:
        write_cached(path, out)
    except OSError:
        pass  # a read-only home: the bound still holds for this process
    return out


def level_bounds(module: ModuleType, n: int, fault: str | None = None) -> np.ndarray | None:
    """The cached (2, P) level bounds of ``n`` modules of ``module`` (after the worst failure
    of kind ``fault``), or None when they are neither shipped, cached nor cheap enough to
    compute now. ValueError naming a bad argument."""
    n, module = check_int(n, "n", low=1), check_module(module)
    return _bounds(module_digest(module), module, n, check_fault(fault, optional=True))


def level_excluded(
    W: np.ndarray, f_max: float, module: ModuleType, n: int, fault: str | None = None
) -> bool:
    """True when some task wrench (rotor wrench: for ``external`` tasks pass W plus the
    weight of n modules) lies beyond every n-module structure in a level direction (after
    each structure's worst failure of kind ``fault``)."""
    values = (level_directions() @ W.T - off_range_allowance(W, f_max)).max(axis=1)
    return values_excluded(values, f_max, module, n, fault)


def off_range_allowance(W: np.ndarray, f_max: float) -> np.ndarray:
    """(t,) how far each wrench may lie off a structure's reach along a unit direction and stay
    feasible by the oracle's off-range rule (``RESIDUAL_TOL (f_max + |w|)``): what a bound
    grants before it excludes (1e-10 along x is feasible for a flat module)."""
    return RESIDUAL_TOL * (f_max + np.linalg.norm(W, axis=1))


def values_excluded(
    values: np.ndarray, f_max: float, module: ModuleType, n: int, fault: str | None = None
) -> bool:
    """True when a task value per level direction (its max over the task's rotor wrenches, or
    a lower bound of it) exceeds the widened support of every n-module structure (after its
    worst failure of kind ``fault``)."""
    bounds = level_bounds(module, n, fault)
    if bounds is None:
        return False
    widened = f_max * (bounds[0] + 0.5 * TOL * bounds[1]) + SUPPORT_SLACK
    return bool((values > widened).any())


MAX_BOUND_LEVELS = 256
"""Levels :func:`bound_levels` examines at most with several types (each its count
vectors); past it the bound stays where the scan stopped (still a valid bound)."""

MAX_COUNT_VECTORS = 50_000
"""Most count vectors (ways of choosing n modules from the palette's types) a bound
enumerates; past it :func:`bound_levels` stops raising its bound (still a valid bound)."""


def n_count_vectors(n: int, k: int) -> int:
    """How many count vectors of n modules of k types there are."""
    return math.comb(n + k - 1, k - 1)


def counts_left(problem: SearchProblem, n: int) -> tuple[np.ndarray, np.ndarray]:
    """(counts (C, K), ok (C,)): the count vectors of level n and which of them the count
    bound and, for one type alone, the level bound leave."""
    p = problem
    counts = count_vectors(n, len(p.palette))
    ok = counts_possible(p.model, list(p.palette), counts, p.f_max, p.fault)
    for i, c in enumerate(counts):
        if ok[i] and int(c.max()) == n:  # one type alone: the level bounds apply
            m = p.palette[int(np.argmax(c))]
            values = DynamicValues(p.model, [m]).values(level_directions(), n * m.mass, n)
            values = values - off_range_grant(p.model, [m], p.f_max, n, n * m.mass)
            ok[i] = not values_excluded(values, p.f_max, m, n, p.fault)
    return counts, ok


def allowed_counts(problem: SearchProblem, n: int) -> tuple[np.ndarray, int]:
    """(allowed, pairs skipped) for level n of a typed search: a bool array indexed by count
    vectors (one axis of length n + 1 per palette type) of the counts :func:`counts_left`
    leaves; and how many (shape, assignment) pairs the others hold (fixed polyominoes of n
    cells times the multinomial of each count vector)."""
    counts, ok = counts_left(problem, n)
    allowed = np.zeros((n + 1,) * len(problem.palette), dtype=bool)
    allowed[tuple(counts.T)] = ok
    shapes = A001168[n - 1] if n <= len(A001168) else 0
    skipped = shapes * sum(_multinomial(c) for c, good in zip(counts, ok) if not good)
    return allowed, skipped


def first_possible_level(problem: SearchProblem) -> tuple[int, str]:
    """(the smallest module count the count bound leaves, "") or (NO_SIZE, proof) when it
    rules out every count up to n_max."""
    p = problem
    for n in range(1, p.n_max + 1):
        counts = count_vectors(n, len(p.palette))
        if counts_possible(p.model, list(p.palette), counts, p.f_max, p.fault).any():
            return n, ""
    lift = " and lift its own weight" if p.model.uses_mass else ""
    return (
        NO_SIZE,
        f"count bound: no mix of up to {p.n_max} modules can exert the task's forces{lift}",
    )


def _multinomial(c: np.ndarray) -> int:
    out, total = 1, 0
    for k in c:
        total += int(k)
        out *= math.comb(total, int(k))
    return out


def bound_levels(problem: SearchProblem) -> int:
    """The smallest module count that no exact bound rules out, n_max + 1 when they rule out
    every count up to n_max: one type and a ``total`` task, the force bound and then the level
    bounds; otherwise the count bound (forces, and weight for ``external`` tasks, per count
    vector) and the level bounds of one type alone. Proved: no structure of fewer modules
    satisfies the task."""
    p = problem
    if p.shape_only:
        n = force_lower_bound(p.wrenches, p.module, p.f_max, p.fault)
        if n == NO_SIZE:
            return p.n_max + 1
        while n <= p.n_max and level_excluded(p.wrenches, p.f_max, p.module, n, p.fault):
            n += 1
        return min(n, p.n_max + 1)
    K = len(p.palette)
    n = 1
    while n <= min(p.n_max, MAX_BOUND_LEVELS) and n_count_vectors(n, K) <= MAX_COUNT_VECTORS:
        if counts_left(p, n)[1].any():
            break
        n += 1
    return min(n, p.n_max + 1)


def bound_proof(problem: SearchProblem) -> str:
    """Why no level up to n_max is left, in the words of the bound that says so."""
    if problem.shape_only:
        n = force_lower_bound(problem.wrenches, problem.module, problem.f_max, problem.fault)
        if n == NO_SIZE:
            return "force bound: no number of modules can exert the task's forces"
        if n > problem.n_max:
            return f"force bound: the task's forces need at least {n} modules"
    return f"exact bounds (force, count, level) rule out every level up to {problem.n_max}"
