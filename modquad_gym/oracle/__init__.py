"""Is a wrench in the feasible-wrench zonotope W = {A u : 0 <= u <= f_max}? (paper Sec. IV)

The number ``gamma(w) = min { ||x||_inf : G x = Q^T w / f_max - c }`` says how far the worst
rotor must deviate from half thrust, as a fraction of f_max / 2 (the gauge of the zonotope about
its centre; coordinates in :mod:`~modquad_gym.oracle.zonotope`). ``margin = 1 - gamma`` is
therefore unit-free: 1 at the centre, 0 on the boundary of W, negative outside (-inf off
range(A), or where gamma leaves the float range). The paper's own measure, ``lambda / |w|`` with
``max lambda s.t. A u = lambda w_hat, 0 <= u <= f_max`` (errata 1: an LP, not a QP), is offered
as :func:`lambda_ratio` (>= 1 exactly when feasible). Every method decides by one tolerance rule
(:mod:`~modquad_gym.oracle.tolerance`) and gives the same answer for (s W, s f_max) at any scale
s (:mod:`~modquad_gym.oracle.scale`).

Methods (``method=`` in :func:`feasible`, :func:`margin`, :class:`WrenchOracle`), one module
each, behind the name -> backend table :data:`~modquad_gym.oracle.backends.BACKENDS`:

``"auto"`` (default) and ``"compiled"`` (:mod:`~modquad_gym.oracle.compiled`)
    Compiled certificates first (an allocation in the cube, or a separating direction, from a
    dual simplex on the support function: a few O(m) pivots, :mod:`~modquad_gym.oracle.walk`),
    the DAQP LP for the undecided rest. The env and the searches decide this way. Margins: the
    DAQP gamma for ``"auto"`` (unchanged values), the same walk run to the optimum for
    ``"compiled"`` (10-80x faster, the fast choice at 64 modules).
``"daqp"`` (:mod:`~modquad_gym.oracle.daqp_lp`)
    One dense active-set LP per wrench: the exact fallback, and the searches' method while
    their work is small (no compilation to load).
``"scipy"`` (:mod:`~modquad_gym.oracle.highs_lp`)
    HiGHS through ``scipy.optimize.linprog``: the plain reference.

The cross-check methods (the certificates in numpy, the paper's LP in cvxpy, the
H-representation and the paper's Algorithm 1) live beside the tests
(``benchmarks/reference_oracle``), which add them to the table as one row each: no product path uses
them.

The LPs themselves are built in one place, :mod:`~modquad_gym.oracle.lp` (used by
:func:`allocate`, :func:`lambda_ratio`, the methods and the hover); the entry points live in
:mod:`~modquad_gym.oracle.api`.
"""

from modquad_gym.core.validation import check_f_max, check_matrix, check_wrenches
from modquad_gym.oracle.api import (
    WrenchOracle,
    allocate,
    decide_with,
    feasible,
    lambda_ratio,
    margin,
    margin_with,
)
from modquad_gym.oracle.backends import BACKENDS, METHODS, Backend, check_method, gamma_with
from modquad_gym.oracle.lp import ray_lp
from modquad_gym.oracle.scale import MAX_TASK_VALUE, check_task_scale
from modquad_gym.oracle.tolerance import (
    BAND,
    RESIDUAL_TOL,
    TOL,
    decide_from_gamma,
    margin_from_gamma,
)
from modquad_gym.oracle.zonotope import Zonotope

__all__ = [
    "BACKENDS",
    "BAND",
    "MAX_TASK_VALUE",
    "METHODS",
    "RESIDUAL_TOL",
    "TOL",
    "Backend",
    "WrenchOracle",
    "Zonotope",
    "allocate",
    "check_f_max",
    "check_matrix",
    "check_method",
    "check_task_scale",
    "check_wrenches",
    "decide_from_gamma",
    "decide_with",
    "feasible",
    "gamma_with",
    "lambda_ratio",
    "margin",
    "margin_from_gamma",
    "margin_with",
    "ray_lp",
]
