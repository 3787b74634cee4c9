"""Fixed-size, permutation-invariant features of a task and of a structure's capability against it.

Why support functions: a task is a *set* of t wrenches (t from 1 to hundreds) and the structure's
capability is a convex set W. Both are summarised, for any t, by their support functions
h(d) = max_{w} d . w on one fixed set of K directions d. The task's support is a max over its
wrenches (invariant to their order); the structure's is exact and cheap for a zonotope,
h_W(d) = f_max * sum_k max(d . a_k, 0). Where h_T(d) > h_W(d), direction d certifiably holds a
task wrench the structure cannot produce. Exact per-wrench margins are LPs (too slow for every
step); the env's hot path uses the oracle's exact decisions plus these support gaps.

Directions live in a *scaled* wrench space w~ = [f ; tau / l] (l: the module side), so that
forces (N) and torques (N m) weigh alike: the 12 signed axes plus ``K - 12`` well-spread unit
vectors (farthest-point sampling from a generator seeded at import, so they never change).
A direction u of the scaled space is d = [u_f ; u_tau / l] in wrench space.

Normalisation (all features are float32 in [-1, 1]):

* ``scale = 4 * n_max * f_max`` (the largest total thrust of n_max modules).
* ``denom(d) = n_max * max(h_1(d), f_max / 4)``, with h_1 the support of one module about its
  centre: a deficit h_T - h_W divided by denom is roughly "modules still missing in direction d,
  as a fraction of n_max" (forces add exactly per module; torques roughly).

Task vector (``K + 7``): h_T(d) / scale (K); mean and max |f| / scale; mean and max |tau| / (l *
scale); mean and standard deviation of f_z / scale; log(1 + t) / log(1 + 1000).

Structure vector (``2K + 7``): h_W(d) / scale (K); deficit (h_T(d) - h_W(d)) / denom(d) (K);
fraction of wrenches satisfied (exact oracle); n_modules / n_max; rank(A) / 6; fraction of
directions with h_W >= h_T; mean, max and min over wrenches of the per-wrench directional
deficit max_d (d . w_i - h_W(d)) / denom(d) (> 0 certifies that wrench infeasible).
Every entry is clipped to [-1, 1].

Candidate rows (``CANDIDATE_FEATURES`` = 5 per action, only with the env's ``lookahead=True``):
for the child structure C made by docking one module at the action's cell, from C's support
h_C on the same K directions (COM and torques recomputed for C; no oracle call):

0. mean_d h_C(d) / scale: the child's overall capability (> 0 for every structure: the +f_z
   axis always has positive support), so a valid action's row is never all zero;
1. fraction of directions with h_T(d) > h_C(d): the necessary-condition deficit count
   (0 when no direction certifies a missing wrench);
2. max_d (h_T(d) - h_C(d)) / denom(d): the largest normalised deficit (< 0: margin everywhere);
3. mean_d max(h_T(d) - h_C(d), 0) / denom(d): the mean positive normalised deficit;
4. fraction of task wrenches w_i rejected by the support test, max_d (d . w_i - h_C(d)) /
   denom(d) > slack_C (each such wrench is certainly infeasible for C; the others may or may
   not be feasible: a necessary test only).

With ``lookahead="exact"`` each row has ``EXACT_FEATURES`` = 3 more entries, from the exact
oracle (:mod:`.lookahead`): what the greedy rule ranks children by, so a policy can copy it and
learn where to depart from it:

5. the child's exact satisfied share (the ``satisfied_fraction`` a step to it would report);
6. the mean over the task's wrenches of the child's exact margin ``1 - gamma`` clipped to
   [-1, 1] (>= 0 exactly where a wrench is feasible);
7. 1 for greedy's choice (the first valid action, in (cell, type) order, of the best
   :func:`~modquad_gym.search.baselines.greedy_rank` of entries 5 and 6), else 0.

Rows of invalid actions are all zero.

The observation itself is a list of named :class:`ObservationBlock` (see
:func:`observation_blocks`), each deriving its own size and space.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from operator import attrgetter

import numpy as np
from gymnasium import spaces

from modquad_gym.core.jit import njit
from modquad_gym.envs.assembly.types import AssemblyState
from modquad_gym.geometry.module import ModuleType
from modquad_gym.geometry.structure import Structure
from modquad_gym.oracle import TOL

DEFAULT_N_DIRECTIONS = 48
"""Default K: the 12 signed axes plus 36 spread directions."""

TASK_SCALARS = 7
STRUCTURE_SCALARS = 7
CANDIDATE_FEATURES = 5
"""k: entries per action of the ``"candidates"`` observation (see the module docstring)."""
EXACT_FEATURES = 3
"""Entries the exact lookahead (``lookahead="exact"``) adds to each candidate row."""


def lookahead_width(lookahead: bool | str) -> int:
    """Entries per action of the lookahead rows: 0 (off), k (True), k + 3 (``"exact"``)."""
    if not lookahead:
        return 0
    return CANDIDATE_FEATURES + (EXACT_FEATURES if lookahead == "exact" else 0)


BATCH = 2**19
"""Most (structure, direction, column) projections :meth:`AssemblyFeatures.supports` holds at
once (4 MB)."""
FUSED_FROM = 65
"""Configuration matrices with at least this many columns (more than 16 four-rotor modules,
beyond the grid env's old reach, so recorded episodes replay bit for bit) get their support in
one compiled pass (:func:`_support`: the same values up to round-off)."""

_DIRECTION_SEED = 20240611
_CANDIDATES = 4096
MAX_N_DIRECTIONS = _CANDIDATES
"""Most support directions: the 12 axes and the rest sampled from a fixed cloud."""
_T_REF = 1000


def unit_directions(k: int = DEFAULT_N_DIRECTIONS) -> np.ndarray:
    """(k, 6) unit vectors: the 12 signed axes, then ``k - 12`` by farthest-point sampling from
    a fixed seeded cloud. Deterministic: the same k always gives the same directions."""
    if not isinstance(k, (int, np.integer)) or isinstance(k, bool) or not 12 <= k <= _CANDIDATES:
        raise ValueError(
            f"n_directions must be an integer in 12..{_CANDIDATES} (the signed axes, then "
            f"directions sampled from {_CANDIDATES} candidates), got {k!r}"
        )
    eye = np.eye(6)
    chosen = [*eye, *(-eye)]
    rng = np.random.default_rng(_DIRECTION_SEED)
    cloud = rng.standard_normal((_CANDIDATES, 6))
    cloud /= np.linalg.norm(cloud, axis=1, keepdims=True)
    # cosine similarity of each candidate to its nearest chosen direction (larger = closer)
    closest = (cloud @ np.array(chosen).T).max(axis=1)
    for _ in range(int(k) - 12):
        i = int(np.argmin(closest))
        chosen.append(cloud[i])
        closest = np.maximum(closest, cloud @ cloud[i])
    return np.array(chosen)


class AssemblyFeatures:
    """Computes the task and structure feature vectors for one module type, n_max and f_max.

    Args:
        module: the module type (its side l scales torques; its rotors give h_1).
        n_max: the largest module count (sets the normalisation).
        f_max: maximum thrust per rotor.
        n_directions: K, the number of support directions (>= 12).
    """

    def __init__(
        self,
        module: ModuleType,
        n_max: int,
        f_max: float,
        n_directions: int = DEFAULT_N_DIRECTIONS,
    ) -> None:
        self.n_max = int(n_max)
        self.f_max = float(f_max)
        self.side = float(module.side)
        self.units = unit_directions(n_directions)
        self.k = len(self.units)
        metric = np.array([1.0, 1.0, 1.0, 1.0 / self.side, 1.0 / self.side, 1.0 / self.side])
        self.D = self.units * metric  # wrench-space directions
        self.scale = 4.0 * self.n_max * self.f_max
        single = Structure([(0, 0)], module=module).configuration_matrix()
        self.h1 = np.maximum(self.D @ single, 0.0).sum(axis=1) * self.f_max
        self.denom = self.n_max * np.maximum(self.h1, self.f_max / 4.0)
        self._denom_over_scale = self.denom / self.scale
        self.task_size = self.k + TASK_SCALARS
        self.structure_size = 2 * self.k + STRUCTURE_SCALARS

    # --- task (once per episode) ----------------------------------------------------------
    def task(self, W: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(task vector float32, h_T / denom (K,), WD (t, K) = (d . w_i) / denom) for W (t, 6)."""
        proj = W @ self.D.T  # (t, K)
        h_T, f, tau, WD, h_Tn = _task_parts(proj, W, self.denom)
        # numpy's pairwise sums (a compiled loop would round differently for t > 8)
        t = len(W)
        fz = W[:, 2]
        fz_mean = np.add.reduce(fz) / t
        dev = fz - fz_mean
        dev *= dev
        fz_std = math.sqrt(np.add.reduce(dev) / t)
        s = self.scale
        ts = self.side * s
        tail = (
            np.add.reduce(f) / t / s,
            f.max() / s,
            np.add.reduce(tau) / t / ts,
            tau.max() / ts,
            fz_mean / s,
            fz_std / s,
            math.log1p(t) / math.log1p(_T_REF),
        )
        return _task_vector(h_T, s, np.array(tail)), h_Tn, WD

    # --- structure (every step) -----------------------------------------------------------
    def support(self, A: np.ndarray) -> tuple[np.ndarray, float]:
        """(h_W / denom, slack) on the K directions for configuration matrix A (6, m).

        h_W(d) = f_max * sum_k max(d . a_k, 0) is the exact support of W. A wrench whose
        per-wrench deficit (see :meth:`structure_against`) exceeds ``slack`` is certainly
        infeasible: the oracle accepts thrusts up to TOL * f_max / 2 outside [0, f_max]
        (gamma <= 1 + TOL), which widens the support by TOL * f_max / 2 * sum_k |d . a_k|;
        slack, 2 * TOL * f_max * sum_k |d . a_k| / denom(d), is four times that, so the test
        never rejects a wrench the oracle accepts.
        """
        if A.shape[1] >= FUSED_FROM:  # large structures: one compiled pass, no (K, m) arrays
            h_Wn, slack_max = _support(self.D, A, self.f_max, TOL, self.denom)
            return h_Wn, float(slack_max)
        P = self.D @ A
        h_W = np.maximum(P, 0.0).sum(axis=1) * self.f_max
        slack = (2.0 * TOL * self.f_max * np.abs(P).sum(axis=1) + 1e-12) / self.denom
        return h_W / self.denom, float(slack.max())

    def supports(self, A: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Batched :meth:`support`: (h_W / denom (L, K), slack (L,), d . c / denom (L, K) with
        c = A 1 f_max / 2 the centre of W) for A of shape (L, 6, m), a few structures at a
        time (the (L, K, m) projections of 300 children of 128 modules took 470 MB at once)."""
        step = max(1, BATCH // (self.k * A.shape[2]))
        if len(A) > step:
            parts = [self.supports(A[i : i + step]) for i in range(0, len(A), step)]
            return tuple(np.concatenate(p) for p in zip(*parts))
        P = np.einsum("kj,ljm->lkm", self.D, A)
        h_W = np.maximum(P, 0.0).sum(axis=2) * self.f_max
        slack = (2.0 * TOL * self.f_max * np.abs(P).sum(axis=2) + 1e-12) / self.denom
        centre = P.sum(axis=2) * (self.f_max / 2.0) / self.denom
        return h_W / self.denom, slack.max(axis=1), centre

    def candidates(
        self, h_Cn: np.ndarray, slack: np.ndarray, h_Tn: np.ndarray, WD: np.ndarray
    ) -> np.ndarray:
        """Candidate rows (float32, (L, CANDIDATE_FEATURES)) of L child structures against the
        task: ``h_Cn`` (L, K) and ``slack`` (L,) from :meth:`supports`, ``h_Tn`` (K,) and ``WD``
        (t, K) from :meth:`task`. Entries as in the module docstring, clipped to [-1, 1]."""
        gap = h_Tn[None, :] - h_Cn  # (L, K)
        per_wrench = (WD[None, :, :] - h_Cn[:, None, :]).max(axis=2)  # (L, t)
        out = np.empty((len(h_Cn), CANDIDATE_FEATURES), dtype=np.float32)
        out[:, 0] = (h_Cn * self._denom_over_scale).mean(axis=1)
        out[:, 1] = np.count_nonzero(gap > 0.0, axis=1) / self.k
        out[:, 2] = gap.max(axis=1)
        out[:, 3] = np.maximum(gap, 0.0).mean(axis=1)
        out[:, 4] = np.count_nonzero(per_wrench > slack[:, None], axis=1) / WD.shape[0]
        return np.clip(out, -1.0, 1.0, out=out)

    def structure_head(self, h_Wn: np.ndarray, rank: int, n_modules: int) -> np.ndarray:
        """The task-independent entries of the structure vector (float32, 2K + 7; the others
        zero): h_W / scale, n_modules / n_max and rank / 6, clipped. Cache it per structure."""
        out = np.zeros(self.structure_size, dtype=np.float32)
        k = self.k
        out[:k] = h_Wn * self._denom_over_scale
        out[2 * k + 1] = n_modules / self.n_max
        out[2 * k + 2] = rank / 6.0
        return np.clip(out, -1.0, 1.0, out=out)

    def structure_against(
        self,
        head: np.ndarray,
        h_Wn: np.ndarray,
        h_Tn: np.ndarray,
        per_wrench: np.ndarray,
        satisfied_fraction: float,
    ) -> np.ndarray:
        """The structure vector (float32, 2K + 7) against the task, from its
        :meth:`structure_head` and the task-dependent parts: ``h_Wn`` and ``h_Tn`` the supports
        divided by denom, ``per_wrench`` (t,) max_d (d . w_i - h_W(d)) / denom(d); a new
        array."""
        mean = np.add.reduce(per_wrench) / len(per_wrench)  # numpy's (pairwise) sum
        return _structure_against(head, h_Wn, h_Tn, per_wrench, satisfied_fraction, mean)


@njit(cache=True)
def _task_parts(proj, W, denom):  # pragma: no cover - compiled
    """(h_T (K,), |f_i| (t,), |tau_i| (t,), proj / denom (t, K), h_T / denom (K,)) from the
    projections proj (t, K) of the wrenches W (t, 6); the same roundings as numpy's
    ``proj.max(axis=0)``, ``sqrt(add.reduce(F * F, axis=1))`` (a sequential sum of three) and
    element-wise division."""
    t, k = proj.shape
    h_T = proj[0].copy()
    WD = np.empty((t, k))
    f = np.empty(t)
    tau = np.empty(t)
    for i in range(t):
        for d in range(k):
            v = proj[i, d]
            if v > h_T[d]:
                h_T[d] = v
            WD[i, d] = v / denom[d]
        f[i] = np.sqrt(W[i, 0] * W[i, 0] + W[i, 1] * W[i, 1] + W[i, 2] * W[i, 2])
        tau[i] = np.sqrt(W[i, 3] * W[i, 3] + W[i, 4] * W[i, 4] + W[i, 5] * W[i, 5])
    return h_T, f, tau, WD, h_T / denom


@njit(cache=True)
def _support(D, A, f_max, tol, denom):  # pragma: no cover - compiled
    """:meth:`AssemblyFeatures.support` in one pass over P = D A: (h_W / denom, max slack)."""
    K, m = D.shape[0], A.shape[1]
    h = np.empty(K)
    worst = 0.0
    for d in range(K):
        pos = 0.0
        total = 0.0
        for k in range(m):
            p = 0.0
            for i in range(6):
                p += D[d, i] * A[i, k]
            if p > 0.0:
                pos += p
                total += p
            else:
                total -= p
        h[d] = pos * f_max / denom[d]
        worst = max(worst, (2.0 * tol * f_max * total + 1e-12) / denom[d])
    return h, worst


@njit(cache=True)
def _task_vector(h_T, scale, tail):  # pragma: no cover - compiled
    """The task vector: h_T / scale then the scalars ``tail``, clipped to [-1, 1], float32."""
    k = len(h_T)
    vec = np.empty(k + len(tail), dtype=np.float32)
    for d in range(k):
        vec[d] = min(max(h_T[d] / scale, -1.0), 1.0)
    for i in range(len(tail)):
        vec[k + i] = min(max(tail[i], -1.0), 1.0)
    return vec


@njit(cache=True)
def _structure_against(head, h_Wn, h_Tn, per_wrench, satisfied_fraction, mean):
    """:meth:`AssemblyFeatures.structure_against` compiled: every entry is rounded to float32
    once from the same float64 value as numpy's element-wise version would (the mean of
    per_wrench comes from numpy, whose pairwise sum a loop would not reproduce)."""
    k = len(h_Wn)
    out = head.copy()
    covered = 0
    for i in range(k):
        out[k + i] = h_Tn[i] - h_Wn[i]
        covered += h_Wn[i] >= h_Tn[i]
    j = 2 * k
    out[j] = satisfied_fraction
    out[j + 3] = covered / k
    out[j + 4] = mean
    out[j + 5] = per_wrench.max()
    out[j + 6] = per_wrench.min()
    for i in range(len(out)):
        out[i] = min(max(out[i], np.float32(-1.0)), np.float32(1.0))
    return out


# --- observation blocks ---------------------------------------------------------------------
@dataclass(frozen=True)
class ObservationBlock:
    """One named entry of the observation: its size, bounds, dtype (hence its space) and how it
    is read from an :class:`~.types.AssemblyState` (``fresh``: a new array, else copied)."""

    name: str
    size: int
    read: Callable[[AssemblyState], np.ndarray]
    low: float = -1.0
    high: float = 1.0
    dtype: type = np.float32
    fresh: bool = False

    def space(self) -> spaces.Box:
        return spaces.Box(self.low, self.high, (self.size,), self.dtype)

    def value(self, state: AssemblyState) -> np.ndarray:
        """The entry of ``state``, the caller's own (copied once at most: megabytes at 128)."""
        out = self.read(state)
        return out if self.fresh else out.copy()


def _candidate_rows(state: AssemblyState) -> np.ndarray:
    """Every action's row: the state's rows at its valid actions, zero elsewhere."""
    rows = np.zeros((state.mask.size, state.candidates.shape[1]), dtype=np.float32)
    rows[state.mask.view(bool)] = state.candidates
    return rows.reshape(-1)


def _occupancy(state: AssemblyState) -> np.ndarray:
    return state.occupancy.astype(np.float32)  # states keep int8 (as the type one-hot)


def _types(state: AssemblyState) -> np.ndarray:
    return state.types_onehot.astype(np.float32)


def observation_blocks(
    n_cells: int, n_types: int, features: AssemblyFeatures, lookahead: bool | str
) -> list[ObservationBlock]:
    """The observation's blocks, in order, for a grid of ``n_cells`` cells and ``n_types``
    module types (the ``"types"`` block only when several); add a block here to add a
    feature."""
    n_actions = n_cells * n_types
    blocks = [
        ObservationBlock("occupancy", n_cells, _occupancy, 0.0, 1.0, fresh=True),
        ObservationBlock("action_mask", n_actions, attrgetter("mask"), 0, 1, np.int8),
        ObservationBlock("task", features.task_size, attrgetter("task.vec")),
        ObservationBlock("structure", features.structure_size, attrgetter("structure_vec")),
    ]
    if lookahead:
        size = n_actions * lookahead_width(lookahead)
        blocks.append(ObservationBlock("candidates", size, _candidate_rows, fresh=True))
    if n_types > 1:
        blocks.append(ObservationBlock("types", n_actions, _types, 0.0, 1.0, fresh=True))
    return blocks
