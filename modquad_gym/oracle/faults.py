"""Does a structure keep exerting a wrench after any failure of one kind? (fault tolerance)

A failure stops a set S of rotors: one rotor (``fault="rotor"``), the four of one module
(``fault="module"``; the module stays docked, so its mass still counts for ``external`` and
dynamic tasks, whose rotor wrenches do not change), any two rotors (``fault="rotor2"``) or a
module and then a rotor of another module (``fault="rotor+module"``, its mass kept too). The
structure then exerts the zonotope of A without the columns of S, Z_S = {A u : 0 <= u <= f_max,
u_S = 0}. A wrench is **tolerated** when it is feasible for Z_S for every failure S, each decided
by the oracle's tolerance rule on the matrix A_{-S} (:mod:`~modquad_gym.oracle.tolerance`); the
**fault margin** is the worst margin over the failures, so it is >= 0 exactly when the wrench is
tolerated. A required margin ``fault_margin=mu`` (thrust to spare while the controller does not
yet know of the failure) asks the fault margin to be >= mu: decided, once the plain tolerance
holds, on each A_{-S} with its thrust range shrunk about its centre by the factor 1 - mu; for
``rotor2`` and ``rotor+module`` also after each smaller failure they contain (``nested``).

Fast and exact (:class:`FaultTolerance`). Z_S is a subset of the intact zonotope, so a wrench
the intact structure cannot exert is tolerated by no failure (one compiled decision rejects
it). For the others, an allocation certificate serves every failure at once: with the intact
centred allocation x (G x = r, rotor j at (1 + x_j) f_max / 2) set to x_S = -1 (the failed
rotors off), the least-norm correction of the other rotors is ``K_S (1 + x_S)``, with ``K_S =
H_{:,S} (I - H_SS)^-1`` and ``H = V^T V`` the projection on the row space of G (Woodbury; the
same for every wrench, so built once per structure). Where the corrected allocation stays in
the cube (with the certificates' clearance GUARD) and solves the equations to round-off, the
wrench is tolerated under S. Most pairs are settled by bounds without scanning the correction;
the rest by the correction itself, an allocation found for an earlier failure, or an active set
that pins the rotors the correction took out of the cube (:mod:`.fault_kernels`). Every other
(wrench, failure) pair is decided by the oracle on A_{-S} itself (its own zonotope, built once
per failure). A failure that lowers the rank (I - H_SS singular: a single module, a line) is
always decided on A_{-S}.

A decision may carry a ``deadline`` (:func:`time.perf_counter` seconds, moved later by the
kernels compiled during it): the certificate then runs a chunk of about :data:`CHUNK_PAIRS`
pairs at a time and the per-failure decisions one failure at a time, and past the deadline it
raises :class:`DecisionInterruptedError`, so it is never taken as a proof nor a refutation.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from modquad_gym.core.compile_clock import from_perf_counter, now
from modquad_gym.core.validation import check_f_max, check_real, check_wrenches
from modquad_gym.oracle.backends import check_method, decide_with, margin_with
from modquad_gym.oracle.failures import (  # noqa: F401 - re-exported
    FAULTS,
    check_fault,
    check_fault_margin,
    failure_sets,
    module_failures,
)
from modquad_gym.oracle.fault_delay import DELAY_SLOPES, MAX_DELAY_S, margin_for_delay  # noqa: F401 - re-exported
from modquad_gym.oracle.tolerance import RESIDUAL_TOL, TOL
from modquad_gym.oracle.zonotope import Zonotope

_EXACT = 1e-9  # residual of a certificate's equations accepted, relative to 1 + |r|_inf

CHUNK_PAIRS = 4096
"""(wrench, failure) pairs the compiled certificate decides between two looks at the clock when
a decision has a deadline (at least one wrench: all its failures)."""


class DecisionInterruptedError(Exception):
    """A fault decision reached its deadline before it finished: neither a proof nor a
    refutation (the caller stops with what it had verified before)."""


class FaultTolerance:
    """Fault tolerance of one structure's matrix A against many wrenches.

    Args:
        A: the (6, m) configuration matrix.
        f_max: per-rotor thrust limit.
        failures: the column sets of the failures (:func:`failure_sets`).
        zonotope: the intact zonotope of A when the caller has it already.
        fault_margin: the worst margin a wrench must keep after each failure (0: feasible
            after it; :func:`check_fault_margin`).
        deadline: :func:`time.perf_counter` time a decision stops at (module docstring).

    ``tests`` counts the (wrench, failure) pairs decided by the oracle on A_{-S}; ``certified``
    those the shared allocation certificate settled, and ``paths`` how many each of its tests
    settled (:data:`~.fault_kernels.PATHS`).
    """

    def __init__(
        self,
        A: np.ndarray,
        f_max: float,
        failures: Sequence[np.ndarray],
        zonotope: Zonotope | None = None,
        fault_margin: float = 0.0,
        deadline: float | None = None,
    ) -> None:
        self.deadline = None if deadline is None else check_real(deadline, "deadline")
        self._due = None if deadline is None else from_perf_counter(self.deadline)  # search clock
        self.intact = zonotope if zonotope is not None else Zonotope(A, f_max)
        self.failures = [np.asarray(S, dtype=np.intp) for S in failures]
        self.fault_margin = check_fault_margin(fault_margin)
        self.tests = 0
        self.certified = 0
        self.breaker: tuple[int, int] | None = None  # (wrench, failure) that ended a decide
        self.paths = np.zeros(7, dtype=np.int64)  # pairs settled per test of the certificate
        self._zonotopes: dict[int, Zonotope | None] = {}
        self._shrunk: dict[int, tuple[Zonotope, np.ndarray] | None] = {}
        self._K: tuple[np.ndarray, ...] | None = None
        self._directions: tuple[np.ndarray, np.ndarray] | None = None

    def _on_time(self) -> None:
        """Raise :class:`DecisionInterruptedError` once the deadline has passed."""
        if self._due is not None and now() >= self._due:
            raise DecisionInterruptedError("the fault decision reached its deadline")

    # --- the failed structures ----------------------------------------------------------
    def failed(self, i: int) -> Zonotope | None:
        """The zonotope of A without the columns of failure i (None: no rotor is left)."""
        if i not in self._zonotopes:
            z = self.intact
            keep = np.ones(z.m, dtype=bool)
            keep[self.failures[i]] = False
            self._zonotopes[i] = Zonotope(z.A[:, keep], z.f_max) if keep.any() else None
        return self._zonotopes[i]

    def _decide_failed(self, i: int, W: np.ndarray, method: str) -> np.ndarray:
        self._on_time()
        self.tests += len(W)
        z = self.failed(i)
        if z is None:  # nothing left: only the zero wrench
            return _zero_rows(W, self.intact.f_max)
        return decide_with(z, W, method)

    def _decide_with_margin(self, i: int, W: np.ndarray, method: str) -> np.ndarray:
        """bool: is the margin of each wrench after failure i at least ``fault_margin``? The
        margin is 1 - gamma about the centre c = A_{-S} f_max / 2, so margin >= mu exactly when
        w - mu c lies in the zonotope of A_{-S} with thrusts up to (1 - mu) f_max (decided by
        the oracle with its tolerance rule: margin >= mu - TOL (1 - mu))."""
        self._on_time()
        self.tests += len(W)
        if i not in self._shrunk:
            z = self.failed(i)
            if z is None:
                self._shrunk[i] = None
            else:
                mu = self.fault_margin
                centre = 0.5 * z.f_max * z.A.sum(axis=1)
                self._shrunk[i] = (Zonotope(z.A, (1.0 - mu) * z.f_max), mu * centre)
        shrunk = self._shrunk[i]
        if shrunk is None:  # nothing left: every margin is 0 or -inf, below mu
            return np.zeros(len(W), dtype=bool)
        z, shift = shrunk
        return decide_with(z, W - shift, method)

    def _margin_failed(self, i: int, W: np.ndarray, method: str) -> np.ndarray:
        self.tests += len(W)
        z = self.failed(i)
        if z is None:
            return np.where(_zero_rows(W, self.intact.f_max), 0.0, -np.inf)
        return margin_with(z, W, method)

    # --- the shared certificate -----------------------------------------------------------
    def _corrections(self) -> tuple[np.ndarray, ...]:
        """The certificate's arrays (:func:`~.fault_corrections.corrections`), made once."""
        if self._K is None:
            from modquad_gym.oracle.fault_corrections import corrections

            self._K = corrections(self.intact, self.failures)
        return self._K

    def _certify(
        self, R: np.ndarray, stop: bool = False, trace: np.ndarray | None = None
    ) -> np.ndarray:
        """int8 (t, F) per centred reduced wrench (row of R, intact coordinates) and failure:
        1 certified tolerated, 0 certified not, -1 undecided. With ``stop`` the rows after the
        first pair certified not tolerated are left out (the array ends there). ``trace``
        (t, F) int8, if given, receives the index of the test that settled each pair
        (:data:`~.fault_kernels.PATHS`). With a deadline, a chunk of rows at a time
        (:data:`CHUNK_PAIRS`), looking at the clock before each."""
        from modquad_gym.oracle.active_set import workspace
        from modquad_gym.oracle.fault_kernels import certify_rows

        z = self.intact
        C, columns, starts, errors, up, down, lift, H = self._corrections()
        out = np.empty((len(R), len(self.failures)), dtype=np.int8)
        R = np.ascontiguousarray(R, dtype=float)
        P = np.ascontiguousarray(z.P)
        work = workspace(z.m)
        trace = np.zeros((0, 0), dtype=np.int8) if trace is None else trace
        step = len(R) if self.deadline is None else CHUNK_PAIRS // max(1, len(self.failures))
        step = max(step, 1)
        for a in range(0, len(R), step):
            self._on_time()
            b = min(a + step, len(R))
            done = certify_rows(R[a:b], z.G, P, H, z.dual, C, columns, starts, errors, up, down,
                                lift, _EXACT, stop, work, out[a:b], self.paths,
                                trace[a:b] if len(trace) else trace)  # fmt: skip
            last = out[a + done - 1] if done else None
            if done < b - a or (stop and last is not None and (last != 1).any() and
                                (stop == 2 or (last == 0).any())):  # fmt: skip
                return out[: a + done]
        return out

    def _screen(self, W: np.ndarray, cert: np.ndarray) -> None:
        """Mark in ``cert`` (0) the undecided pairs that a support rejects: with the failed
        rotors S off, the support of the (tolerance-widened) zonotope in a direction d is
        ``f_max sum_{j not in S} (max(0, d . a_j) + TOL / 2 |d . a_j|)``; a wrench beyond it in
        some d of a fixed set (each rotor's own direction, its opposite, and the coordinate
        axes) is not tolerated. Exact, like every rejection certificate."""
        undecided = cert == -1
        if not undecided.any():
            return
        if self._directions is None:
            z = self.intact
            A = z.A / np.maximum(np.linalg.norm(z.A, axis=0), 1e-300)
            D = np.vstack([A.T, -A.T, np.eye(6), -np.eye(6)])
            DA = D @ z.A  # (k, m)
            per_rotor = np.maximum(DA, 0.0) + 0.5 * TOL * np.abs(DA)
            h = per_rotor.sum(axis=1)
            loss = np.array([per_rotor[:, S].sum(axis=1) for S in self.failures])  # (F, k)
            self._directions = (D, z.f_max * (h[None] - loss))
        D, h_failed = self._directions
        rows = np.flatnonzero(undecided.any(axis=1))
        WD = W[rows] @ D.T  # (t', k)
        scale = 1.0 + np.abs(WD).max(axis=1)
        beyond = (WD[:, None, :] - h_failed[None]).max(axis=2)  # (t', F)
        rejected = beyond > 1e3 * RESIDUAL_TOL * scale[:, None]
        sub = cert[rows]
        sub[rejected & (sub == -1)] = 0
        cert[rows] = sub

    # --- the questions --------------------------------------------------------------------
    def decide(self, W: np.ndarray, method: str = "auto", *, stop_early: bool = False):
        """bool (t,): is each wrench (row of W) feasible after every failure (with at least
        ``fault_margin`` left)? With ``"auto"`` or ``"compiled"`` the shared certificate
        settles what it can; any other method decides every failure by itself (a reference).
        With ``stop_early`` the answer is only whether every wrench is tolerated (a bool): it
        stops at the first wrench that is not, and ``breaker`` names (row of W, failure) where
        a failure rules it out (None when the intact structure or the margin does). A margin
        is required after the plain tolerance holds (it needs it), failure by failure."""
        self.breaker = None
        ok = decide_with(self.intact, W, method)
        if stop_early and not ok.all():
            return False
        live = every = np.flatnonzero(ok)
        if not len(live) or not self.failures:
            return bool(ok.all()) if stop_early else ok
        if method in ("auto", "compiled"):
            R, _ = self.intact.reduce(W[live])
            if stop_early:  # the first undecided wrench at once, then the rest in a batch
                done = self._first_breaker(W, live, R, method)
                if done is False or done == len(live):
                    return done is not False and self._margin_holds(W, live, method)
                live, R = live[done:], R[done:]
            cert = self._certify(R, stop=1 if stop_early else 0)
            if len(cert) < len(live):  # stopped at a pair certified not tolerated
                self.breaker = (int(live[len(cert) - 1]), int(np.argmax(cert[-1] == 0)))
                return False
        else:
            cert = np.full((len(live), len(self.failures)), -1, dtype=np.int8)
            self._screen(W[live], cert)
        rows = np.flatnonzero(cert.min(axis=1, initial=1) < 1)  # wrenches with a pair left
        sub = cert[rows]
        self.certified += cert.size - int(np.count_nonzero(sub != 1))
        alive = np.ones(len(live), dtype=bool)
        alive[rows] = ~(sub == 0).any(axis=1)
        if stop_early and not alive.all():
            k = int(np.argmax(~alive[rows]))
            self.breaker = (int(live[rows[k]]), int(np.argmax(sub[k] == 0)))
            return False
        # failures with the most undecided wrenches first: they are the likely breakers
        undecided = (sub == -1) & alive[rows, None]
        order = np.flatnonzero(undecided.any(axis=0))
        order = order[np.argsort(-undecided[:, order].sum(axis=0), kind="stable")]
        for i in order:
            todo = rows[alive[rows] & (sub[:, i] == -1)]
            if len(todo):
                alive[todo] = self._decide_failed(int(i), W[live[todo]], method)
            if stop_early and not alive[todo].all():
                self.breaker = (int(live[todo[np.argmin(alive[todo])]]), int(i))
                return False
            if not alive.any():
                break
        if stop_early:
            return self._margin_holds(W, every, method)
        for i in range(len(self.failures) if self.fault_margin > 0.0 else 0):
            todo = np.flatnonzero(alive)
            if not len(todo):
                break
            alive[todo] = self._decide_with_margin(i, W[live[todo]], method)
        ok[live] = alive
        return ok

    def _first_breaker(self, W: np.ndarray, live: np.ndarray, R: np.ndarray, method: str):
        """For a decision that stops early: the certificate runs to the first pair certified
        not tolerated, or the first wrench with pairs it leaves undecided, which the oracle on
        A_{-S} decides at once (in a search most structures fail on the first such pair).
        Returns False (``breaker`` set) when that rules the structure out, else the number of
        rows of ``live`` done (all tolerated)."""
        cert = self._certify(R, stop=2)
        row, last = len(cert) - 1, cert[-1]
        self.certified += int(np.count_nonzero(cert[:-1] >= 0)) + int(np.count_nonzero(last == 1))
        if (last == 0).any():  # a pair certified not tolerated (the row may be unfinished)
            self.breaker = (int(live[row]), int(np.argmax(last == 0)))
            return False
        for i in np.flatnonzero(last == -1):
            if not self._decide_failed(int(i), W[live[row : row + 1]], method)[0]:
                self.breaker = (int(live[row]), int(i))
                return False
        return len(cert)

    def _margin_holds(self, W: np.ndarray, live: np.ndarray, method: str) -> bool:
        """Whether the wrenches of ``live`` (each tolerated) keep ``fault_margin`` after every
        failure."""
        for i in range(len(self.failures) if self.fault_margin > 0.0 else 0):
            if not self._decide_with_margin(i, W[live], method).all():
                return False
        return True

    def margin(self, W: np.ndarray, method: str = "auto") -> np.ndarray:
        """float (t,): the worst margin over the failures, >= 0 exactly when tolerated (where
        the LPs' round-off and the certificates disagree, within the oracle's agreement band,
        the margin takes its sign from :meth:`decide`, as :func:`~modquad_gym.oracle.margin`
        does)."""
        out = np.full(len(W), np.inf)
        for i in range(len(self.failures)):
            out = np.minimum(out, self._margin_failed(i, W, method))
        ok = self.decide(W, method)
        out[ok & (out < 0)] = 0.0
        out[~ok & (out >= 0)] = np.nextafter(-TOL, -np.inf)
        return out

    def worst_failure(self, W: np.ndarray, method: str = "auto") -> tuple[int, float]:
        """(index of the failure that leaves the smallest margin over the wrenches, that
        margin)."""
        worst = [float(self._margin_failed(i, W, method).min()) for i in range(len(self.failures))]
        i = int(np.argmin(worst))
        return i, worst[i]


def _zero_rows(W: np.ndarray, f_max: float) -> np.ndarray:
    """bool (t,): rows that are zero within the off-range tolerance (all a rotorless failure
    can exert)."""
    Wn = W / f_max
    norms = np.sqrt(np.einsum("ij,ij->i", Wn, Wn))
    return norms <= RESIDUAL_TOL


def _matrix_and_failures(structure, fault: str, nested: bool) -> tuple[np.ndarray, list]:
    """(A, :func:`failure_sets`) of a Structure (its own rotor counts) or a (6, 4n) matrix."""
    fault = check_fault(fault)
    if hasattr(structure, "configuration_matrix"):
        A = structure.configuration_matrix()
        if fault not in ("module", "rotor+module"):
            return A, failure_sets(A.shape[1], fault, nested=nested)
        starts = np.cumsum([0] + [m.n_rotors for m in structure.modules])
        return A, module_failures(starts, fault, nested=nested)
    A = np.asarray(structure)
    return A, failure_sets(A.shape[1] if A.ndim == 2 else 0, fault, nested=nested)


def tolerates(
    structure,
    W: np.ndarray,
    f_max: float = 1.0,
    fault: str = "rotor",
    method: str = "auto",
    fault_margin: float = 0.0,
    *,
    deadline: float | None = None,
) -> np.ndarray:
    """bool (t,): does each wrench (row of W, (t, 6)) stay feasible after ANY failure?

    ``structure`` is a :class:`~modquad_gym.geometry.structure.Structure` or its (6, 4n)
    configuration matrix (columns four per module, in cell order). ``fault="rotor"``: any one
    rotor stops (its column leaves A); ``"module"``: any one module's rotors stop (its columns
    leave A; its mass stays, so pass the rotor wrenches of the whole structure); ``"rotor2"``:
    any two rotors stop. With ``fault_margin=mu`` each wrench must also keep a margin of at
    least mu after every failure, and for ``rotor2`` / ``rotor+module`` after each smaller
    failure they contain (:func:`fault_margin` >= mu): thrust to spare for the transient
    before the controller knows, failure after failure. Exact by the oracle's tolerance rule
    on each failed matrix (module docstring). Past ``deadline`` (:func:`time.perf_counter`
    seconds, plus the compilation during the call) it raises :class:`DecisionInterruptedError`."""
    mu = check_fault_margin(fault_margin, check_fault(fault))
    A, failures = _matrix_and_failures(structure, fault, nested=mu > 0.0)  # 0: monotone
    W = check_wrenches(W)
    z = Zonotope(A, check_f_max(f_max))
    tolerance = FaultTolerance(A, z.f_max, failures, z, mu, deadline)
    return tolerance.decide(W, check_method(method))


def fault_margin(
    structure, W: np.ndarray, f_max: float = 1.0, fault: str = "rotor", method: str = "auto"
) -> np.ndarray:
    """float (t,): the worst margin (:func:`~modquad_gym.oracle.margin`) of each wrench over
    every failure of kind ``fault`` and each smaller one it contains (``nested``); >= 0 exactly
    when :func:`tolerates` is True (>= mu, up to the oracle's tolerance band, exactly when
    ``tolerates(..., fault_margin=mu)`` is). No rotor left: -inf (0 for the zero wrench)."""
    A, failures = _matrix_and_failures(structure, fault, nested=True)
    W = check_wrenches(W)
    z = Zonotope(A, check_f_max(f_max))
    return FaultTolerance(A, z.f_max, failures, z).margin(W, check_method(method))
