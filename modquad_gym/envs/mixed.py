"""``ModQuadAssembly-v0`` with several module types: each action docks a module *of a type*.

``gym.make("ModQuadAssembly-v0", modules=[mA, mB, ...])`` (types, or stock names such as
``"t45,t45m,flat"``, :func:`modquad_gym.module.palette`) builds this environment; without
``modules`` the one-type environment, its spaces and its episodes are unchanged.

Spaces (G = 2 n_max - 1 grid cells a side, K types, the palette order fixed at construction):

* action ``Discrete(G * G * K)``: ``a = k * G * G + c`` docks a module of type k at grid cell
  c (c indexed as in the one-type environment: ``c = (y + n_max - 1) G + (x + n_max - 1)``);
  ``action_of(cell, k)`` and ``cell_of(a)``, ``type_of(a)`` convert. A valid action's cell is
  empty and adjacent; every type of a valid cell is valid. The masks (``action_masks()``,
  ``obs["action_mask"]``, ``info["action_mask"]``) have G * G * K entries, type-major
  (``mask.reshape(K, G * G)[k]`` is the cell mask of type k). Invalid actions never raise.
* observation: the one-type entries (``"occupancy"``, ``"task"``, ``"structure"``; the
  structure features are those of the mixed structure's own configuration matrix, normalised
  with the first type's single-module support) plus ``"types"`` (G * G * K,) in {0, 1},
  type-major one-hot: ``types.reshape(K, G * G)[k, c]`` is 1 when cell c holds a type-k module.
  With ``lookahead=True`` ``"candidates"`` has one row per (type, cell) action.

Starting state: one module at (0, 0) of type ``initial_type`` (default 0, the first type; an
int, or ``"random"`` to draw it with the env's generator at each reset; ``reset(options=
{"initial_type": k})`` for one episode). A structure is reachable from a start exactly when it
holds a module of the start's type (any connected structure can be grown from any of its cells).

Tasks of kind ``external`` are decided on the rotor wrenches ``w + M g e_z`` of the current
structure's mass M (:func:`modquad_gym.tasks.rotor_wrenches`), so heavier structures must lift
more; ``total`` tasks as in the one-type environment. ``info`` also carries ``modules`` (the
type name of each module, in ``cells`` order) and ``mass_kg``.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from gymnasium import spaces
from gymnasium.error import ResetNeeded

from ..module import GRAVITY, ModuleType, palette
from ..structure import Cell, Structure, mixed_configuration_matrices, normalise_typed
from ..tasks import check_kind
from .assembly import _CACHE_SIZE, _STEPS, ModQuadAssemblyEnv, _Backend, _Capability
from .features import CANDIDATE_FEATURES

__all__ = ["MixedAssemblyEnv"]


class _MixedBackend(_Backend):
    """The one-type backend for typed keys ``(((x, y), type), ...)`` of a palette."""

    def __init__(self, types: list[ModuleType], n_max, f_max, n_directions, method) -> None:
        super().__init__(types[0], n_max, f_max, n_directions, method)
        self.palette = types
        self.index = {id(m): k for k, m in enumerate(types)}

    def capability_of(self, key) -> _Capability:
        hit = self.capability.get(key)
        if hit is None:
            if len(self.capability) >= _CACHE_SIZE:
                self.capability.clear()
            cells = tuple(c for c, _ in key)
            s = Structure.from_trusted(cells, modules=tuple(m for _, m in key))
            A = s.configuration_matrix()
            rank = self.oracle.zonotope(A, key=key).rank
            hit = self.capability[key] = _Capability(A, rank, len(key), self.features)
        return hit

    def supports_of(self, keys: list) -> tuple[np.ndarray, np.ndarray]:
        missing = [k for k in dict.fromkeys(keys) if k not in self.supports]
        if missing:
            if len(self.supports) + len(missing) > _CACHE_SIZE:
                self.supports.clear()
            cells = np.array([[c for c, _ in k] for k in missing], dtype=float)
            types = np.array([[self.index[id(m)] for _, m in k] for k in missing])
            A = mixed_configuration_matrices(cells, types, self.palette)
            h, slack = self.features.supports(A)
            for k, hk, sk in zip(missing, h, slack):
                self.supports[k] = (hk, float(sk))
        rows = [self.supports[k] for k in keys]
        return np.array([r[0] for r in rows]), np.array([r[1] for r in rows])


class MixedAssemblyEnv(ModQuadAssemblyEnv):
    """Assemble a structure of several module types (module docstring); every other argument
    is that of :class:`~modquad_gym.envs.assembly.ModQuadAssemblyEnv`.

    Args:
        modules: the palette: a list of :class:`~modquad_gym.module.ModuleType` (one side), or
            stock names (``"t45,t45m,flat"`` or ``["t45", "flat"]``).
        initial_type: the first module's type index, or ``"random"``.
    """

    def __init__(self, *args: Any, modules: Any = None, initial_type: Any = 0, **kwargs: Any):
        if kwargs.get("module") is not None:
            raise ValueError("give module= (one type) or modules= (a palette), not both")
        types = palette(modules if modules is not None else ["t45"])
        if len({m.side for m in types}) > 1 or len({m.n_rotors for m in types}) > 1:
            raise ValueError("modules: every type must have the same side and rotor count")
        self.palette = types
        self.n_types = len(types)
        self.initial_type = self._check_type(initial_type, "initial_type", allow_random=True)
        kwargs["module"] = types[0]
        super().__init__(*args, **kwargs)
        G, K = self.side, self.n_types
        self._n_cells = G * G
        self._n_actions = G * G * K
        self.action_space = spaces.Discrete(G * G * K)
        obs = dict(self.observation_space.spaces)
        obs["action_mask"] = spaces.Box(0, 1, (G * G * K,), np.int8)
        obs["types"] = spaces.Box(0.0, 1.0, (G * G * K,), np.float32)
        if self.lookahead:
            obs["candidates"] = spaces.Box(-1.0, 1.0, (G * G * K * CANDIDATE_FEATURES,), np.float32)
        self.observation_space = spaces.Dict(obs)
        self._cell_mask0 = self._initial_mask.copy()
        self._initial_mask = np.tile(self._cell_mask0, K)
        self._masses = np.array([m.mass for m in types])
        self._tidx: list[int] = []

    def _check_type(self, value: Any, what: str, allow_random: bool = False) -> int | str:
        if allow_random and value == "random":
            return "random"
        if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, np.integer)):
            raise ValueError(f"{what} must be a type index (or 'random'), got {value!r}")
        if not 0 <= int(value) < self.n_types:
            raise ValueError(f"{what} must lie in [0, {self.n_types}), got {value!r}")
        return int(value)

    # --- grid <-> actions -----------------------------------------------------------------
    def action_of(self, cell: Cell, type_index: int = 0) -> int:
        """The action that docks a module of palette type ``type_index`` at ``cell``."""
        return int(type_index) * self.side * self.side + super().action_of(cell)

    def cell_of(self, action: int) -> Cell:
        return super().cell_of(int(action) % (self.side * self.side))

    def type_of(self, action: int) -> int:
        """The palette index of the type that ``action`` docks."""
        return int(action) // (self.side * self.side)

    def _backend(self, f_max: float) -> _Backend:
        b = self._backends.get(f_max)
        if b is None:
            b = _MixedBackend(
                self.palette, self.n_max, f_max, self.n_directions, self.oracle_method
            )
            self._backends[f_max] = b
        return b

    # --- state ----------------------------------------------------------------------------
    @property
    def structure(self) -> Structure:
        """The current structure (cells in docking order, each with its type)."""
        if self._cells is None:
            raise ResetNeeded("call reset() before asking for the structure")
        return Structure(self._cells, modules=[self.palette[t] for t in self._tidx])

    def _key(self, cells: list[Cell], tidx: list[int]) -> tuple:
        return normalise_typed(cells, (self.palette[t] for t in tidx))

    def _shifted(self, mass: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(rotor wrenches, h_T / denom, WD) of the task for a structure of ``mass`` kg."""
        if self._kind == "total":
            return self._W, self._h_Tn, self._WD
        W = self._W.copy()
        W[:, 2] += mass * GRAVITY
        WD = self._WD + mass * self._lift_n
        return W, WD.max(axis=0), WD

    def _evaluate(self) -> None:
        b = self._be
        self._evaluated += 1
        key = self._key(self._cells, self._tidx)
        hit = self._memo.get(key)
        if hit is None:
            mass = float(self._masses[self._tidx].sum())
            W_all, h_Tn, WD = self._shifted(mass)
            cap = b.capability_of(key)
            per_wrench = np.maximum.reduce(WD - cap.h_Wn, axis=1)
            open_ = per_wrench <= cap.slack  # the others are certainly infeasible
            n_sat = 0
            if np.count_nonzero(open_):
                n_sat = b.count_feasible(cap, key, W_all[open_])
            vec = b.features.structure_against(
                cap.head, cap.h_Wn, h_Tn, per_wrench, n_sat / len(self._W)
            )
            hit = self._memo[key] = (n_sat, vec)
        n_sat, self._structure_vec = hit
        self._frac = n_sat / len(self._W)
        self._success = n_sat == len(self._W)

    def _update_candidates(self) -> None:
        G2, K = self._n_cells, self.n_types
        if self._cand.shape[0] != G2 * K:
            self._cand = np.zeros((G2 * K, CANDIDATE_FEATURES), dtype=np.float32)
        self._cand[:] = 0.0
        valid = np.flatnonzero(self._mask)
        if len(valid) == 0:
            return
        memo = self._cand_memo
        mass0 = float(self._masses[self._tidx].sum())
        for k in range(K):  # one child mass per type: one batch each
            acts = valid[valid // G2 == k]
            if not len(acts):
                continue
            keys = [self._key([*self._cells, self.cell_of(a)], [*self._tidx, k]) for a in acts]
            missing = [c for c in dict.fromkeys(keys) if c not in memo]
            if missing:
                _, h_Tn, WD = self._shifted(mass0 + self._masses[k])
                h, slack = self._be.supports_of(missing)
                memo.update(zip(missing, self._be.features.candidates(h, slack, h_Tn, WD)))
            self._cand[acts] = [memo[c] for c in keys]

    def _observation(self) -> dict[str, np.ndarray]:
        obs = super()._observation()
        obs["types"] = self._types_obs.copy()
        return obs

    def _info(self, invalid: bool = False, terms: dict[str, float] | None = None) -> dict:
        info = super()._info(invalid, terms)
        info["modules"] = [self.palette[t].name for t in self._tidx]
        info["mass_kg"] = float(self._masses[self._tidx].sum())
        return info

    # --- Gymnasium API --------------------------------------------------------------------
    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[dict[str, np.ndarray], dict]:
        options = dict(options or {})
        start = options.pop("initial_type", None)
        if start is not None:
            start = self._check_type(start, "options['initial_type']")
        if seed is not None:  # seed first, so a random initial type follows the seed
            super(ModQuadAssemblyEnv, self).reset(seed=seed)
        if start is None:
            start = self.initial_type
        if start == "random":
            start = int(self.np_random.integers(self.n_types))
        self._tidx = [int(start)]
        G2 = self._n_cells
        self._types_obs = np.zeros(G2 * self.n_types, dtype=np.float32)
        self._types_obs[start * G2 + self._centre] = 1.0
        return super().reset(seed=None, options=options or None)

    def _memo_for(self, task: Any, f_max: float) -> tuple[dict, dict]:
        # called by reset once the task is drawn: the place to read its kind
        self._kind = check_kind(getattr(task, "kind", "total"))
        feats = self._backend(f_max).features
        self._lift_n = GRAVITY * feats.D[:, 2] / feats.denom
        return super()._memo_for(task, f_max)

    def step(self, action: Any) -> tuple[dict[str, np.ndarray], float, bool, bool, dict]:
        if self._cells is None:
            raise ResetNeeded("call reset() before step()")
        if self._done:
            raise ResetNeeded("the episode is over; call reset() before step()")
        a = self._parse_action(action)
        self._steps += 1
        added = invalid = False
        frac_before = self._frac
        G2 = self._n_cells
        if self._success:  # solved at reset: this step (any action) only ends the episode
            terminated = True
        elif a is not None and self._mask[a]:
            added = True
            c, k = a % G2, a // G2
            x, y = self.cell_of(c)
            self._cells.append((x, y))
            self._tidx.append(int(k))
            self._occ[c] = 1.0
            self._types_obs[k * G2 + c] = 1.0
            self._mask[c::G2] = 0
            for dx, dy in _STEPS:
                nx, ny = x + dx, y + dy
                if max(abs(nx), abs(ny)) <= self.radius:
                    b = (ny + self.radius) * self.side + nx + self.radius
                    if not self._occ[b]:
                        self._mask[b::G2] = 1
            self._evaluate()
            terminated = self._success or len(self._cells) >= self.n_max or not self._mask.any()
        else:
            invalid = True
            terminated = self.invalid_action == "terminate"
        truncated = not terminated and self._steps >= self.max_steps
        self._done = terminated or truncated
        if terminated:
            self._mask[:] = 0
        if self.lookahead and (added or terminated):
            self._update_candidates()
        terms = self.weights.terms(
            self._frac - frac_before, added, self._success and terminated, invalid
        )
        reward = float(sum(terms.values()))
        return self._observation(), reward, terminated, truncated, self._info(invalid, terms)

    def _frame(self) -> np.ndarray:
        from ..oracle import feasible
        from ..viz import structure_image

        s = self.structure
        W, _, _ = self._shifted(s.mass)
        status = feasible(s.configuration_matrix(), W, self._be.oracle.f_max, self.oracle_method)
        return structure_image(s, size=self.render_size, wrench_status=status)

    def _ansi(self) -> str:
        text = super()._ansi().splitlines()
        letters = {c: chr(65 + t) for c, t in zip(self._cells, self._tidx)}
        rows = [text[0]]
        for row_text, y in zip(text[1:], range(self.radius, -self.radius - 1, -1)):
            marks = row_text.split(" ")
            for i, x in enumerate(range(-self.radius, self.radius + 1)):
                if (x, y) in letters:
                    ch = letters[(x, y)]
                    marks[i] = ch.lower() if (x, y) == (0, 0) else ch
            rows.append(" ".join(marks))
        legend = ", ".join(f"{chr(65 + k)} = {m.name}" for k, m in enumerate(self.palette))
        return "\n".join(rows + [legend]) + "\n"
