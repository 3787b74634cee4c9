"""Numbers of any size: overflow-free row norms and the searches' check of a task's scale.

Wrenches are divided by f_max on entry (:meth:`~modquad_gym.oracle.Zonotope.reduce`), so every
answer of the oracle is the same for (s W, s f_max) at any scale s whose values are representable.
Huge wrenches (torques of 1e200, say) are decided by the exact bounding-box certificate, and their
gamma comes from homogeneity, ``gamma(r) = t gamma(r / t)``: the LPs only ever see numbers of
order one, and no step squares a huge value.
"""

from __future__ import annotations

import numpy as np

from modquad_gym.core.validation import check_f_max, check_wrenches

MAX_TASK_VALUE = 1e100
"""Largest wrench component (in newtons or newton-metres, and in units of f_max) that
:func:`check_task_scale` accepts: far beyond anything a structure can exert, and small enough
that no step of a search overflows."""


def row_norms(X: np.ndarray) -> np.ndarray:
    """Euclidean norm of each row of X, without overflow for any finite entries."""
    t = np.abs(X).max(axis=1, initial=0.0) if X.shape[1] else np.zeros(len(X))
    safe = np.where(t > 0.0, t, 1.0)
    Y = X / safe[:, None]
    return t * np.sqrt(np.einsum("ij,ij->i", Y, Y))


def check_task_scale(W: np.ndarray, f_max: float) -> np.ndarray:
    """W (checked, (t, 6)) when f_max passes :func:`check_f_max` and every |w_i| and every
    |w_i| / f_max is at most :data:`MAX_TASK_VALUE`, else a ValueError naming the value and its
    1-based row. The searches call it: they test one task against many structures and
    multiply and square its numbers on the way, where the oracle itself takes any finite value
    (:meth:`~modquad_gym.oracle.Zonotope.reduce`)."""
    W, f_max = check_wrenches(W), check_f_max(f_max)
    if not len(W):
        return W
    within = within_scale(np.abs(W).max(axis=1), f_max)
    if not within.all():
        row = int(np.argmax(~within))
        raise ValueError(
            f"wrench row {row + 1} {W[row].tolist()} with f_max = {f_max:g} is beyond "
            f"{MAX_TASK_VALUE:g} (newtons, and times f_max): far beyond what any structure can "
            "exert (check the units)"
        )
    return W


def within_scale(size: np.ndarray, f_max: float) -> np.ndarray:
    """True where a wrench whose largest |component| is ``size`` is within the searches' scale
    at ``f_max``: ``size`` and ``size / f_max`` at most :data:`MAX_TASK_VALUE` (the rule of
    :func:`check_task_scale`; False for inf and nan)."""
    with np.errstate(over="ignore", under="ignore", invalid="ignore"):
        size = np.abs(np.asarray(size, dtype=float))
        return np.maximum(size, size / f_max) <= MAX_TASK_VALUE


def check_scale_bound(size: float, f_max: object, what: str) -> None:
    """A ValueError when ``f_max`` fails :func:`check_f_max` or wrenches whose components
    reach ``size`` would be refused by :func:`check_task_scale`: the same rule, for a task
    generator's parameters before anything is drawn. The error names ``what`` (the parameters
    that set ``size``) when ``size`` itself is too large, else ``f_max`` (too small for it)."""
    f_max = check_f_max(f_max)
    if within_scale(np.array([size]), f_max)[0]:
        return
    if not within_scale(np.array([size]), 1.0)[0]:
        raise ValueError(
            f"{what}: wrenches up to {size:.3g} are beyond {MAX_TASK_VALUE:g}: far beyond what "
            "any structure can exert (check the units)"
        )
    raise ValueError(
        f"f_max = {f_max:g} is too small for wrenches up to {size:.3g}: {size / f_max:.3g} "
        f"units of f_max, beyond {MAX_TASK_VALUE:g} (check the units)"
    )
