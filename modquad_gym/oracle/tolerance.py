"""The tolerance rule: one rule by which every method decides, and the margin it implies.

A wrench w is **feasible** exactly when

1. its off-range residual is at most ``RESIDUAL_TOL * (f_max + |w|)`` (checked once, in
   :meth:`~modquad_gym.oracle.Zonotope.reduce`, for every method), and
2. ``gamma(w) <= 1 + TOL``, with ``TOL = 1e-6``. Equivalently: some allocation ``A u = w`` has
   every rotor in ``[-TOL f_max / 2, (1 + TOL / 2) f_max]``; or: w lies in the zonotope scaled by
   ``1 + TOL`` about its centre.

Every method decides by this rule from its own computed gamma (or from certificates that bound
gamma on one side of ``1 + TOL``). The margin is ``1 - gamma`` with every value whose gamma lies in
``[1 - TOL, 1 + TOL]`` reported as exactly 0, so for every method ``margin >= 0`` exactly when
``feasible`` (:func:`decide_from_gamma`, :func:`margin_from_gamma`; the certified ``"auto"``
decisions and the margin's LP gamma agree outside the band below, and inside it the margin takes
its sign from the decision). :func:`~modquad_gym.oracle.lambda_ratio` applies the same rule.

Agreement band: every method computes gamma to better than 1e-9 (LP gammas are re-evaluated from
the returned allocation, so they never undercut the true gamma; HiGHS runs with tightened
tolerances), and every certificate keeps a clearance of :data:`GUARD` from the threshold. So all
methods agree on every wrench with ``|gamma - (1 + TOL)| > BAND``; inside that band the answer
depends on round-off.
"""

from __future__ import annotations

import numpy as np

TOL = 1e-6
"""Decision tolerance: feasible when gamma <= 1 + TOL (module docstring)."""

RESIDUAL_TOL = 1e-9
"""Off-range residual tolerance, relative to f_max + |w|."""

BAND = 1e-7
"""Methods agree on every wrench with |gamma - (1 + TOL)| > BAND (floating-point accuracy)."""

GUARD = 1e-8
"""Clearance of every certificate from the threshold 1 + TOL."""

SUPPORT_SLACK = 1e-12
"""Absolute slack (in units of f_max-normalised wrenches) before a support test rejects (the
searches' cached directions and level bounds)."""

ACCEPT = 1.0 + TOL - GUARD
"""Certificates accept when some allocation has |x|_inf <= ACCEPT."""

REJECT = 1.0 + TOL + GUARD
"""Certificates reject when d . r > REJECT * sum_j |d . g_j| for some direction d."""


def decide_from_gamma(gamma: np.ndarray) -> np.ndarray:
    """The tolerance rule: feasible exactly when gamma <= 1 + TOL (inf: off range)."""
    return np.asarray(gamma) <= 1.0 + TOL


def margin_from_gamma(gamma: np.ndarray) -> np.ndarray:
    """``1 - gamma``, with 0 wherever gamma lies in [1 - TOL, 1 + TOL]: >= 0 exactly when
    :func:`decide_from_gamma` is True."""
    gamma = np.asarray(gamma, dtype=float)
    band = (gamma >= 1.0 - TOL) & decide_from_gamma(gamma)
    return np.where(band, 0.0, 1.0 - gamma)
