"""An independent checker of minimum-structure certificates (numpy and the standard library only).

A certificate (format: ``docs/certificates.md``) claims that a structure of ``minimum`` modules
satisfies a task and that no structure with fewer modules does. This module verifies the claim
without any other part of modquad_gym: it rebuilds every configuration matrix from the rotor
data in the certificate, enumerates every smaller structure itself and checks each proof.

Why "valid" is sound (every test below in units of f_max: the task's wrenches and the answer's
thrusts divided by f_max, f_max = 1, each direction divided by its largest entry, so that no
tolerance underflows; a test that overflows is NaN or inf and fails):

* "Reaches": thrusts within T = :data:`THRUST_TOL` of [0, f_max] (the package oracle's rule,
  gamma <= 1 + 1e-6); the proofs exclude a slightly wider band (:data:`PROOF_BAND`) and more
  than the answer's residual, so two valid certificates of one task never contradict.
* The answer: for each task wrench w (and, with a fault, after each single failure, the failed
  columns forced to zero) the certificate gives thrusts u with ``-T f_max <= u <= (1 + T)
  f_max`` and each component of A u - w within :func:`residual_allowed`.
* A smaller structure with columns a_k reaches exactly the zonotope of such thrusts, whose
  support in a direction d is at most h(d) = f_max sum_k (max(0, d . a_k) + B |d . a_k|),
  B = :data:`PROOF_BAND` >= T. If
  d . w > h(d), no thrusts reach w: the structure fails the task (with a failure, the failed
  columns are left out of the sum: it fails after that failure, so it does not tolerate it).
  The test demands d . w - h(d) > :data:`SEPARATION_TOL` |d| (|s| + f_max sum_k |a_k|), s the
  sum of the magnitudes of w's terms (:func:`wrenches`): more than the answer's residual
  allowance and the round-off of computing w and both sides (a small multiple of 2^-53 times
  that scale), so a passing test cannot be a rounding artefact (nor can a level bound's: its
  tolerance scales with the magnitudes of its products' factors).
* Structures are enumerated by the checker's third file, ``proofcheck_shapes.py``, not read;
  a level proved structure by structure must give one proof per enumerated structure, in its
  order.
* A bound covers a whole level n without enumeration: a module centre lies within L1 distance
  R = (n - 1) side of the centre of mass (a convex combination of the centres, all within n - 1
  grid steps), so a module of type t adds at most H_t = f_max max_{|v|_1 <= R} sum_k
  (max(0, d . a_k(v)) + B |d . a_k(v)|) to the support, a convex function of v whose maximum
  is at one of the four vertices (+-R, 0), (0, +-R). The task value d . w_i(M, j) is affine in
  the structure's mass M and inertia vector j; each module adds at most |J_t| + m_t R^2 to each
  |j_c|. Both sides are affine in the module counts, so the bound holds for every mix of types
  when it holds for n modules of each type alone: d . w_i >= n H_t - (the least single-failure
  loss, with a fault) plus a margin, for every type t.

Tolerances: :data:`THRUST_TOL`, :data:`RESIDUAL_TOL`, :data:`SEPARATION_TOL`, :data:`BOUND_TOL`.
The file is read, and every field checked for its JSON type and shape before any proof, by the
checker's second file, ``proofcheck_format.py``; the work is bounded by the file's size (levels
listed, rotors per type, bytes of JSON: :mod:`proofcheck_format`), in memory by blocks.
Command line: ``python -m modquad_gym.proofcheck FILE`` or ``modquad check FILE``.
"""

from __future__ import annotations

import sys

import numpy as np

try:  # the checker's two other files: its format and its shapes (numpy, the standard library)
    from . import proofcheck_format as fmt
    from . import proofcheck_shapes as shapes
except ImportError:  # run as a file, python proofcheck.py: the files beside it (even with -I)
    import importlib.util
    from pathlib import Path

    def _beside(name: str):
        spec = importlib.util.spec_from_file_location(name, Path(__file__).with_name(name + ".py"))
        module = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(module)
        return module

    fmt, shapes = _beside("proofcheck_format"), _beside("proofcheck_shapes")

FORMAT, VERSION, CertificateFormatError = fmt.FORMAT, fmt.VERSION, fmt.CertificateFormatError
MAX_ENUMERATED, count, structures = shapes.MAX_ENUMERATED, shapes.count, shapes.structures
THRUST_TOL = 5e-7  # the answer's thrusts may leave [0, f_max] by this fraction: the oracle's rule
PROOF_BAND = 5.01e-7  # the band the proofs exclude: THRUST_TOL with room for the oracle's LP
RESIDUAL_TOL = 1e-11  # |A u - w| allowed per component, relative to its scale (residual_allowed)
SEPARATION_TOL = 5e-11  # relative margin of a separating direction: above the residual's
EPS = 2.0**-52  # twice the unit round-off: the round-off of a sum of k terms is below k EPS
BOUND_TOL = 1e-9  # relative margin of a level bound


class ProofError(Exception):
    """The certificate is well formed but a proof fails (the message names it)."""


load = fmt.load


def check_file(path: str, report=None) -> str:
    """:func:`check` of the certificate in ``path``; a format error names the file."""
    cert = load(path)
    try:
        return check(cert, report)
    except CertificateFormatError as e:
        raise CertificateFormatError(f"{path}: {e}") from None


# --- the physics ----------------------------------------------------------------------------
class Types:
    """The module types of a certificate as arrays, indexed by type."""

    def __init__(self, types: list) -> None:
        a = fmt.module_types(types)  # checked: shapes, signs, one side, symmetric inertia
        dirs = scaled(a["directions"])
        self.pos, self.spins = a["positions"], a["spins"]
        self.dirs = dirs / np.linalg.norm(dirs, axis=2, keepdims=True)
        self.side, self.c_tau, self.mass, J = a["side"], a["c_tau"], a["mass"], a["inertia"]
        r = self.spins.shape[1]
        self.J = np.stack([J[:, 0, 0], J[:, 1, 1], J[:, 2, 2], J[:, 0, 1], J[:, 0, 2],
                           J[:, 1, 2]], axis=1)  # fmt: skip
        self.n, self.rotors, self.l = len(types), r, float(self.side[0])

    def columns(self, cells: np.ndarray, types: np.ndarray, sizes: bool = False):
        """(columns (L, n r, 6), masses (L,), inertia vectors j (L, 6)) of structures: column k
        is [d_k ; p_k x d_k + spin_k c_tau d_k], p_k from the centre of mass; with ``sizes``,
        also the sums of the magnitudes of j's terms (L, 6), which bound its round-off (terms of
        opposite signs cancel)."""
        m = self.mass[types]
        M = m.sum(axis=1)
        c = (cells - np.einsum("ln,lni->li", m, cells)[:, None, :] / M[:, None, None]) * self.l
        p = self.pos[types] + np.concatenate([c, np.zeros(c.shape[:2] + (1,))], 2)[:, :, None]
        d = self.dirs[types]
        tau = np.cross(p, d) + (self.spins * self.c_tau[:, None])[types][..., None] * d
        a = np.concatenate([d, tau], axis=3).reshape(len(cells), -1, 6)
        x, y = c[..., 0], c[..., 1]
        own, parts = self.J[types], (y * y, x * x, x * x + y * y, -x * y, 0 * x, 0 * x)
        j = own.sum(axis=1) + np.stack([np.einsum("ln,ln->l", m, v) for v in parts], axis=1)
        if not sizes:
            return a, M, j
        size = np.stack([np.einsum("ln,ln->l", m, np.abs(v)) for v in parts], axis=1)
        return a, M, j, np.abs(own).sum(axis=1) + size


def scaled(v: np.ndarray) -> np.ndarray:
    """``v`` (..., k) with each row divided by its largest magnitude (a zero row stays zero):
    the same directions, none so small or so large that squaring it under- or overflows (a
    tolerance proportional to a norm that underflows to 0 would vanish)."""
    largest = np.abs(v).max(axis=-1, keepdims=True)
    return np.divide(v, largest, out=np.zeros_like(v), where=largest > 0)


def separation(a, w, d, f_max: float, off=None, size=None) -> np.ndarray:
    """(L,) d . w - h(d) - the tolerance: > 0 where d separates w from the structure's
    zonotope with thrusts within THRUST_TOL of the box (:func:`support_terms`; columns ``a``
    (L, m, 6), without the columns where ``off`` (L, m) is True); ``size``: the magnitudes of
    w's terms (:func:`wrenches`), which the tolerance scales with (default w itself)."""
    plus = support_terms(np.einsum("lkq,lq->lk", a, d))
    plus = plus if off is None else np.where(off, 0.0, plus)
    tol = separation_tolerance(a, w if size is None else size, d, f_max)
    return np.einsum("lq,lq->l", d, w) - f_max * plus.sum(axis=1) - tol


def separation_tolerance(a, size, d, f_max: float) -> np.ndarray:
    """SEPARATION_TOL |d| (|s| + f_max sum_k |a_k|): columns ``a`` (..., m, 6), wrench term
    magnitudes ``size`` (..., 6), directions ``d`` (..., 6), broadcast together."""
    scale = np.linalg.norm(size, axis=-1) + f_max * np.linalg.norm(a, axis=-1).sum(axis=-1)
    return SEPARATION_TOL * np.linalg.norm(d, axis=-1) * scale


def support_terms(da: np.ndarray) -> np.ndarray:
    """Each column's share max(0, d . a_k) + PROOF_BAND |d . a_k| of the support in direction d
    (per f_max) of the zonotope whose thrusts may leave [0, f_max] by a little more than the
    answer's band: a proof that no thrusts reach w holds for the answer's thrusts too
    (certificates of one task never contradict)."""
    return np.maximum(da, 0.0) + PROOF_BAND * np.abs(da)


def failed_columns(fault, failure: np.ndarray, n: int, rotors: int) -> np.ndarray:
    """(L, n rotors) bool: the columns each structure's failure index stops (-1: none)."""
    k = np.arange(n * rotors)[None, :]
    f = failure[:, None]
    if fault == "module":
        return (f >= 0) & (k // rotors == f)
    return (f >= 0) & (k == f)


def bound_margin(T: Types, task, f_max: float, fault, n: int, d: np.ndarray, i: int) -> float:
    """The least margin over the types of the level bound of n modules (module docstring):
    > 0 proves that no structure of n modules satisfies wrench i (direction d)."""
    base, per_mass, per_inertia = task
    R = (n - 1) * T.l
    corners = np.array([[R, 0, 0], [-R, 0, 0], [0, R, 0], [0, -R, 0]])
    p = T.pos[:, None] + corners[None, :, None, :]  # (K, 4, r, 3)
    dirs = T.dirs[:, None]
    tau = np.cross(p, dirs) + (T.spins * T.c_tau[:, None])[:, None, :, None] * dirs
    a = np.concatenate([np.broadcast_to(dirs, tau.shape), tau], axis=3)  # (K, 4, r, 6)
    H = f_max * support_terms(a @ d).sum(axis=2).max(axis=1)  # (K,): convex in the placement
    loss = 0.0
    if fault is not None and not np.any(d[3:]):
        force = np.maximum(T.dirs @ d[:3], 0.0)  # (K, r): placement-free
        loss = f_max * float((force.max(axis=1) if fault == "rotor" else force.sum(axis=1)).min())
    J = (np.abs(T.J) + T.mass[:, None] * R * R).T  # (6, K): |j_c| per module, at most
    inertia = np.abs(d @ per_inertia[i]) @ J  # (K,)
    value = d @ base[i] + n * T.mass * (d @ per_mass[i]) - n * inertia
    ad = np.abs(d)  # the tolerance scales with the terms' magnitudes (products that cancel)
    supports = f_max * (np.abs(a) @ ad).sum(axis=2).max(axis=1)  # (K,)
    terms = T.mass * (ad @ np.abs(per_mass[i])) + (ad @ np.abs(per_inertia[i])) @ J + supports
    scale = 1.0 + ad @ np.abs(base[i]) + n * terms
    return float((value - n * H + loss - BOUND_TOL * scale).min())


# --- the checks ------------------------------------------------------------------------------
def wrenches(task, i, M, j, size: bool = False) -> np.ndarray:
    """(L, 6) task wrenches i (L,) of structures of masses M (L,) and inertia vectors j; with
    ``size`` (j then the magnitudes of its terms, :meth:`Types.columns`), the sums of the
    wrenches' terms' magnitudes instead: what bounds their round-off (terms that cancel leave
    a small wrench with a large error)."""
    base, pm, pi = (np.abs(x) for x in task) if size else task
    return base[i] + M[:, None] * pm[i] + np.einsum("lqc,lc->lq", pi[i], j)


def _connected(cells: np.ndarray) -> bool:
    """Distinct cells, each reached from the first through neighbours (linear in the cells)."""
    cellset = set(map(tuple, cells.tolist()))
    seen, todo = {tuple(cells[0].tolist())}, [tuple(cells[0].tolist())]
    while todo:
        x, y = todo.pop()
        for near in ((x + 1, y), (x - 1, y), (x, y + 1), (x, y - 1)):
            if near in cellset and near not in seen:
                seen.add(near)
                todo.append(near)
    return len(seen) == len(cellset) == len(cells)


def check_answer(answer, T: Types, task, f_max: float, fault, minimum: int) -> None:
    """Verify the answer's thrusts; ``answer``: (cells, types, allocations) arrays."""
    cells, types, U = answer
    t, m = len(task[0]), minimum * T.rotors
    shape = (1 if fault is None else m if fault == "rotor" else minimum, t, m)
    if U.shape != shape:  # first: the cheapest test
        raise ProofError(f"answer.allocations: shape {U.shape}, needs {shape} (failures, "
                         "wrenches, rotors)")  # fmt: skip
    if len(cells) != minimum or types.shape != (minimum,) or not _connected(cells):
        raise ProofError(f"answer: needs {minimum} distinct connected cells, one type each")
    if types.min() < 0 or types.max() >= T.n:
        raise ProofError("answer.types: a type index outside the types")
    cells = cells - cells.min(axis=0)  # connected: each coordinate now below minimum
    a, M, j, j_size = T.columns(cells[None].astype(float), types[None], sizes=True)
    A, idx = a[0].T, np.arange(t)
    W, size = (wrenches(task, idx, np.repeat(M, t), np.repeat(x, t, axis=0), b)
               for x, b in ((j, False), (j_size, True)))  # fmt: skip
    fails = [np.zeros(m, bool)] if fault is None else list(
        failed_columns(fault, np.arange(shape[0]), minimum, T.rotors))  # fmt: skip
    if not np.all(np.isfinite(U)):
        raise ProofError("answer.allocations: a thrust is not a finite number")
    for f, off in enumerate(fails):
        u = U[f]
        where = f"answer: allocation of failure {f}" if fault else "answer: allocation"
        if np.any(u[:, off] != 0):
            raise ProofError(f"{where}: a failed rotor has thrust")
        low = np.flatnonzero(((u < -THRUST_TOL * f_max) | (u > (1 + THRUST_TOL) * f_max)).any(1))
        if len(low):
            raise ProofError(f"{where}: wrench {low[0]}: a thrust outside [0, f_max]")
        resid, allowed = np.abs(u @ A.T - W), residual_allowed(A[:, ~off], W, size, f_max)
        bad = np.flatnonzero(~(resid <= allowed).all(axis=1))  # NaN fails too
        if len(bad):
            k = bad[0]
            q = int(np.argmax(np.nan_to_num(resid[k] - allowed[k], nan=np.inf)))
            raise ProofError(f"{where}: wrench {k}: component {q} of A u differs from the "
                             f"wrench by {resid[k, q]:.3g}, {allowed[k, q]:.3g} allowed (less "
                             "where the wrench's terms round off)")  # fmt: skip


def residual_allowed(A, W, size, f_max: float) -> np.ndarray:
    """(t, 6) how far each component of A u may miss the wrenches W (t, 6): RESIDUAL_TOL of
    its own scale (f_max times the row's column magnitudes, plus the wrench component, plus
    f_max: one large torque buys no error in a force, and a row no rotor reaches keeps a
    floor), less the round-off of W (``size``: its terms' magnitudes) and of A u (a sum of m
    terms), which the claim must not lean on."""
    rows = f_max * np.abs(A).sum(axis=1)  # (6,)
    return RESIDUAL_TOL * (rows + np.abs(W) + f_max) - EPS * (A.shape[1] + 8) * (rows + size)


def check_level(entry, n, T: Types, task, f_max, fault, D) -> str:
    """Verify the proof of level n; returns how it was proved."""
    if "bound" in entry:
        p, i = entry["bound"]
        if not (0 <= p < len(D) and 0 <= i < len(task[0])):
            raise ProofError(f"level {n}: bound: direction or wrench index out of range")
        if not bound_margin(T, task, f_max, fault, n, D[p], i) > 0:  # NaN fails too
            raise ProofError(f"level {n}: bound: direction {p} does not exceed the level's support")
        return "bound"
    if n > MAX_ENUMERATED:
        raise ProofError(f"level {n}: only levels of 1 to {MAX_ENUMERATED} modules are enumerated")
    total = count(n, T.n)  # read off a table: the entries are compared before any enumeration
    for name, a in entry.items():
        if len(a) != total:
            raise ProofError(
                f"level {n}: {name}: has {len(a)} entries, there are {total} structures"
            )
    P, I = entry["direction"], entry["wrench"]  # noqa: E741
    F = entry["failure"] if fault else -np.ones(total, np.int64)
    if P.min() < 0 or P.max() >= len(D) or I.min() < 0 or I.max() >= len(task[0]):
        raise ProofError(f"level {n}: a direction or wrench index out of range")
    if F.max() >= (n * T.rotors if fault == "rotor" else n) or F.min() < -1:
        raise ProofError(f"level {n}: a failure index out of range")
    for s, cells, types in structures(n, T.n, T.rotors):
        sl = slice(s, s + len(cells))
        a, M, j, j_size = T.columns(cells.astype(float), types, sizes=True)
        off = failed_columns(fault, F[sl], n, T.rotors) if fault else None
        w, size = (wrenches(task, I[sl], M, x, b) for x, b in ((j, False), (j_size, True)))
        ok = separation(a, w, D[P[sl]], f_max, off, size) > 0
        if not ok.all():
            k = int(np.argmin(ok))
            after = f" after failure {F[s + k]}" if fault else ""
            raise ProofError(
                f"level {n}: structure {s + k} (cells {cells[k].tolist()}, types "
                f"{types[k].tolist()}): direction {P[s + k]} does not separate wrench "
                f"{I[s + k]}{after}"
            )
    return f"{total} structures"


def check(cert: dict, report=None) -> str:
    """Verify a certificate (a dict): a one-line summary if valid; raises :class:`ProofError`
    naming the first thing that fails, :class:`CertificateFormatError` for a malformed one.
    ``report(n, how)`` is called after each level."""
    c = fmt.parse(cert)  # every field checked for its type and shape first
    with np.errstate(all="ignore"):  # what overflows is refused: every test fails on inf or NaN
        return _checked(c, Types(cert["types"]), report, cert["task"]["name"])


def _checked(c: dict, T: Types, report, name: str | None) -> str:
    """:func:`check` of the parsed certificate ``c``, in units of its f_max (wrenches and
    thrusts divided by it, f_max 1: no tolerance underflows however small f_max is) with its
    directions :func:`scaled`."""
    f_max, fault, minimum, top, levels = c["f_max"], c["fault"], c["minimum"], c["top"], c["levels"]
    task = tuple(x / f_max for x in c["task"])
    if not all(np.isfinite(x).all() for x in task):
        raise CertificateFormatError(f"task: its wrench model over f_max ({f_max!r}) overflows")
    D = scaled(c["directions"])
    if minimum is not None:
        cells, types, U = c["answer"]
        check_answer((cells, types, U / f_max), T, task, 1.0, fault, minimum)
    if any(not 1 <= n <= top for n in levels):  # no set of 1..top: top may be huge
        raise ProofError(f"levels: proofs of levels outside 1..{top}")
    for n in range(1, top + 1):
        if n not in levels:
            raise ProofError(f"level {n}: no proof")
        how = check_level(levels[n], n, T, task, 1.0, fault, D)
        if report is not None:
            report(n, how)
    tolerant = f", tolerating any single {fault} failure" if fault else ""
    what = "the task" if name is None else f"the task {name!r}"
    if minimum is None:
        return f"valid: no structure of up to {_count(top, 'module')} satisfies {what}{tolerant}"
    return (f"valid: the minimum is {_count(minimum, 'module')}: the answer satisfies "
            f"{what} ({_count(len(task[0]), 'wrench')}){tolerant}; no structure of fewer "
            "modules does")  # fmt: skip


def _count(n: int, noun: str) -> str:
    return f"{n} {noun}" if n == 1 else f"{n} {noun}es" if noun.endswith("h") else f"{n} {noun}s"


def main(argv: list[str] | None = None) -> int:
    """``python -m modquad_gym.proofcheck FILE``: prints "valid ..." (exit 0), "invalid: ..."
    (exit 1) or "error: ..." for a file that is not a certificate (exit 2)."""
    args = sys.argv[1:] if argv is None else argv
    if len(args) != 1:
        print("usage: python -m modquad_gym.proofcheck CERTIFICATE.json[.gz]", file=sys.stderr)
        return 2
    try:
        print(check_file(args[0]))
        return 0
    except CertificateFormatError as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    except ProofError as e:
        print(f"invalid: {e}")
        return 1


if __name__ == "__main__":
    sys.exit(main())
