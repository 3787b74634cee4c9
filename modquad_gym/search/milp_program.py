"""The mixed-integer program of one level of the ``milp`` search (:mod:`.milp`, whose docstring
states it; ``docs/search.md`` proves it): the window of cells, the mass groups, each wrench's
demand and :class:`LevelProgram` (rows, bounds, cuts), solved by HiGHS through
:func:`scipy.optimize.milp`. The search imports it on first use: scipy loads only when a program
is built."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp
from scipy.optimize import Bounds, LinearConstraint, OptimizeResult, milp

from modquad_gym.core.compile_clock import now
from modquad_gym.geometry.cells import is_connected
from modquad_gym.geometry.inertia import to_vector
from modquad_gym.geometry.module import ModuleType
from modquad_gym.geometry.structure import Structure
from modquad_gym.oracle.tolerance import RESIDUAL_TOL, TOL
from modquad_gym.search import milp_worker
from modquad_gym.search.bounds import counts_left
from modquad_gym.search.problem import SearchProblem

MARGIN = 1e-4
"""Widening (units of f_max) of the thrust bounds and wrench rows beyond the oracle's rule, so
that HiGHS (feasibility tolerance 1e-7, relative to its scaled rows) never rules out a structure the
oracle accepts (1e-6 did not: a 3-module answer with two wrenches at its vertices was refuted). A
candidate inside the margin but outside the rule is rejected by the oracle and cut off."""

INITIAL_DIRECTIONS = 24
"""A level's program starts with the task's wrenches that are extreme along +-each axis and
along this many fixed random directions of wrench space (the others join when a candidate
misses them). Measured on 12 paper-like and planted tasks of 5-8 modules: axes alone 72 s in
all, 10 directions 59 s, 24: 59 s, 48: 50 s (a loaded 2-core machine)."""

MAX_NONZEROS = 2_500_000
"""A level whose program would exceed this many constraint nonzeros is not attempted: the
search stops there with the bound it proved. It bounds memory and building time (the time
limit itself is kept by :mod:`.milp_worker`): up to 2.1 M (96 modules) HiGHS took at most
1.6 GB; a 4.9 M program (a 128-module planted task) ran 13 min past a 30 s limit in this
process, before the worker."""

IN_PROCESS_NONZEROS = 50_000
"""Outside the main thread, programs with at most this many constraint nonzeros are solved in
this process (no worker to start or feed), larger ones in the worker of :mod:`.milp_worker`,
killed at the deadline; in the main thread they go to the worker, which a Ctrl-C or SIGTERM
kills at once (a small one is tried here while it boots, and solved here while another thread
holds it: :mod:`.milp_worker`). HiGHS
overran a 1 s limit by at most 0.06 s below 100 k nonzeros (one type, three types, a dynamic
task with inertia; its whole presolve took 0.6 s at 71 k), by 0.3 s at 155 k, 2.3 s at 385 k
and 19 s at 860 k (a loaded 2-core machine)."""

INFEASIBLE = 2
"""scipy.optimize.milp's status of an infeasible program."""
TIME_LIMIT = 1
"""scipy.optimize.milp's status when it stopped at a limit (time, nodes, iterations)."""


def window(n: int) -> np.ndarray:
    """(N, 2) the cells (x, y), x, y >= 0, x + y <= n - 1: a translate of every n-cell
    polyomino with a cell in column 0 and one in row 0 lies in it (N = n (n + 1) / 2)."""
    return np.array([(x, y) for x in range(n) for y in range(n - x)], dtype=int).reshape(-1, 2)


def directed_edges(cells: np.ndarray) -> np.ndarray:
    """(E, 2) index pairs (a, b) of face-adjacent cells, both directions."""
    index = {tuple(c): i for i, c in enumerate(cells.tolist())}
    out = []
    for i, (x, y) in enumerate(cells.tolist()):
        for dx, dy in ((1, 0), (-1, 0), (0, 1), (0, -1)):
            j = index.get((x + dx, y + dy))
            if j is not None:
                out.append((i, j))
    return np.array(out, dtype=int).reshape(-1, 2)


# ---------------------------------------------------------------------------- mass groups
@dataclass(frozen=True)
class Group:
    """A level's split into mass classes: ``counts[k]`` modules of the palette types
    ``classes[k]`` (types of equal mass); ``mass`` the total in kg."""

    classes: tuple[tuple[int, ...], ...]
    counts: tuple[int, ...]
    mass: float


def mass_classes(palette: tuple[ModuleType, ...]) -> tuple[tuple[int, ...], ...]:
    """The palette's type indices grouped by mass (one class for one type or equal masses)."""
    out: dict[float, list[int]] = {}
    for t, m in enumerate(palette):
        out.setdefault(round(m.mass, 12), []).append(t)
    return tuple(tuple(v) for v in out.values())


def level_groups(problem: SearchProblem, n: int) -> list[Group]:
    """The mass class counts of level n that the exact count and level bounds leave
    (:func:`.bounds.counts_left`), each a program of its own; none: the level is refuted."""
    classes = mass_classes(problem.palette)
    counts, ok = counts_left(problem, n)
    masses = [problem.palette[c[0]].mass for c in classes]
    seen: dict[tuple[int, ...], Group] = {}
    for row in counts[ok]:
        split = tuple(int(sum(row[t] for t in c)) for c in classes)
        if split not in seen:
            mass = float(sum(k * m for k, m in zip(split, masses, strict=True)))
            seen[split] = Group(classes, split, mass)
    return list(seen.values())


# ---------------------------------------------------------------------------- the demand
@dataclass(frozen=True)
class Demand:
    """What the rotors of every structure of one total mass must produce, units of f_max:
    row i is ``fixed[i] + per_inertia[i] @ j`` (j the structure's inertia vector about its
    centre of mass; ``per_inertia`` None when the wrenches do not depend on it).
    ``of_sample[k]`` is the row of the problem's k-th rotor wrench."""

    fixed: np.ndarray
    per_inertia: np.ndarray | None
    of_sample: np.ndarray

    @classmethod
    def of(cls, problem: SearchProblem, mass: float) -> Demand:
        model, f = problem.model, problem.f_max
        fixed = (model.base + mass * model.per_mass) / f  # the rows of model.at(mass, j)
        if model.uses_inertia:
            return cls(fixed, model.per_inertia / f, np.arange(len(fixed)))
        fixed, inverse = np.unique(fixed, axis=0, return_inverse=True)
        return cls(fixed, None, np.asarray(inverse).ravel())

    def extreme_rows(self, directions: int = INITIAL_DIRECTIONS) -> list[int]:
        """The rows (of the fixed part) with the largest force and extreme along +-each axis
        and along ``directions`` fixed random directions (seeded: the same every run)."""
        W = self.fixed
        D = np.random.default_rng(0).normal(size=(directions, 6))
        picks = [int(np.argmax(np.linalg.norm(W[:, :3], axis=1)))]
        for k in range(6):
            picks += [int(np.argmax(W[:, k])), int(np.argmin(W[:, k]))]
        picks += np.argmax(W @ D.T, axis=0).tolist()
        return list(dict.fromkeys(picks))


def inertia_terms(
    P: np.ndarray, palette: tuple[ModuleType, ...], mass: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The inertia vector about the centre of mass as a linear function of the occupancy:
    ``j = sum_a z_a lin[a] + sum_(a, b) z_a z_b pair[(a, b)]`` over cell-type indices a = c K + t
    (cells at ``P`` (N, 3), total mass ``mass``), pairs of different cells a < b. From
    J = sum_a z_a (I_t + m_t (|p|^2 E - p p^T)) - M (|c|^2 E - c c^T), c = sum_a z_a m_a p_a / M.
    Returns (lin (N K, 6), pairs (Q, 2), pair (Q, 6))."""
    K = len(palette)
    N = len(P)
    E = np.eye(3)
    m = np.tile([t.mass for t in palette], N)  # (NK,)
    p = np.repeat(P, K, axis=0)  # (NK, 3)
    own = np.array([t.inertia for t in palette] * N)  # (NK, 3, 3)
    sq = np.einsum("ai,ai->a", p, p)
    outer = np.einsum("ai,aj->aij", p, p)
    shift = sq[:, None, None] * E - outer  # |p|^2 E - p p^T
    lin = to_vector(own + m[:, None, None] * shift - (m * m / mass)[:, None, None] * shift)
    a, b = np.triu_indices(N * K, k=1)
    keep = a // K != b // K  # one type per cell: z_a z_b = 0 within a cell
    a, b = a[keep], b[keep]
    dot = np.einsum("ai,ai->a", p[a], p[b])
    sym = 0.5 * (np.einsum("ai,aj->aij", p[a], p[b]) + np.einsum("ai,aj->aij", p[b], p[a]))
    pair = -(2.0 * m[a] * m[b] / mass)[:, None] * to_vector(dot[:, None, None] * E - sym)
    return lin, np.column_stack([a, b]), pair


# ---------------------------------------------------------------------------- the program
@dataclass
class LevelProgram:
    """The program of level ``n`` and one mass group over a growing subset ``rows`` of the
    demand's rows, with cuts excluding rejected occupied sets (``cuts``)."""

    problem: SearchProblem
    n: int
    group: Group
    demand: Demand
    rows: list[int] = field(default_factory=list)
    cuts: list[np.ndarray] = field(default_factory=list)

    def __post_init__(self) -> None:
        p, n = self.problem, self.n
        self.cells = window(n)
        self.N = len(self.cells)
        self.K = len(p.palette)
        self.R = p.palette[0].n_rotors
        self.edges = directed_edges(self.cells)
        self.P = np.zeros((self.N, 3))
        self.P[:, :2] = self.cells * p.palette[0].side
        blocks = []  # (6, N K R): column of rotor j of type t at cell c, window frame
        for cx, cy, _ in self.P:
            for m in p.palette:
                d = m.directions.T
                shift = np.stack([cy * d[2], -cx * d[2], cx * d[1] - cy * d[0]])
                blocks.append(np.vstack([d, m.columns[3:] + shift]))
        self.A = sp.coo_matrix(np.hstack(blocks))
        self.weights = np.array([m.mass for m in p.palette]) / self.group.mass  # m_t / M
        self.root = np.flatnonzero(self.cells[:, 1] == 0)  # root candidates: row 0
        self.NK = self.N * self.K
        self.NKR = self.NK * self.R
        self.diameter = float(np.linalg.norm(self.P, axis=1).max())
        if self.demand.per_inertia is not None:
            self.lin, self.pairs, self.pair = inertia_terms(self.P, p.palette, self.group.mass)
            own = max(float(np.abs(m.inertia).max()) for m in p.palette)
            # |j|_2 <= sqrt(6) max |J_ab|, |J_ab| <= n (own + m_max |p_a - c|^2), |p_a - c| <=
            # sqrt(2) diameter in the window
            self.j_max = 3.0 * n * (own + 2.0 * max(m.mass for m in p.palette) * self.diameter**2)
        else:
            self.pairs = np.zeros((0, 2), dtype=int)
        self.off_y = self.NK
        self.off_p = self.off_y + len(self.root)
        self.off_g = self.off_p + len(self.pairs)
        self.off_v = self.off_g + len(self.edges)

    def nonzeros(self, t: int) -> int:
        """About how many constraint nonzeros the program with t wrenches has."""
        per = 2 * self.NKR + 6 * self.NKR + 3 * self.NK + 6 * len(self.pairs)
        return t * per + 6 * len(self.edges) + 4 * self.NK + 3 * len(self.pairs)

    def _structure_rows(self, add) -> None:
        """Rows on the occupancy, roots, products and flow."""
        n, K, N = self.n, self.K, self.N
        z = np.arange(self.NK).reshape(N, K)
        for cls, k in zip(self.group.classes, self.group.counts, strict=True):
            cols = z[:, list(cls)].ravel()
            add(cols, np.ones(len(cols)), k, k)  # modules of each mass class
        if K > 1:
            for c in range(N):
                add(z[c], np.ones(K), -np.inf, 1.0)  # one type per cell
        col0 = z[self.cells[:, 0] == 0].ravel()
        add(col0, np.ones(len(col0)), 1.0, np.inf)  # a cell in column 0
        ys = self.off_y + np.arange(len(self.root))
        add(ys, np.ones(len(ys)), 1.0, 1.0)  # one root
        for i, c in enumerate(self.root):
            add([ys[i], *z[c]], [1.0, *(-np.ones(K))], -np.inf, 0.0)  # on an occupied cell
            for b in self.root[:i]:  # the first occupied cell of row 0
                add([ys[i], *z[b]], [1.0, *np.ones(K)], -np.inf, 1.0)
        for q, (a, b) in enumerate(self.pairs):  # w = z_a z_b (McCormick, exact for binaries)
            w = self.off_p + q
            add([w, a], [1.0, -1.0], -np.inf, 0.0)
            add([w, b], [1.0, -1.0], -np.inf, 0.0)
            add([a, b, w], [1.0, 1.0, -1.0], -np.inf, 1.0)
        cap = float(n - 1)
        for e, (a, b) in enumerate(self.edges):  # flow only between occupied cells
            g = self.off_g + e
            add([g, *z[a]], [1.0, *(-cap * np.ones(K))], -np.inf, 0.0)
            add([g, *z[b]], [1.0, *(-cap * np.ones(K))], -np.inf, 0.0)
        root_of = {int(c): int(ys[i]) for i, c in enumerate(self.root)}
        for c in range(N):  # inflow - outflow = x_c - n y_c
            into = self.off_g + np.flatnonzero(self.edges[:, 1] == c)
            out = self.off_g + np.flatnonzero(self.edges[:, 0] == c)
            cols = [*into, *out, *z[c]]
            vals = [1.0] * len(into) + [-1.0] * len(out) + [-1.0] * K
            if c in root_of:
                cols.append(root_of[c])
                vals.append(float(n))
            add(cols, vals, 0.0, 0.0)
        if n > 1:
            for c in range(N):  # an occupied cell has an occupied neighbour
                nbs = self.edges[self.edges[:, 0] == c, 1]
                add([*z[c], *z[nbs].ravel()], [*np.ones(K), *(-np.ones(len(nbs) * K))], -np.inf, 0)
        for cut in self.cuts:  # not exactly this occupied set
            cols = z[cut].ravel()
            add(cols, np.ones(len(cols)), -np.inf, float(n - 1))

    def build(self, relax: bool):
        """(c, constraints, integrality, bounds) for :func:`scipy.optimize.milp`."""
        r_i: list[np.ndarray] = []
        c_i: list[np.ndarray] = []
        v_i: list[np.ndarray] = []
        lb: list[float] = []
        ub: list[float] = []

        def add(cols, vals, lo, hi):
            cols = np.asarray(cols, dtype=int)
            r_i.append(np.full(len(cols), len(lb)))
            c_i.append(cols)
            v_i.append(np.asarray(vals, dtype=float))
            lb.append(lo)
            ub.append(hi)

        self._structure_rows(add)
        NK, NKR = self.NK, self.NKR
        lo, hi = -0.5 * TOL - MARGIN, 1.0 + 0.5 * TOL + MARGIN
        n_var = self.off_v + len(self.rows) * NKR
        low, high = np.zeros(n_var), np.ones(n_var)
        high[self.off_g : self.off_v] = float(self.n - 1)
        low[self.off_v :], high[self.off_v :] = lo, hi  # a thrust's lower bound: global
        D = self.demand
        for i, row in enumerate(self.rows):
            w = D.fixed[row]
            base = self.off_v + i * NKR
            size = float(np.linalg.norm(w))
            if D.per_inertia is not None:
                size += float(np.linalg.norm(D.per_inertia[row], 2)) * self.j_max
            eps = RESIDUAL_TOL * (1.0 + size) + MARGIN
            slack = np.array([eps] * 3 + [eps * (1.0 + self.diameter)] * 3)
            # A v - (m_t / M) z (p_c x F) (torque rows) - P j(z) = fixed, within the slack
            coef = np.zeros((6, NK))
            moment = np.cross(self.P, w[:3])  # (N, 3): p_c x F
            coef[3:] = -(moment[:, None, :] * self.weights[None, :, None]).reshape(NK, 3).T
            extra = []
            if D.per_inertia is not None:
                Pi = D.per_inertia[row]  # (6, 6)
                coef -= Pi @ self.lin.T
                extra = [(self.off_p + np.arange(len(self.pairs)), -(Pi @ self.pair.T))]
            first = len(lb)
            for k in range(6):
                nz = np.flatnonzero(coef[k])
                cols = [base + self.A.col[self.A.row == k], nz]
                vals = [self.A.data[self.A.row == k], coef[k, nz]]
                for idx, block in extra:
                    cols.append(idx)
                    vals.append(block[k])
                add(np.concatenate(cols), np.concatenate(vals), w[k] - slack[k], w[k] + slack[k])
            assert len(lb) == first + 6
        q = np.arange(NKR)
        zq = q // self.R  # the occupancy variable of each thrust
        for i in range(len(self.rows)):  # v - hi z <= 0
            base = self.off_v + i * NKR
            start = len(lb)
            r_i.append(np.concatenate([start + q, start + q]))
            c_i.append(np.concatenate([base + q, zq]))
            v_i.append(np.concatenate([np.ones(NKR), np.full(NKR, -hi)]))
            lb.extend([-np.inf] * NKR)
            ub.extend([0.0] * NKR)
        M = sp.csr_matrix(
            (np.concatenate(v_i), (np.concatenate(r_i), np.concatenate(c_i))),
            shape=(len(lb), n_var),
        )
        integrality = np.zeros(n_var)
        if not relax:
            integrality[: self.off_p] = 1  # occupancy and roots (products follow)
        cons = LinearConstraint(M, np.array(lb), np.array(ub))
        return np.zeros(n_var), cons, integrality, Bounds(low, high)

    def solve(self, relax: bool, seconds: float) -> OptimizeResult:
        """HiGHS's result (scipy's OptimizeResult) within ``seconds``, building included, in
        the worker of :mod:`.milp_worker` (killed ``GRACE`` s past the limit or at a Ctrl-C or
        SIGTERM; one that ends without an answer leaves the program undecided, status 1, as a
        time-out does). At most :data:`IN_PROCESS_NONZEROS` nonzeros: solved here outside the
        main thread or while another thread holds the worker, tried here while it boots."""
        t0 = now()
        c, cons, integrality, bounds = self.build(relax)
        left = seconds - (now() - t0)
        options = {"time_limit": max(left, 1e-3), "presolve": True}
        kwargs = dict(c=c, constraints=cons, integrality=integrality, bounds=bounds)
        small = cons.A.nnz <= IN_PROCESS_NONZEROS
        if small and (not milp_worker.in_main_thread() or milp_worker.busy()):
            return milp(**kwargs, options=options)
        if small and not milp_worker.booted():
            short = min(options["time_limit"], milp_worker.BOOT_TRY)
            res = milp(**kwargs, options={**options, "time_limit": short})
            if res.status != TIME_LIMIT or short == options["time_limit"]:
                return res
            left = seconds - (now() - t0)
        try:
            reply = milp_worker.solve({**kwargs, "options": options}, left) if left > 0 else None
        except milp_worker.WorkerError as exc:  # the next solve starts another worker
            return OptimizeResult(status=1, x=None, message=str(exc))
        if reply is None:
            return OptimizeResult(status=1, x=None, message="time limit reached (worker killed)")
        status, x, message = reply
        return OptimizeResult(status=status, x=x, message=message)

    def occupied(self, x: np.ndarray) -> tuple[np.ndarray, list[int]]:
        """(occupied cell indices, the type index of each) of a solution."""
        z = x[: self.NK].reshape(self.N, self.K)
        cells = np.flatnonzero(z.max(axis=1) > 0.5)
        return cells, [int(np.argmax(z[c])) for c in cells]

    def structure(self, cells: np.ndarray, types: list[int]) -> Structure | None:
        """The structure of occupied cells (None unless n connected cells)."""
        coords = tuple((int(x), int(y)) for x, y in self.cells[cells])
        if len(coords) != self.n or not is_connected(coords):
            return None
        palette = self.problem.palette
        if len(palette) == 1:
            return Structure.from_trusted(coords, palette[0])
        return Structure.from_trusted(coords, modules=tuple(palette[t] for t in types))


def relaxation_feasible(problem: SearchProblem, n: int, seconds: float) -> bool | None:
    """Is the LP relaxation of level n feasible for some mass group (True), infeasible for
    every one (False: no structure of n modules works), or undecided in ``seconds`` (None)?"""
    t0 = now()
    for group in level_groups(problem, n):
        demand = Demand.of(problem, group.mass)
        prog = LevelProgram(problem, n, group, demand, rows=list(range(len(demand.fixed))))
        left = seconds - (now() - t0)
        if left <= 0 or prog.nonzeros(len(prog.rows)) > MAX_NONZEROS:
            return None
        res = prog.solve(relax=True, seconds=left)
        if res.status != INFEASIBLE:
            return True if res.status == 0 else None
    return False
