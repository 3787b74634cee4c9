"""Oracle accuracy: each method's gamma against the exact gamma, on stock structures and on
matrices of growing condition number, with the decisions it gets wrong.

    python -m benchmarks.oracle_accuracy [--directions 60] [--seeds 0 1 2 3] [--out results]
                                         [--force]

Writes ``results/oracle_accuracy.md``, the numbers :mod:`modquad_gym.oracle.tolerance` and
``docs/oracle.md`` quote. Two tables:

* **Stock structures** (1 module, a line of 6, 2 x 2, 64 t45 modules, 128 mixed ones; f_max 1
  and 1e6): wrenches of known gamma s, boundary points ``A u*`` (``u*`` the bang-bang maximiser
  of ``y . A u``, so gamma is exactly 1; y rounded to integers for every third direction, to hit
  the lattice's degenerate facets and edges) scaled about the centre by s in {1, 1 + TOL -+ 2
  BAND, 0.3, 1.5}. Per method the worst ``|gamma - s|``, the most it undercuts s, and the wrong
  decisions; "walk" is the compiled walk alone, where it reaches the optimum.
* **Condition** (6 x 8 matrices with singular values (1, 1, 1, 1, 1, 1 / cond), wrenches
  ``A u`` with u leaning on the weak direction): the exact gamma is a rational certificate (the
  optimal basis of HiGHS on the raw A, solved in fractions; primal value = dual bound), so the
  error of every method, the same reduced coordinates for all, is measured exactly.
"""

from __future__ import annotations

from fractions import Fraction

import numpy as np

from benchmarks.common import (
    Distinct,
    bench_args,
    int_option,
    markdown_table,
    report_page,
    run_main,
    seed_option,
    write_text,
)
from modquad_gym.geometry.module import STOCK_TYPES
from modquad_gym.geometry.structure import Structure
from modquad_gym.oracle import BAND, METHODS, TOL, Zonotope, allocate, gamma_with
from modquad_gym.oracle.lp import HIGHS_OPTIONS

SCALES = (1.0, 1.0 + TOL - 2 * BAND, 1.0 + TOL + 2 * BAND, 0.3, 1.5)
CONDITIONS = (1e4, 1e5, 1e6, 1e7, 3e7, 1e8, 5e8)


def stock_structures() -> dict[str, np.ndarray]:
    """The stock structures measured, by name: their configuration matrices."""
    mixed = [STOCK_TYPES[t] for t in ("t45", "t45m", "flat", "t30")]
    lattice = [(i, j) for i in range(8) for j in range(8)]
    grid = [(i, j) for i in range(8) for j in range(16)]
    return {
        "1 module (rank 4)": Structure([(0, 0)]).configuration_matrix(),
        "line of 6 (rank 5)": Structure([(0, i) for i in range(6)]).configuration_matrix(),
        "2 x 2": Structure([(0, 0), (0, 1), (1, 0), (1, 1)]).configuration_matrix(),
        "64 t45 (8 x 8)": Structure(lattice).configuration_matrix(),
        "128 mixed (8 x 16)": Structure(
            grid, modules=[mixed[k % 4] for k in range(128)]
        ).configuration_matrix(),
    }


def condition_of_stock_types() -> list[dict]:
    """Per stock module type: the largest condition number (largest over smallest kept singular
    value) and the largest cut singular value (relative to the largest) over lines of 1 to 128
    modules and lattices to 8 x 16."""
    shapes = [[(0, i) for i in range(n)] for n in (1, 2, 3, 6, 32, 128)]
    shapes += [[(i, j) for i in range(a) for j in range(b)] for a, b in ((2, 2), (8, 8), (8, 16))]
    rows = []
    for name, module in STOCK_TYPES.items():
        cond, cut = 0.0, 0.0
        for cells in shapes:
            A = Structure(cells, module=module).configuration_matrix()
            S, rank = np.linalg.svd(A, compute_uv=False), Zonotope(A).rank
            cond = max(cond, S[0] / S[rank - 1])
            cut = max(cut, float(S[rank:].max(initial=0.0)) / S[0])
        rows.append({"module type": name, "largest condition": f"{cond:.2g}",
                     "largest cut": f"{cut:.1e}"})  # fmt: skip
    return rows


def known_gammas(A, f_max: float, rng, n: int) -> tuple[np.ndarray, np.ndarray]:
    """(W, s): n directions' boundary points scaled by each of SCALES (module docstring)."""
    c = A.sum(axis=1) * (f_max / 2.0)
    W, s_ = [], []
    for k in range(n):
        y = rng.normal(size=6)
        y = np.round(y) if k % 3 == 0 else y
        w = A @ np.where(A.T @ y > 0, f_max, 0.0)
        for s in SCALES:
            W.append(c + s * (w - c))
            s_.append(s)
    return np.array(W), np.array(s_)


def walk_gammas(z: Zonotope, W: np.ndarray) -> np.ndarray:
    """The compiled walk's gammas alone (nan where it gives up: the methods then ask DAQP)."""
    from modquad_gym.oracle import kernels

    R, _ = z.reduce(W)
    G, P, k = kernels.walk_view(z)
    out = np.empty(len(W))
    R = np.ascontiguousarray(R * k)
    kernels.gamma_rows(G, P, kernels.prepare(G, P), R, np.inf, out, np.empty((0, z.rank)))
    return out


def stock_rows(directions: int, seeds: list[int]) -> list[dict]:
    """One row per (stock structure, f_max): each method's worst error and undercut over the
    wrenches of every seed."""
    rows = []
    for name, A in stock_structures().items():
        for f_max in (1.0, 1e6):
            drawn = [known_gammas(A, f_max, np.random.default_rng(q), directions) for q in seeds]
            W, s = np.concatenate([d[0] for d in drawn]), np.concatenate([d[1] for d in drawn])
            z = Zonotope(A, f_max)
            row = {"structure": name, "f_max": f"{f_max:g}", "wrenches": len(W)}
            walk = walk_gammas(z, W)
            done = np.isfinite(walk)
            row["walk err"] = f"{np.abs(walk[done] - s[done]).max(initial=0.0):.1e}"
            row["walk gave up"] = int(np.count_nonzero(~done))
            for method in METHODS:
                gamma = gamma_with(z, W, method)
                row[f"{method} err"] = f"{np.abs(gamma - s).max():.1e}"
                row[f"{method} under"] = f"{max(0.0, float((s - gamma).max())):.1e}"
            rows.append(row)
    return rows


def conditioned(cond: float, rng) -> tuple[np.ndarray, list[np.ndarray]]:
    """A 6 x 8 matrix of condition ``cond`` and 12 wrenches leaning on its weak direction."""
    U, _ = np.linalg.qr(rng.normal(size=(6, 6)))
    V, _ = np.linalg.qr(rng.normal(size=(8, 6)))
    A = (U * np.array([1, 1, 1, 1, 1, 1 / cond])) @ V.T
    W = []
    for _ in range(12):
        u = 0.5 + rng.uniform(0.1, 0.5) * (V[:, 5] + 0.3 * rng.normal(size=8))
        W.append(A @ np.clip(u, 0.02, 0.98))
    return A, W


def _solve(M: list[list[Fraction]], v: list[Fraction]) -> list[Fraction] | None:
    """M^-1 v in fractions (Gauss-Jordan); None when M is singular."""
    n = len(M)
    M = [row[:] + [v[i]] for i, row in enumerate(M)]
    for c in range(n):
        p = next((i for i in range(c, n) if M[i][c] != 0), None)
        if p is None:
            return None
        M[c], M[p] = M[p], M[c]
        for i in range(n):
            if i != c and M[i][c] != 0:
                f = M[i][c] / M[c][c]
                M[i] = [a - f * b for a, b in zip(M[i], M[c], strict=True)]
    return [M[i][n] / M[i][i] for i in range(n)]


def certified_gamma(A: np.ndarray, w: np.ndarray) -> Fraction | None:
    """The exact gamma of the float inputs (full-rank A, f_max 1) from the optimal basis of
    HiGHS on the raw A: the dual vertex y (b . y = 1, a_j . y = 0 on the 5 most central
    columns) gives the bound 1 / sum_j |a_j . y|, the primal solve an allocation reaching it;
    None when they do not meet (the basis guess failed)."""
    from scipy.optimize import linprog

    m = A.shape[1]
    b = 2.0 * w - A.sum(axis=1)
    eye, ones = np.eye(m), np.ones((m, 1))
    box = np.vstack([np.hstack([eye, -ones]), np.hstack([-eye, -ones])])  # |x_j| <= s
    res = linprog(np.r_[np.zeros(m), 1.0], A_ub=box, b_ub=np.zeros(2 * m),
                  A_eq=np.hstack([A, np.zeros((6, 1))]), b_eq=b, bounds=(None, None),
                  method="highs", options=HIGHS_OPTIONS)  # fmt: skip
    if res.status != 0:
        return None
    Ae = [[Fraction(float(A[i, j])) for j in range(m)] for i in range(6)]
    be = [2 * Fraction(float(w[i])) - sum(Ae[i]) for i in range(6)]
    T = [int(j) for j in np.argsort(np.abs(res.x[:m]))[:5]]
    y = _solve([be] + [[Ae[i][j] for i in range(6)] for j in T], [Fraction(1)] + [Fraction(0)] * 5)
    if y is None:
        return None
    ay = [sum(Ae[i][j] * y[i] for i in range(6)) for j in range(m)]
    gamma = 1 / sum(abs(v) for v in ay)
    sign = [0 if j in T else (1 if ay[j] > 0 else -1) for j in range(m)]
    M = [[Ae[i][j] for j in T] + [sum(sign[j] * Ae[i][j] for j in range(m))] for i in range(6)]
    x = _solve(M, be)
    if x is None or x[-1] != gamma or any(abs(v) > gamma for v in x[:-1]):
        return None
    return gamma


def condition_rows(seeds: list[int]) -> list[dict]:
    """One row per condition number: each method's and allocate's worst |gamma - exact| over
    one matrix and its 12 wrenches per seed."""
    rows = []
    for cond in CONDITIONS:
        err: dict[str, float] = dict.fromkeys([*METHODS, "allocate"], 0.0)
        certified = 0
        for seed in seeds:
            A, W = conditioned(cond, np.random.default_rng(seed))
            z = Zonotope(A)
            for w in W:
                exact = certified_gamma(A, w)
                if exact is None:
                    continue
                certified += 1
                for method in METHODS:
                    gamma = gamma_with(z, w[None], method)[0]
                    err[method] = max(err[method], abs(gamma - float(exact)))
                err["allocate"] = max(err["allocate"], abs(allocate(A, w)[1] - float(exact)))
        rows.append({"condition": f"{cond:.0e}", "certified": certified}
                    | {k: f"{v:.1e}" for k, v in err.items()})  # fmt: skip
    return rows


def main(argv: list[str] | None = None) -> int:
    args = bench_args(
        argv,
        "python -m benchmarks.oracle_accuracy",
        __doc__.split("\n\n")[0],
        {
            "--directions": {
                "type": int_option(1, 10_000),
                "default": 60,
                "help": "directions per structure, f_max and seed (default 60)",
            },
            "--seeds": {
                "type": seed_option,
                "nargs": "+",
                "action": Distinct,
                "default": [0, 1, 2, 3],
                "help": "random seeds, each its own wrenches (default 0 1 2 3)",
            },
        },
        seed_help=None,
        outputs=("oracle_accuracy.md",),
    )
    seeds = " ".join(str(q) for q in args.seeds)
    command = f"python -m benchmarks.oracle_accuracy --directions {args.directions} --seeds {seeds}"
    stock = stock_rows(args.directions, args.seeds)
    notes = (
        f"Wrenches of known gamma s (s in {', '.join(f'{s:.8g}' for s in SCALES)}); "
        "`err` the worst |gamma - s|, `under` the most a gamma undercuts s."
    )
    cond = condition_rows(args.seeds)
    more = [
        "## Condition", "",
        "Worst |gamma - exact| per method (exact: a rational certificate) on 6 x 8 matrices of "
        "singular values (1, 1, 1, 1, 1, 1 / condition), 12 wrenches per seed.", "",
        markdown_table(cond),
    ]  # fmt: skip
    more += [
        "", "## Stock structures' condition", "",
        "Over lines of 1 to 128 modules and lattices to 8 x 16 of each stock type: the largest "
        "condition number (largest over smallest kept singular value) and the largest singular "
        "value the rank rule cuts, relative to the largest.", "",
        markdown_table(condition_of_stock_types()),
    ]  # fmt: skip
    page = report_page("Oracle accuracy", command, notes, stock, *more)
    write_text(args.out / "oracle_accuracy.md", page)
    print(page)
    return 0


if __name__ == "__main__":
    raise SystemExit(run_main(main, "oracle_accuracy"))
