"""The oracle's cross-check methods, kept beside the tests (no product path imports them):
the certificates in vectorised numpy (``"certified"``), the paper's LP in cvxpy (``"cvxpy"``),
the exact H-representation (``"hrep"``) and the paper's Algorithm 1 (``"quickhull"``).

:func:`register` adds each as one row of the oracle's method table
(:data:`modquad_gym.oracle.backends.BACKENDS`, the extension point for a new method), so that
``mq.feasible(A, W, method="hrep")`` and the like work inside the tests and the oracle benchmark.
"""

from __future__ import annotations

import weakref

_CACHES: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


def cache(z) -> dict:
    """What these methods build once per zonotope ``z`` (by name), kept while z lives."""
    return _CACHES.setdefault(z, {})


def register() -> None:
    """Add the reference methods to the oracle's table (a second call changes nothing)."""
    from benchmarks.reference_oracle.certified import decide_reduced
    from benchmarks.reference_oracle.cvxpy_lp import gamma_cvxpy, ray_cvxpy
    from benchmarks.reference_oracle.hrep import decide_hrep, gamma_hrep
    from benchmarks.reference_oracle.quickhull import gamma_quickhull
    from modquad_gym.oracle.backends import BACKENDS, Backend
    from modquad_gym.oracle.daqp_lp import gamma_daqp

    BACKENDS.setdefault(
        "certified", Backend(gamma_daqp, decide_reduced, margin_sign_from_decide=True)
    )
    BACKENDS.setdefault("cvxpy", Backend(gamma_cvxpy, ray=ray_cvxpy))
    BACKENDS.setdefault("hrep", Backend(gamma_hrep, decide_hrep))
    BACKENDS.setdefault("quickhull", Backend(gamma_quickhull))
