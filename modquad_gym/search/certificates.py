"""Certificates of certified answers: a file an outsider checks with :mod:`modquad_gym.proofcheck`.

A certificate holds the task (its rotor-wrench model, linear in a structure's mass and inertia),
``f_max``, the module types' rotor data, the fault model (none, rotor or module), the answer with
thrusts for every task wrench (and after every single failure of a tolerant answer) and, for every
smaller level, a bound that covers the whole level or one proof per structure: a separating
direction (an index into shared directions), the task wrench it separates and, for a tolerant
search, the failure. Format: ``docs/certificates.md``.

It is made after the search, from the problem and the answer alone (whichever search found it):
the structures of each smaller level are taken in the checker's canonical order and each is
separated by a direction already known, the ones left by the oracle's LP duals
(:meth:`~modquad_gym.oracle.Zonotope.separating_direction`) or, where a dual is too weak for the
strict test, by the wrench's own directions (:mod:`.certificate_directions`), which then serve
the rest; every test is the checker's own formula (:func:`~modquad_gym.proofcheck.separation`),
so a certificate made here passes the checker unless the answer is wrong.
"""

from __future__ import annotations

import gzip
import json
from pathlib import Path

import numpy as np

from modquad_gym import proofcheck as pc
from modquad_gym.core.bars import progress_bar
from modquad_gym.search import certificate_directions as separations
from modquad_gym.search.certificate_answer import CertificateError, answer

MAX_STRUCTURES = 2_000_000
"""Most structures of a level proved one by one (level 13 of one type: 1.9 million)."""

STRICT = 4.0
"""A direction is used only where it separates with this many times the checker's tolerance."""


def check_fault(fault: str | None, fault_margin: float = 0.0) -> None:
    """Refuse what the format does not cover, before any search (it proves no margin)."""
    if fault not in (None, "rotor", "module") or fault_margin:
        what = f"a margin after it (fault_margin={fault_margin:g})" if fault_margin else repr(fault)
        raise CertificateError(f"certificates cover fault rotor or module, not {what}")


def make(result, problem, progress: bool = False, bounds: bool = True) -> dict:
    """The certificate (a JSON-ready dict) of a certified ``result`` of ``problem`` (a
    :class:`~modquad_gym.search.problem.SearchProblem`). ``progress`` shows a bar per level;
    ``bounds=False`` proves every level structure by structure (to measure what bounds save)."""
    if not result.certified:
        raise CertificateError("only a certified answer has a certificate (this one is not)")
    check_fault(problem.fault, problem.fault_margin)
    T, task, f_max, fault = _parts(problem)
    model = problem.model
    cert: dict = {"format": pc.FORMAT, "version": pc.VERSION, "f_max": f_max, "fault": fault}
    cert["types"] = [type_dict(m) for m in problem.palette]
    cert["task"] = {"name": getattr(problem.task, "name", None), "kind": problem.kind,
                    "base": task[0].tolist(), "per_mass": task[1].tolist(),
                    "per_inertia": task[2].tolist() if model.uses_inertia else None}  # fmt: skip
    if result.structure is None:
        cert["minimum"], cert["n_max"], top = None, int(result.n_max), int(result.n_max)
    else:
        cert["minimum"] = top = result.n_modules
        cert["answer"] = answer(result.structure, problem, T, task, f_max, fault)
        top -= 1
    prover = _Prover(T, task, f_max, fault, problem, bounds)
    # top down: the bound of a level usually covers the smaller ones too
    cert["levels"] = [prover.level(n, progress) for n in range(top, 0, -1)][::-1]
    used = sorted({int(p) for e in cert["levels"] for p in _directions_of(e)})
    index = np.full(len(prover.pool) + 1, -1)
    index[used] = np.arange(len(used))
    for e in cert["levels"]:
        if "bound" in e:
            e["bound"]["direction"] = int(index[e["bound"]["direction"]])
        else:
            e["direction"] = index[np.asarray(e["direction"])].tolist()
    cert["directions"] = np.array(prover.pool)[used].reshape(-1, 6).tolist()
    cert["producer"] = {"method": result.method}
    return cert


def check_levels(problem) -> int | None:
    """Before the search: refuse (CertificateError, the words :func:`make` would use after it)
    when a level below the search's proved bound (:func:`~.bounds.bound_levels`) cannot be
    proved (:func:`unprovable_levels`): every certified answer has at least that many modules,
    so its certificate proves that level. Else the smallest level from the bound up to n_max
    that cannot be proved, or None: the certificate of an answer above it, or of no structure
    up to n_max, will be refused; one of an answer at or below it will not, so whether it is
    refused depends on the answer, and nothing is refused here."""
    from modquad_gym.search.bounds import bound_levels

    check_fault(problem.fault, problem.fault_margin)
    levels = unprovable_levels(problem, range(1, problem.n_max + 1))
    lower = bound_levels(problem)
    below = [n for n in levels if n < lower]
    if below:  # the highest: the certificate proves its levels top down
        raise CertificateError(_too_large(below[-1]))
    return levels[0] if levels else None


def unprovable_levels(problem, levels) -> list[int]:
    """The levels of ``levels`` a certificate of ``problem`` cannot prove, whatever its answer:
    more structures than :data:`MAX_STRUCTURES` (or modules than the checker enumerates) and no
    level bound covering them. Known before any search: at such a level the bound's candidate
    directions are the fixed ones (force normals, level directions), since every level above it
    is larger still, so none was proved one structure at a time (which finds the other
    directions); a pair whose margin before the checker's tolerance is not positive fails with
    it too."""
    T, task, f_max, fault = _parts(problem)
    D = _Prover(T, task, f_max, fault, problem)._candidates()
    out = []
    for n in levels:
        if n <= pc.MAX_ENUMERATED and pc.count(n, T.n) <= MAX_STRUCTURES:
            continue
        if bound_margins(T, task, f_max, fault, n, D).max() <= 0:
            out.append(n)
    return out


def _too_large(n: int) -> str:
    return (
        f"level {n}: no level bound covers it and it holds too many structures to prove one "
        f"by one (at most {MAX_STRUCTURES:,})"
    )


def _parts(problem):
    """(module types, task model arrays, f_max, fault) of ``problem``, as the checker reads
    them."""
    T = pc.Types([type_dict(m) for m in problem.palette])
    model = problem.model
    task = tuple(np.asarray(a, float) for a in (model.base, model.per_mass, model.per_inertia))
    return T, task, float(problem.f_max), problem.fault


def write(
    result, problem, path: str | Path, force: bool = False, *, what: str = "path", **options
) -> Path:
    """Write the certificate of ``result`` to ``path`` (gzip-compressed JSON when it ends in
    ``.gz``). ``path`` is checked before the proof is made and again once it is made, as every
    saver checks its file (:func:`~modquad_gym.core.outputs.check_output_file`): an existing
    file or link (one that appeared meanwhile too) is kept unless ``force``, a folder or a
    parent that cannot take the file is refused (OutputError; ``what`` names ``path`` there: a
    command's option, ``--certificate``, gets the advice ``--force``). ``options`` go to
    :func:`make`."""
    from modquad_gym.core.outputs import atomic_write, check_output_file
    from modquad_gym.core.validation import check_flag

    force = check_flag(force, "force")
    path = check_output_file(path, force=force, what=what)
    text = json.dumps(make(result, problem, **options), separators=(",", ":"))
    path = check_output_file(path, force=force, what=what)  # the proof may take a while

    def fill(tmp: Path) -> None:  # gzip without a name or time: the same bytes every time
        gz = path.name.endswith(".gz")
        tmp.write_bytes(gzip.compress(text.encode(), mtime=0) if gz else text.encode())

    return atomic_write(path, fill)


def _directions_of(entry: dict):
    return [entry["bound"]["direction"]] if "bound" in entry else entry["direction"]


def type_dict(m) -> dict:
    """A module type's entry of a certificate (its rotor data, side, drag ratio, mass, inertia)."""
    return {"name": m.name, "side": m.side, "c_tau": m.c_tau, "mass": m.mass,
            "inertia": np.asarray(m.inertia).tolist(), "positions": m.positions.tolist(),
            "directions": m.directions.tolist(), "spins": m.spins.tolist()}  # fmt: skip


class _Prover:
    """Finds the proof of each smaller level, keeping the directions found (``pool``)."""

    def __init__(self, T, task, f_max, fault, problem, bounds: bool = True) -> None:
        self.T, self.task, self.f_max, self.fault, self.problem = T, task, f_max, fault, problem
        self.bounds = bounds
        self.bound_pairs: list[tuple[int, int]] = []  # (direction, wrench) of bounds found
        self._fixed: np.ndarray | None = None
        self._forces = 0
        self.pool: list[np.ndarray] = []
        self.uses: list[int] = []

    # -- whole levels ------------------------------------------------------------------------
    def level(self, n: int, progress: bool) -> dict:
        bound = self._bound(n) if self.bounds else None
        if bound is not None:
            return {"n": n, "bound": {"direction": bound[0], "wrench": bound[1]}}
        total = pc.count(n, self.T.n) if n <= pc.MAX_ENUMERATED else None
        if total is None or total > MAX_STRUCTURES:
            raise CertificateError(_too_large(n))
        P, I, F = (np.full(total, -1, np.int64) for _ in range(3))
        bar = progress_bar(progress, f"certificate level {n}", " structures", total=total,
                           delay=0.5)  # fmt: skip
        for s, cells, types in pc.structures(n, self.T.n, self.T.rotors):
            self._block(cells, types, P[s : s + len(cells)], I[s : s + len(cells)],
                        F[s : s + len(cells)])  # fmt: skip
            if bar is not None:
                bar.update(len(cells))
        if bar is not None:
            bar.close()
        entry = {"n": n, "direction": P.tolist(), "wrench": I.tolist()}
        if self.fault is not None:
            entry["failure"] = F.tolist()
        return entry

    def _candidates(self) -> np.ndarray:
        """Directions a level bound may use: the palette's force-facet normals (the force
        bound's), the level bounds' fixed directions, and the directions found so far."""
        if self._fixed is None:
            from modquad_gym.search.bounds import force_normals, level_directions

            N = force_normals(list(self.problem.palette))
            self._forces = len(N)
            self._fixed = np.vstack([np.hstack([N, np.zeros_like(N)]), level_directions()])
        return np.vstack([self._fixed, *([np.array(self.pool)] if self.pool else [])])

    def _bound(self, n: int):
        """(direction index, wrench) of a bound covering level n, or None: a bound found for
        another level, else the candidate pair of the largest margin (:func:`bound_margins`),
        each confirmed by the checker's formula."""
        args = (self.T, self.task, self.f_max, self.fault, n)
        D = self._candidates()
        for p, i in self.bound_pairs:
            if pc.bound_margin(*args, self.pool[p], i) > 0:
                return p, i
        D = self._candidates()
        margins = bound_margins(*args, D[: self._forces])  # the force bound's first: fewer
        if margins.max() <= 0:
            margins = bound_margins(*args, D)
        p, i = np.unravel_index(int(np.argmax(margins)), margins.shape)
        if margins[p, i] <= 0 or pc.bound_margin(*args, D[p], int(i)) <= 0:
            return None
        self.bound_pairs.append((self._add(D[p]), int(i)))
        return self.bound_pairs[-1]

    def _add(self, d: np.ndarray) -> int:
        d = np.asarray(d, float) / np.linalg.norm(d)
        self.pool.append(d)
        self.uses.append(0)
        return len(self.pool) - 1

    # -- structure by structure --------------------------------------------------------------
    def _block(self, cells, types, P, I, F) -> None:
        T, task, f_max = self.T, self.task, self.f_max
        a, M, j, j_size = T.columns(cells.astype(float), types, sizes=True)
        L, t = len(cells), len(task[0])
        i, of = np.tile(np.arange(t), L), np.repeat(np.arange(L), t)  # every (structure, wrench)
        W, S = (
            pc.wrenches(task, i, M[of], x[of], b).reshape(L, t, 6)
            for x, b in ((j, False), (j_size, True))
        )  # the wrenches and their terms' sizes
        alive = np.ones(len(cells), bool)
        for p in np.argsort(-np.array(self.uses, dtype=float), kind="stable"):
            if not alive.any():
                break
            self._try(int(p), a, (W, S), alive, P, I)
        while alive.any():
            k = int(np.argmax(alive))
            worst: tuple = ()  # (excess, wrench) of the clearest miss tried
            for d, wrench, excess in separations.candidates(a[k].T, W[k], f_max):
                worst = max(worst, (excess, wrench))
                p = self._add(d)
                self._try(p, a, (W, S), alive, P, I)
                if not alive[k]:
                    break
            else:  # no direction tried separates it intact: with a fault, one after a failure
                what = f"the structure {cells[k].tolist()} (types {types[k].tolist()})"
                if self.fault is None and worst:
                    raise CertificateError(separations.too_close(what, *worst[::-1], STRICT))
                if self.fault is None:
                    raise CertificateError(
                        f"{what} of {len(cells[k])} modules satisfies the task: the answer is "
                        "not a minimum"
                    )
                P[k], I[k], F[k] = self._failure(a[k], (W[k], S[k]), cells[k], types[k])
                alive[k] = False

    def _try(self, p: int, a, wrenches, alive, P, I) -> None:
        """Assign direction p to the alive structures it separates (strictly); ``wrenches``:
        (their task wrenches, those wrenches' term magnitudes)."""
        W, S = wrenches
        d = self.pool[p]
        idx = np.flatnonzero(alive)
        values = W[idx] @ d  # (L, t)
        i = values.argmax(axis=1)
        w, size = W[idx, i], S[idx, i]
        margin = pc.separation(a[idx], w, np.broadcast_to(d, w.shape), self.f_max, size=size)
        tol = pc.separation_tolerance(a[idx], size, d, self.f_max)
        hit = margin > (STRICT - 1.0) * tol
        P[idx[hit]], I[idx[hit]] = p, i[hit]
        alive[idx[hit]] = False
        self.uses[p] += int(hit.sum())

    def _failure(self, a, wrenches, cells, types):
        """(direction, wrench, failure) after which one intact-feasible structure fails
        (``wrenches``: its task wrenches and their term magnitudes)."""
        W = wrenches[0]
        n, r = len(cells), self.T.rotors
        failures = np.arange(n * r if self.fault == "rotor" else n)
        offs = pc.failed_columns(self.fault, failures, n, r)
        got = self._pool_failure(a, wrenches, offs)
        if got is not None:
            return got[0], got[1], int(failures[got[2]])
        # each failure's LP dual first, then the other candidates of each
        tries = [separations.candidates(a[~off].T, W, self.f_max) for off in offs]
        worst: tuple = ()  # (excess, wrench, failure) of the clearest miss tried
        for rest in (False, True):
            for f, (off, found) in enumerate(zip(offs, tries)):
                for d, i, excess in found:
                    worst = max(worst, (excess, i, f))
                    p = self._add(d)
                    got = self._pool_failure(a, wrenches, off[None], [p])
                    if got is not None:
                        return p, got[1], int(failures[f])
                    if not rest:
                        break
        what = f"the structure {cells.tolist()} (types {types.tolist()})"
        if worst:
            f = worst[2]
            what = f"{what}, after {self.fault} {f + 1} (1-based) fails,"
            raise CertificateError(separations.too_close(what, worst[1], worst[0], STRICT))
        raise CertificateError(
            f"{what} tolerates every single {self.fault} failure: the answer is not a minimum"
        )

    def _pool_failure(self, a, wrenches, offs, among=None):
        """(direction, wrench, index into ``offs``) of a pool direction (or one of ``among``)
        that separates a task wrench from the structure (columns ``a``) after a failure (rows
        of ``offs``: the failed columns), strictly; None when none does."""
        W, S = wrenches
        idx = np.arange(len(self.pool)) if among is None else np.array(among)
        if not len(idx):
            return None
        D = np.array(self.pool)[idx]  # (P, 6)
        plus = pc.support_terms(D @ a.T)  # (P, m)
        h = self.f_max * (plus.sum(axis=1)[:, None] - plus @ offs.T)  # (P, F)
        values = D @ W.T  # (P, t)
        best = values.argmax(axis=1)
        tol = pc.separation_tolerance(a, S[best], D, self.f_max)
        margin = values.max(axis=1)[:, None] - h - STRICT * tol[:, None]  # (P, F)
        p, f = np.unravel_index(int(np.argmax(margin)), margin.shape)
        if margin[p, f] <= 0:
            return None
        self.uses[idx[p]] += 1
        return int(idx[p]), int(best[p]), int(f)


def bound_margins(T, task, f_max, fault, n, D) -> np.ndarray:
    """(P, t) :func:`~modquad_gym.proofcheck.bound_margin` of every direction (rows of D) and
    wrench at once, up to its tolerance term (a search for the best pair)."""
    base, per_mass, per_inertia = task
    R = (n - 1) * T.l
    corners = np.array([[R, 0, 0], [-R, 0, 0], [0, R, 0], [0, -R, 0]])
    p = T.pos[:, None] + corners[None, :, None, :]  # (K, 4, r, 3)
    dirs = np.broadcast_to(T.dirs[:, None], p.shape)
    tau = np.cross(p, dirs) + (T.spins * T.c_tau[:, None])[:, None, :, None] * dirs
    da = np.concatenate([dirs, tau], axis=3) @ D.T  # (K, 4, r, P)
    H = f_max * pc.support_terms(da).sum(axis=2).max(axis=1).T  # (P, K)
    loss = np.zeros(len(D))
    if fault is not None:
        force = np.maximum(np.einsum("krq,pq->pkr", T.dirs, D[:, :3]), 0.0)
        per = force.max(axis=2) if fault == "rotor" else force.sum(axis=2)  # (P, K)
        loss = np.where(np.any(D[:, 3:], axis=1), 0.0, f_max * per.min(axis=1))
    dP = np.abs(np.einsum("pq,tqc->ptc", D, per_inertia))  # (P, t, 6)
    inertia = dP @ (np.abs(T.J) + T.mass[:, None] * R * R).T  # (P, t, K)
    value = (D @ base.T)[:, :, None] + n * T.mass * (D @ per_mass.T)[:, :, None] - n * inertia
    return (value - n * H[:, None, :] + loss[:, None, None]).min(axis=2)
