"""The oracle's entry points: :func:`feasible`, :func:`margin`, :func:`lambda_ratio`,
:func:`allocate` and the caching :class:`WrenchOracle`."""

from __future__ import annotations

import math
from collections import OrderedDict
from collections.abc import Hashable
from typing import TYPE_CHECKING

import numpy as np

from modquad_gym.core.validation import check_f_max, check_int, check_wrenches
from modquad_gym.oracle import backends
from modquad_gym.oracle.backends import BACKENDS, check_method
from modquad_gym.oracle.highs_lp import condition_error
from modquad_gym.oracle.lp import GammaLP
from modquad_gym.oracle.scale import row_norms
from modquad_gym.oracle.tolerance import TOL
from modquad_gym.oracle.zonotope import Zonotope

if TYPE_CHECKING:
    from modquad_gym.oracle.whitened import WhitenedZonotope


class WrenchOracle:
    """Feasibility and margins of task wrenches for many structures, with a per-structure cache.

    Args:
        f_max: maximum thrust per rotor (N, normalised to 1 in the paper).
        method: one of :data:`~modquad_gym.oracle.METHODS` (see :mod:`modquad_gym.oracle`);
            ``"auto"`` is the default.
        cache_size: how many prepared zonotopes to keep (least recently used are dropped), an
            integer >= 0.

    A ``key`` (e.g. a structure's key) is the caller's promise that it names one matrix: the
    zonotope cached under it is answered without comparing the matrices. A matrix of another
    shape under a cached key is refused (ValueError naming ``key``: a cheap check that catches
    a key reused for another structure); one of the same shape is not compared. Pass
    ``key=None`` for a matrix that is not to be cached.

    ``calls`` counts the wrench-structure tests made (one per wrench per structure);
    ``fallback`` the wrenches of :meth:`screened` that no compiled certificate decided (the exact
    LP did).
    """

    def __init__(self, f_max: float = 1.0, method: str = "auto", cache_size: int = 4096) -> None:
        self.f_max = check_f_max(f_max)
        self.method = check_method(method)
        self.cache_size = check_int(cache_size, "cache_size", low=0)
        self._cache: OrderedDict[Hashable, Zonotope] = OrderedDict()
        self.calls = 0
        self.fallback = 0

    def zonotope(self, A: np.ndarray, key: Hashable | None = None) -> Zonotope:
        """The prepared zonotope of A, cached under ``key`` (e.g. a structure's key; one
        cached for gammas only, :meth:`gamma_zonotope`, is replaced by the full one)."""
        if key is None:
            return Zonotope(A, self.f_max)
        z = self._cache.get(key)
        if z is not None:
            _same_shape(A, z, key)
        if type(z) is not Zonotope:
            return self._keep(key, Zonotope(A, self.f_max))
        self._cache.move_to_end(key)
        return z

    def gamma_zonotope(self, A: np.ndarray, key: Hashable) -> Zonotope | WhitenedZonotope:
        """A zonotope of the finite float matrix A that gammas can be walked on, cached under
        ``key``: the cached one, else the :class:`~.whitened.WhitenedZonotope` (no SVD: the
        exact lookahead's children) or, where A is rank-deficient or ill-conditioned, the full
        :class:`Zonotope`."""
        from modquad_gym.oracle.whitened import whitened  # numba: loaded on first use

        z = self.cached(key)
        if z is None:
            return self._keep(key, whitened(A, self.f_max) or Zonotope(A, self.f_max))
        _same_shape(A, z, key)
        return z

    def cached(self, key: Hashable) -> Zonotope | WhitenedZonotope | None:
        """The zonotope cached under ``key`` (for gammas only where :meth:`gamma_zonotope`
        cached it), or None (no matrix needed to ask)."""
        z = self._cache.get(key)
        if z is not None:
            self._cache.move_to_end(key)
        return z

    def _keep(self, key: Hashable, z):
        self._cache[key] = z
        self._cache.move_to_end(key)
        if len(self._cache) > self.cache_size:
            self._cache.popitem(last=False)
        return z

    def feasible(self, A: np.ndarray, W: np.ndarray, key: Hashable | None = None) -> np.ndarray:
        W = check_wrenches(W)
        z = self.zonotope(A, key)
        self.calls += len(W)
        return backends.decide_with(z, W, self.method)

    def margin(self, A: np.ndarray, W: np.ndarray, key: Hashable | None = None) -> np.ndarray:
        W = check_wrenches(W)
        z = self.zonotope(A, key)
        self.calls += len(W)
        return backends.margin_with(z, W, self.method)

    def screened(
        self,
        A: np.ndarray,
        W: np.ndarray,
        WD: np.ndarray,
        h: np.ndarray,
        slack: float,
        key: Hashable | None = None,
    ) -> tuple[np.ndarray, int, int]:
        """(per_wrench, tested, satisfied): the structure of A against finite wrenches W (t, 6)
        behind a support screen the caller proved.

        ``per_wrench = max_d (WD[:, d] - h[d])`` (t,), with WD (t, k) the wrenches' projections
        on k directions and h (k,) the structure's supports there, in the caller's units; a
        wrench with ``per_wrench > slack`` is outside the structure (the caller's proof) and is
        not tested. The others are decided by the method: ``tested`` of them, ``satisfied``
        feasible. With ``"auto"`` or ``"compiled"`` the screen and the decisions are one
        compiled call (the environment decides every step this way)."""
        z = self.zonotope(A, key)
        screen = BACKENDS[self.method].screen
        if screen is None or not z.rank:
            per_wrench = np.maximum.reduce(WD - h, axis=1)
            open_ = per_wrench <= slack
            n_open = int(np.count_nonzero(open_))
            if not n_open:
                return per_wrench, 0, 0
            W_open = W if n_open == len(open_) else W[open_]
            self.calls += n_open
            ok = backends.decide_with(z, W_open, self.method)
            return per_wrench, n_open, int(np.count_nonzero(ok))
        per_wrench, verdict, counts = screen(z, W, WD, h, slack)
        tested, satisfied = int(counts[0]), int(counts[1])
        self.calls += tested
        if counts[2]:
            rest = np.flatnonzero(verdict == -1)
            self.fallback += len(rest)
            satisfied += int(np.count_nonzero(backends.decide_with(z, W[rest], "daqp")))
        return per_wrench, tested, satisfied


def _same_shape(A: np.ndarray, z, key: Hashable) -> None:
    """A ValueError naming ``key`` when A is not of the shape of the matrix cached under it."""
    shape = A.shape if isinstance(A, np.ndarray) else np.shape(np.asarray(A, dtype=object))
    if shape != z.A.shape:
        raise ValueError(
            f"key {key!r}: A has shape {shape}, but the zonotope cached under this key is "
            f"of a {z.A.shape} matrix; a key names one matrix (use another key, or key=None)"
        )


def feasible(A: np.ndarray, W: np.ndarray, f_max: float = 1.0, method: str = "auto") -> np.ndarray:
    """bool (t,): is each wrench (row of W, shape (t, 6)) in W = {A u : 0 <= u <= f_max}?

    Exact up to the tolerance rule (:mod:`modquad_gym.oracle.tolerance`): on range(A) (residual
    at most ``RESIDUAL_TOL * (1 + |w|)``) and gamma <= 1 + TOL. Raises ValueError for a
    malformed A or W, non-finite values or f_max <= 0.
    """
    W = check_wrenches(W)
    return backends.decide_with(Zonotope(A, f_max), W, check_method(method))


def margin(A: np.ndarray, W: np.ndarray, f_max: float = 1.0, method: str = "auto") -> np.ndarray:
    """float (t,): ``1 - gamma`` per wrench, >= 0 exactly when feasible.

    gamma is the smallest s such that some allocation u with A u = w keeps every rotor within
    s * f_max / 2 of half thrust. So the margin is 1 at hover-at-half-thrust, 0 on the boundary
    (and for every gamma in [1 - TOL, 1 + TOL], the tolerance band), negative outside W, and -inf
    for wrenches off range(A) (rank-deficient structures) or so large that 1 - gamma leaves the
    float range. The same for (s W, s f_max) at any scale s.
    """
    W = check_wrenches(W)
    return backends.margin_with(Zonotope(A, f_max), W, check_method(method))


def decide_with(z: Zonotope, W: np.ndarray, method: str = "auto") -> np.ndarray:
    """bool (t,): is each wrench (row of W, (t, 6)) in the zonotope ``z``, decided by
    ``method`` (one of :data:`~modquad_gym.oracle.METHODS`) and the tolerance rule? For many
    decisions on one prepared :class:`Zonotope`; ``z``, W and ``method`` are checked as
    :func:`feasible` checks them (ValueError naming what is wrong)."""
    return backends.decide_with(*_checked(z, W, method))


def margin_with(z: Zonotope, W: np.ndarray, method: str = "auto") -> np.ndarray:
    """float (t,): ``1 - gamma`` per wrench (row of W) in the zonotope ``z`` by ``method``, as
    :func:`margin` gives it; arguments checked as by :func:`decide_with`."""
    return backends.margin_with(*_checked(z, W, method))


def _checked(z: object, W: object, method: object) -> tuple[Zonotope, np.ndarray, str]:
    if not isinstance(z, Zonotope):
        raise ValueError(f"z must be a Zonotope (Zonotope(A, f_max)), got {type(z).__name__}")
    return z, check_wrenches(W), check_method(method)


def lambda_ratio(
    A: np.ndarray, W: np.ndarray, f_max: float = 1.0, method: str = "scipy"
) -> np.ndarray:
    """The paper's measure per wrench: lambda* / |w| with (errata 1, an LP)
    ``max lambda s.t. A u = lambda w_hat, lo <= u <= hi``, solved by HiGHS
    (``method="scipy"``).

    The same tolerance rule as :func:`feasible`: the thrust bounds are widened to
    ``[-TOL f_max / 2, (1 + TOL / 2) f_max]`` (the zonotope scaled by 1 + TOL about its centre),
    so lambda_ratio >= 1 exactly when ``feasible`` (its sign is taken from ``feasible`` for the
    wrenches where the two LPs' round-off disagree: within BAND of the threshold).
    inf for w = 0 (and for every wrench in the range of an all-zero A: within the off-range
    rule of w = 0); 0 when no positive multiple of w is feasible (e.g. off range(A)).
    """
    ray = BACKENDS[method].ray if method in BACKENDS else None
    if ray is None:
        names = " or ".join(repr(name) for name, b in BACKENDS.items() if b.ray is not None)
        raise ValueError(f"lambda_ratio supports method {names}, got {method!r}")
    W = check_wrenches(W)
    z = Zonotope(A, f_max)
    lo, hi = -TOL / 2.0, 1.0 + TOL / 2.0  # in units of f_max, as z's reduced coordinates
    norms = row_norms(W)
    out = np.full(len(W), np.inf)
    _, off = z.reduce(W)
    out[off] = 0.0
    live = np.flatnonzero(~off & (norms > 0))
    if len(live) and z.rank:
        # directions in range(A) coordinates, each scaled to max |d_i| = 1 (the ratio
        # lambda / |d| does not depend on the length of d, and the LP sees numbers of order one)
        D = W[live] @ z.Q
        D /= np.abs(D).max(axis=1, keepdims=True)
        lams = ray(z, D, lo, hi)
        # lambda* is in units of f_max: the ratio is lambda* / (|w| / f_max)
        with np.errstate(over="ignore", divide="ignore"):
            out[live] = lams / (row_norms(W[live] @ z.Q) / z.f_max)
    ok = backends.decide_with(z, W, "auto")
    out[ok & (out < 1.0)] = 1.0
    out[~ok & (out >= 1.0)] = np.nextafter(1.0, 0.0)
    return out


def allocate(A: np.ndarray, w: np.ndarray, f_max: float = 1.0) -> tuple[np.ndarray, float]:
    """The most centred exact allocation for one wrench ``w`` (6 numbers: shape (6,) or
    (1, 6); anything else is a ValueError naming ``w``, call it once per wrench): (u, gamma)
    with A u = w and every rotor within gamma * f_max / 2 of half thrust. When gamma > 1 the
    wrench is infeasible and u is the least-squares allocation clipped to [0, f_max] (what the
    rotors can do). A ValueError naming A's condition number where HiGHS finds no optimum (a
    numerical failure: the LP is always feasible and bounded)."""
    z = Zonotope(A, f_max)
    try:
        W = check_wrenches(w)
    except ValueError as exc:
        raise ValueError(f"w: {exc}") from None
    if len(W) != 1:
        raise ValueError(
            f"w must be one wrench of 6 numbers (shape (6,) or (1, 6)), got shape {W.shape}; "
            "call allocate once per wrench"
        )
    w = W[0]
    R, off = z.reduce(w[None])
    if off[0]:
        u = np.clip(np.linalg.lstsq(z.A, w, rcond=None)[0], 0.0, z.f_max)
        return u, math.inf
    if not z.rank:  # an all-zero A: w is (within the off-range rule) its only wrench, 0
        return np.full(z.m, z.f_max / 2.0), 0.0
    res = GammaLP.build(z.V).solve(R[0] / z.sigma)  # equilibrated rows, as highs_lp
    if res.status != 0:  # always feasible and bounded: a numerical failure (ill-conditioned A)
        raise ValueError(condition_error(z, f"HiGHS: {res.message}"))
    x, gamma = res.x[: z.m], float(res.fun)
    u = (1.0 + x) * (z.f_max / 2.0)
    return np.clip(u, 0.0, z.f_max), gamma
