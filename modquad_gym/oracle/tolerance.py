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

Accuracy, measured against exact gammas (``python -m benchmarks.oracle_accuracy``, its numbers
in ``results/oracle_accuracy.md``):

* On stock structures (1 to 128 modules, f_max 1 and 1e6; condition numbers at most 1.5e3) HiGHS's
  gamma (``"scipy"``, :func:`~modquad_gym.oracle.allocate`) is within 5e-11 and the compiled
  walk's within 2e-13 where it reaches the optimum (all but at most 1 of 1200 wrenches per
  structure). DAQP's (the ``"auto"`` margins, and the walk's fallback) is an upper bound up to
  1.3e-7 high on the 64-module lattice (its proximal iterations; 3e-8 on the others), never low by
  more than 3e-15. A DAQP gamma within ``TOL`` above the threshold is recomputed by HiGHS
  (:data:`~modquad_gym.oracle.daqp_lp.RECHECK`), and every certificate keeps a clearance of
  :data:`GUARD` from it, so all methods *decide* alike on every wrench with
  ``|gamma - (1 + TOL)| > BAND``; inside that band the answer depends on round-off. Margins take
  their sign from their method's decision.
* Every method works in the reduced coordinates of an SVD of A, whose rounding moves gamma by
  about eps times A's condition number (the ratio of its largest and smallest kept singular
  values; the rank rule keeps directions down to 1e-9 of the largest, condition 1e9). On 6 x 8
  matrices the worst error, the same for every method, is 1.6e-10 to condition 1e6, 1.6e-9 at 1e7,
  9e-8 at 3e7, 3e-7 at 1e8 and 1.9e-6 at 5e8. So the band above holds for A of condition up to
  about 1e7; beyond, every method alike may decide a wrench near the threshold wrongly. A
  direction the rank rule cuts counts as off range, though a wrench much smaller than
  ``|A| f_max`` may need it (the off-range rule is relative to ``f_max + |w|``): never on a
  stock structure, whose singular values are 0 (to round-off) or above 6e-4 of the largest.
"""

from __future__ import annotations

import numpy as np

TOL = 1e-6
"""Decision tolerance: feasible when gamma <= 1 + TOL (module docstring)."""

RESIDUAL_TOL = 1e-9
"""Off-range residual tolerance, relative to f_max + |w|."""

BAND = 1e-7
"""Methods decide alike (and as the exact gamma says) on every wrench with
|gamma - (1 + TOL)| > BAND, for A of condition number up to about 1e7 (module docstring)."""

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
