"""One table from method name to backend, and the three queries every caller goes through.

``BACKENDS`` maps each name of :data:`METHODS` to a :class:`Backend`: its gamma (every method
has one; margins are ``1 - gamma`` by the tolerance rule) and, where the method decides faster
than by computing gamma, its own decisions. :func:`gamma_with`, :func:`decide_with` and
:func:`margin_with` reduce the wrenches once (off range(A): infeasible, gamma = inf) and hand the
rest to the backend. A new method is one module with a gamma function and one row here.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from modquad_gym.oracle.compiled import (
    decide_compiled,
    gamma_compiled,
    gamma_compiled_from,
    screen_compiled,
)
from modquad_gym.oracle.daqp_lp import gamma_daqp
from modquad_gym.oracle.highs_lp import gamma_highs, ray_highs
from modquad_gym.oracle.tolerance import TOL, decide_from_gamma, margin_from_gamma

if TYPE_CHECKING:
    from modquad_gym.oracle.zonotope import Zonotope

Rows = Callable[["Zonotope", np.ndarray], np.ndarray]
"""A function of a zonotope and centred reduced wrenches R (t, rank) in range(A)."""

Ray = Callable[["Zonotope", np.ndarray, float, float], np.ndarray]
"""``(z, D, lo, hi) -> lambda*`` per row d of D: the paper's LP from the origin,
``max lambda s.t. Q^T A u = lambda d_hat, lo <= u <= hi`` (units of f_max)."""

Screen = Callable[
    ["Zonotope", np.ndarray, np.ndarray, np.ndarray, float],
    tuple[np.ndarray, np.ndarray, np.ndarray],
]
"""``(z, W, WD, h, slack) -> (per_wrench, verdict, counts)``: a caller's support screen fused
with the decisions (:func:`~modquad_gym.oracle.compiled.screen_compiled`)."""

_FAR = 1e6  # rows beyond this many bounding boxes get their gamma by homogeneity (gamma_with)


@dataclass(frozen=True)
class Backend:
    """One feasibility method.

    Args:
        gamma: exact gamma per row of R (float (t,)).
        decide: decisions per row of R (bool (t,)) when the method has a faster way than the
            tolerance rule applied to ``gamma``; None: by the rule from ``gamma``.
        margin_sign_from_decide: margins take their sign from ``decide`` where the two disagree
            (within the LP's accuracy of the threshold), so that margin >= 0 exactly when
            feasible even though decisions and margins come from different computations.
        ray: the paper's LP from the origin, for :func:`~modquad_gym.oracle.lambda_ratio`
            (None: the method does not offer it).
        screen: the decisions fused with a support screen, for
            :meth:`~modquad_gym.oracle.WrenchOracle.screened` (None: the screen in numpy, then
            ``decide``).
    """

    gamma: Rows
    decide: Rows | None = None
    margin_sign_from_decide: bool = False
    ray: Ray | None = None
    screen: Screen | None = None


BACKENDS: dict[str, Backend] = {
    "auto": Backend(gamma_daqp, decide_compiled, True, screen=screen_compiled),
    "compiled": Backend(gamma_compiled, decide_compiled, True, screen=screen_compiled),
    "daqp": Backend(gamma_daqp),
    "scipy": Backend(gamma_highs, ray=ray_highs),
}

METHODS = tuple(BACKENDS)
"""The names of the feasibility methods, ``"auto"`` (the default) first."""


def check_method(method: str) -> str:
    """``method`` when it names a backend, else a ValueError listing them."""
    if not isinstance(method, str) or method not in BACKENDS:
        raise ValueError(f"unknown method {method!r}; choose one of {', '.join(BACKENDS)}")
    return method


def _gamma_rows(z: Zonotope, R: np.ndarray, backend: Backend, cap: float = np.inf) -> np.ndarray:
    """gamma per row of R (in range(A)) by ``backend``.

    gamma is positively homogeneous in the centred reduced wrench r, so a row far outside the
    zonotope (beyond ``_FAR`` times its bounding box: huge torques, say) is solved as
    ``t * gamma(r / t)`` with t = max |r_i|, and the LPs only ever see numbers of order one.
    With a finite ``cap`` (< ``_FAR``), the compiled walk, which stops at a proof of gamma >
    cap and returns that proved lower bound; a far row's is t / max(box) > _FAR (its box).
    A rank-0 A (all zero): every row in its range is the centre, gamma 0."""
    if not z.rank:
        return np.zeros(len(R))
    t = np.abs(R).max(axis=1)
    box = max(float(z.box.max()), 1e-300)
    far = t > _FAR * box
    if cap < _FAR:
        g = t / box
        near = np.flatnonzero(~far)
        if len(near):
            g[near] = gamma_compiled(z, R[near], cap)
        return g
    if far.any():
        R = R.copy()
        R[far] /= t[far, None]
    g = backend.gamma(z, R)
    with np.errstate(over="ignore"):
        g[far] *= t[far]
    return g


def gamma_with(z: Zonotope, W: np.ndarray, method: str, cap: float = np.inf) -> np.ndarray:
    """gamma per wrench (row of W) by ``method``: inf off range(A). With ``cap`` below
    ``_FAR`` (the compiled walk whatever ``method``: only it stops early), a wrench whose
    gamma is proved above ``cap`` gets that proved lower bound (> cap) instead: enough for a
    margin clipped at ``1 - cap``."""
    R, off = z.reduce(W)
    out = np.full(len(W), np.inf)
    on = np.flatnonzero(~off)
    if len(on):
        out[on] = _gamma_rows(z, R[on], BACKENDS[method], cap)
    return out


def gamma_capped_from(
    z: Zonotope, W: np.ndarray, cap: float, start: tuple | None = None, lower=None
) -> tuple[np.ndarray, tuple[np.ndarray, np.ndarray]]:
    """(:func:`gamma_with` by the compiled walk with ``cap`` (< ``_FAR``), each row's optimal
    vertex: (tight columns int (t, rank - 1), column bounds int8 (t, m)), -1 and 0 where the
    walk stopped elsewhere), the walk of row i started at the vertex ``start`` gives it
    (:func:`~.compiled.gamma_compiled_from`; None: every walk from the dual-metric direction).
    The same gamma up to round-off; a row proved above ``cap`` may get another proved bound
    above it: a row whose finite ``lower`` bound (t,) (the caller's proof) exceeds ``cap`` by
    far more than round-off (:func:`proved_above`) gets that bound, no walk."""
    R, off = z.reduce(W)
    out = np.full(len(W), np.nan)  # nan: walked
    t = np.abs(R).max(axis=1, initial=0.0) if len(W) else np.zeros(0)
    box = max(float(z.box.max(initial=0.0)), 1e-300)
    far = t > _FAR * box
    out[far] = t[far] / box
    if lower is not None:
        known = proved_above(lower, cap) & ~far
        out[known] = lower[known]
    out[off] = np.inf
    if start is None:
        tights = np.full((len(W), max(z.rank - 1, 1)), -1, dtype=np.int64)
        signs = np.zeros((len(W), z.m), dtype=np.int8)
    else:
        tights = np.array(start[0], dtype=np.int64, order="C")
        signs = np.array(start[1], dtype=np.int8, order="C")
    gamma_compiled_from(z, R, cap, tights, signs, out)
    return out, (tights, signs)


def proved_above(lower: np.ndarray, cap: float) -> np.ndarray:
    """bool (t,): where the gamma lower bounds ``lower`` are finite and above ``cap`` by a
    relative 1e-9 (far beyond their round-off): proof that gamma > ``cap``."""
    return np.isfinite(lower) & (lower > cap * (1.0 + 1e-9))


def decide_with(z: Zonotope, W: np.ndarray, method: str) -> np.ndarray:
    """bool per wrench (row of W) by ``method`` and the tolerance rule: False off range(A)."""
    backend = BACKENDS[method]
    R, off = z.reduce(W)
    if len(off) and not off.any():  # common: every wrench in range(A)
        return _decide_rows(z, R, backend)
    out = np.zeros(len(W), dtype=bool)
    on = np.flatnonzero(~off)
    if len(on):
        out[on] = _decide_rows(z, R[on], backend)
    return out


def _decide_rows(z: Zonotope, R: np.ndarray, backend: Backend) -> np.ndarray:
    """Decisions per row of R (in range(A)): the backend's own, else the rule on its gamma."""
    if backend.decide is not None:
        return backend.decide(z, R)
    return decide_from_gamma(_gamma_rows(z, R, backend))


def margin_with(z: Zonotope, W: np.ndarray, method: str) -> np.ndarray:
    """``1 - gamma`` per wrench (row of W) by ``method``, >= 0 exactly when feasible."""
    out = margin_from_gamma(gamma_with(z, W, method))
    if BACKENDS[method].margin_sign_from_decide:
        # the certified decisions and the LP gamma agree unless gamma is within the LP's
        # accuracy of 1 + TOL; there the certificate wins, so the sign always matches feasible()
        ok = decide_with(z, W, method)
        out[ok & (out < 0)] = 0.0
        out[~ok & (out >= 0)] = np.nextafter(-TOL, -np.inf)
    return out
