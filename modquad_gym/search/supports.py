"""Support functions of many structures at once, straight from their cells (numba).

The support of a structure's feasible set W = {A u : 0 <= u <= f_max} in a direction d of
wrench space is h(d) = f_max * sum_k max(0, d . a_k). For the rotor k of a module whose centre
sits at c = (c_x, c_y, 0) from the centre of mass, d . a_k = b_k + c_x alpha_k + c_y beta_k,
where b_k is d . (the module's own column) and alpha_k, beta_k come from the torque part
d_tau . (c x r_k). Precomputing (b, alpha, beta) per direction makes a support O(4n) without
building A: the exhaustive search rejects most structures this way (a separating direction
learned earlier, or a level bound) before any LP.

After a failure (a rotor, two rotors, a module) the structure's support is that of the rotors
left; at worst (over every failure of the kind) it is h(d) less the largest positive rotor term,
the two largest, or the largest module's sum: a direction whose task value exceeds that rules
the structure out of a fault-tolerant search, exactly.

The oracle's tolerance is included as it is everywhere: thrusts may leave [0, f_max] by
TOL * f_max / 2, which widens the support by TOL * f_max / 2 * sum_k |d . a_k|.

Mixed structures: ``types[l, i]`` is the palette index of module i of structure l; ``masses``
(per type) place its centre of mass. For tasks of kind ``external`` the rotors must produce
w + M g e_z with M the structure's total mass, so a task value d . w gains ``M g d_z``: ``lift``
holds each type's weight m g (zeros for ``total`` tasks, which leaves every test unchanged).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from modquad_gym.core.jit import njit
from modquad_gym.geometry.module import ModuleType
from modquad_gym.oracle.tolerance import SUPPORT_SLACK as SLACK


def direction_terms(
    modules: Sequence[ModuleType], D: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(b, alpha, beta), each (P, K, r): for each direction (rows of D, (P, 6)) and module type,
    the per-rotor terms of d . a_k = b + c_x alpha + c_y beta."""
    D = np.asarray(D, dtype=float).reshape(-1, 6)
    dt = D[:, 3:]
    b, alpha, beta = [], [], []
    for m in modules:
        r = m.directions  # (r, 3)
        b.append(D @ m.columns)
        alpha.append(-dt[:, 1:2] * r[:, 2] + dt[:, 2:3] * r[:, 1])
        beta.append(dt[:, 0:1] * r[:, 2] - dt[:, 2:3] * r[:, 0])
    return tuple(np.ascontiguousarray(np.stack(x, axis=1)) for x in (b, alpha, beta))


@njit(cache=True)
def _centres(cells, types, l, masses, side, cx, cy):
    """Module centres of structure l relative to its mass-weighted centre, in metres."""
    n = cells.shape[1]
    mx = 0.0
    my = 0.0
    mt = 0.0
    for i in range(n):
        m = masses[types[l, i]]
        mx += m * cells[l, i, 0]
        my += m * cells[l, i, 1]
        mt += m
    mx /= mt
    my /= mt
    for i in range(n):
        cx[i] = (cells[l, i, 0] - mx) * side
        cy[i] = (cells[l, i, 1] - my) * side


LOSSES = {None: 0, "rotor": 1, "rotor2": 2, "module": 3, "rotor+module": 4}
"""What a failure of each kind takes from a support at worst (the ``lose`` code of
:func:`reject`): nothing, the largest rotor term, the two largest, the largest module's sum, or
a module's sum with the largest rotor term of another module (a single module: its own sum)."""


@njit(cache=True)
def _support(b, alpha, beta, p, types, l, cx, cy, lose):
    """(sum_k max(0, d . a_k) less what the worst failure of kind ``lose`` (:data:`LOSSES`)
    takes from it, sum_k |d . a_k|) of structure l in direction p: after that failure the
    structure's support in p is at most the first, widened by the second's tolerance share."""
    n = cx.shape[0]
    r = b.shape[2]
    plus = 0.0
    total = 0.0
    top1 = 0.0  # the two largest positive rotor terms
    top2 = 0.0
    module = 0.0  # the largest sum of positive terms of one module
    best = 0.0  # the largest rotor term of a module, the module, and the second largest of one
    best_at = -1  # module's largest terms (of another module than best_at)
    second = 0.0
    for i in range(n):
        t = types[l, i]
        own = 0.0
        largest = 0.0
        for j in range(r):
            v = b[p, t, j] + cx[i] * alpha[p, t, j] + cy[i] * beta[p, t, j]
            if v > 0.0:
                plus += v
                total += v
                own += v
                largest = max(largest, v)
                if v > top1:
                    top2 = top1
                    top1 = v
                elif v > top2:
                    top2 = v
            else:
                total -= v
        module = max(module, own)
        if largest > best:
            second, best, best_at = best, largest, i
        elif largest > second:
            second = largest
    if lose == 4:  # a module, then the largest rotor term of another one (a second pass)
        module = 0.0
        for i in range(n):
            t = types[l, i]
            own = 0.0
            for j in range(r):
                v = b[p, t, j] + cx[i] * alpha[p, t, j] + cy[i] * beta[p, t, j]
                own += max(v, 0.0)
            if n > 1:
                own += second if i == best_at else best
            module = max(module, own)
    if lose == 1:
        plus -= top1
    elif lose == 2:
        plus -= top1 + top2
    elif lose >= 3:
        plus -= module
    return plus, total


@njit(cache=True)
def reject(
    cells, types, masses, side, b, alpha, beta, values, f_max, half_tol, alive, lift, dz, lose=0
):
    """Clear ``alive[l]`` for every structure l that some direction p separates from a task
    wrench: values[p] (the task's max_i d_p . w_i, less the oracle's off-range grant) plus
    the weight term (sum of ``lift`` over the structure's modules) * dz[p] above its widened
    support (after the worst failure of kind ``lose``, :data:`LOSSES`: then the structure does
    not tolerate that failure). The direction that rejected the previous structure is tried
    first (neighbours in the canonical order are alike), then the others in order; the outcome
    does not depend on the order."""
    L, n, _ = cells.shape
    P = b.shape[0]
    cx = np.empty(n)
    cy = np.empty(n)
    last = 0
    lifting = np.any(lift != 0.0)
    for l in range(L):
        if not alive[l]:
            continue
        _centres(cells, types, l, masses, side, cx, cy)
        weight = 0.0
        if lifting:
            for i in range(n):
                weight += lift[types[l, i]]
        for q in range(P):
            p = last if q == 0 else (q - 1 if q <= last else q)
            plus, total = _support(b, alpha, beta, p, types, l, cx, cy, lose)
            if values[p] + weight * dz[p] > f_max * (plus + half_tol * total) + SLACK:
                alive[l] = False
                last = p
                break


@njit(cache=True)
def max_supports(cells, types, masses, side, b, alpha, beta, plus_out, total_out, lose=0):
    """Running maxima over the structures of ``cells`` of both support sums (after the worst
    failure of kind ``lose``), per direction."""
    L, n, _ = cells.shape
    P = b.shape[0]
    cx = np.empty(n)
    cy = np.empty(n)
    for l in range(L):
        _centres(cells, types, l, masses, side, cx, cy)
        for p in range(P):
            plus, total = _support(b, alpha, beta, p, types, l, cx, cy, lose)
            if plus > plus_out[p]:
                plus_out[p] = plus
            if total > total_out[p]:
                total_out[p] = total
