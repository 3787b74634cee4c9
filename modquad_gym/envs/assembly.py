"""The Gymnasium environment ``ModQuadAssembly-v0``: build a structure module by module.

Split as in Jumanji: this module is the environment (state, spaces, transitions); tasks come from
a generator (:mod:`modquad_gym.tasks`), the reward from :mod:`.reward`, observation features from
:mod:`.features`, pictures from :mod:`modquad_gym.viz`.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium import spaces
from gymnasium.error import ResetNeeded

from ..extras import import_optional
from ..module import ModuleType
from ..oracle import WrenchOracle, check_f_max
from ..structure import Cell, Key, Structure, configuration_matrices, normalise
from ..tasks import TaskRequirement, make_generator
from ..validation import check_int
from .features import CANDIDATE_FEATURES, DEFAULT_N_DIRECTIONS, AssemblyFeatures
from .reward import RewardWeights

INVALID_ACTION_MODES = ("penalise", "terminate")

_CACHE_SIZE = 16384
_MEMO_TASKS = 16
_STEPS = ((1, 0), (-1, 0), (0, 1), (0, -1))
N_MAX_LIMIT = 16
"""Largest ``n_max`` (the grid has (2 n_max - 1)^2 actions; the searches stop at 16 too)."""
MAX_STEPS_LIMIT = 4 * N_MAX_LIMIT
"""Largest ``max_steps``; also ``max_episode_steps`` at registration, so no episode is longer."""


class _Capability:
    """What the env keeps per structure (translation key), for any task: its configuration
    matrix, support values (see :meth:`AssemblyFeatures.support`), rank and the
    task-independent part of its structure vector (:meth:`AssemblyFeatures.structure_head`)."""

    __slots__ = ("A", "h_Wn", "slack", "rank", "head")

    def __init__(
        self, A: np.ndarray, rank: int, n_modules: int, features: AssemblyFeatures
    ) -> None:
        self.A = A
        self.rank = rank
        self.h_Wn, self.slack = features.support(A)
        self.head = features.structure_head(self.h_Wn, rank, n_modules)


class _Backend:
    """Everything that depends on (module, n_max, f_max, K) and survives across episodes: the
    oracle with its per-structure zonotope cache, the feature maker, and per-structure
    capability and support values. Reusing it across episodes is what makes steps fast with a
    fresh task each episode."""

    def __init__(
        self, module: ModuleType, n_max: int, f_max: float, n_directions: int, method: str
    ) -> None:
        self.module = module
        self.oracle = WrenchOracle(f_max, method=method)
        self.features = AssemblyFeatures(module, n_max, f_max, n_directions)
        self.capability: dict[Key, _Capability] = {}
        self.supports: dict[Key, tuple[np.ndarray, float]] = {}
        self.tests = 0  # wrench-structure tests made (info["oracle_calls"] counts these)

    def capability_of(self, key: Key) -> _Capability:
        """The :class:`_Capability` of the structure with translation ``key``, cached."""
        hit = self.capability.get(key)
        if hit is None:
            if len(self.capability) >= _CACHE_SIZE:
                self.capability.clear()
            A = Structure.from_trusted(key, module=self.module).configuration_matrix()
            rank = self.oracle.zonotope(A, key=key).rank
            hit = self.capability[key] = _Capability(A, rank, len(key), self.features)
        return hit

    def count_feasible(self, cap: _Capability, key: Key, W: np.ndarray) -> int:
        """How many rows of W (k, 6) the structure ``key`` can produce (exact oracle)."""
        self.tests += len(W)
        return int(np.count_nonzero(self.oracle.feasible(cap.A, W, key=key)))

    def supports_of(self, keys: list[Key]) -> tuple[np.ndarray, np.ndarray]:
        """(h_W / denom (L, K), slack (L,)) of the structures ``keys`` (all of one size), cached
        per key; misses are computed in one batch from their configuration matrices (no oracle
        call, no zonotope)."""
        missing = [k for k in dict.fromkeys(keys) if k not in self.supports]
        if missing:
            if len(self.supports) + len(missing) > _CACHE_SIZE:
                self.supports.clear()
            h, slack = self.features.supports(configuration_matrices(missing, self.module))
            for k, hk, sk in zip(missing, h, slack):
                self.supports[k] = (hk, float(sk))
        rows = [self.supports[k] for k in keys]
        return np.array([r[0] for r in rows]), np.array([r[1] for r in rows])


class ModQuadAssemblyEnv(gym.Env[dict[str, np.ndarray], np.int64]):
    """Assemble the smallest modular multirotor (H-ModQuad) that can exert a task's wrenches.

    ## Description
    A task is a set of t wrenches w = [f; tau] (body frame, SI units; f_max per rotor) that the
    robot must be able to produce. The agent starts from one module and docks one more per step
    on a square grid. A structure satisfies a wrench when it lies in its feasible-wrench zonotope
    W = {A u : 0 <= u <= f_max}, decided exactly by :class:`~modquad_gym.oracle.WrenchOracle`.
    The goal is to satisfy every wrench with as few modules as possible (paper Problem 1).

    Make it with ``gym.make("modquad_gym:ModQuadAssembly-v0", **kwargs)``, which imports
    ``modquad_gym`` (and so registers the environment) first and works in a fresh process; after
    ``import modquad_gym``, ``gym.make("ModQuadAssembly-v0", **kwargs)`` works too. (Gymnasium 1.x
    does not load the ``gymnasium.envs`` entry point, so the bare id needs the import.)

    ## Action Space
    ``Discrete(G * G)`` with G = 2 * n_max - 1: one action per grid cell (x, y), with x and y in
    [-(n_max - 1), n_max - 1] around the initial module at (0, 0):
    ``a = (y + n_max - 1) * G + (x + n_max - 1)``. Action a is *valid* when its cell is empty,
    4-adjacent to the structure and the episode is not over; a valid action docks a module there.
    The mask of valid actions is exposed three ways: ``action_masks()`` (bool, also before
    ``reset``, for sb3-contrib's MaskablePPO), ``obs["action_mask"]`` and
    ``info["action_mask"]``. In a terminal state (and in the rare task that one module already
    satisfies) no action is valid.

    Every other action is *invalid*, and an invalid action never raises: it leaves the
    structure unchanged and costs ``w_invalid`` (``invalid_action="penalise"``) or also ends the
    episode (``"terminate"``), with ``info["invalid_action"]`` True. Invalid are an empty cell
    that is not adjacent, an occupied cell, and anything that is not an integer in
    ``[0, G * G)``: -1, G * G, 2.5, nan, True, None, "3", [1, 2], ... An integer is a Python
    or numpy integer or a one-element array of integer dtype; a whole-number float (3.0,
    ``np.float32(3)``, ``np.array([3.0])``) counts as that integer; a boolean never does.

    ## Observation Space
    A ``Dict`` of Boxes (float32 unless noted), fixed-size for any number t of task wrenches:

    * ``"occupancy"`` (G * G,) in {0, 1}: 1 where a module sits, indexed like the actions:
      ``occupancy[a]`` is the cell of action a, and ``occupancy.reshape(G, G)`` has row
      y + n_max - 1 and column x + n_max - 1 (flat, as SB3's MultiInputPolicy expects; reshape
      for a CNN). The initial module is always at the centre.
    * ``"action_mask"`` (G * G,) int8 in {0, 1}: 1 for valid actions.
    * ``"task"`` (K + 7,) in [-1, 1]: permutation-invariant task features (support function on
      K fixed directions, force/torque statistics, log t).
    * ``"structure"`` (2K + 7,) in [-1, 1]: the structure's support function, its deficit against
      the task per direction, the fraction of satisfied wrenches, n_modules / n_max, rank / 6 and
      per-wrench directional deficits.
    * ``"candidates"`` (G * G * k,) in [-1, 1], only with ``lookahead=True`` (k = 5,
      :data:`~modquad_gym.envs.features.CANDIDATE_FEATURES`): per-action lookahead, row a
      (``candidates.reshape(G * G, k)[a]``) describes the child structure that action a would
      build, from its support function alone (its capability, the fraction of directions and
      the largest and mean normalised support deficit against the task, the fraction of task
      wrenches its support certainly rejects). Rows of invalid actions are zero, rows of valid
      ones never all zero. These are cheap necessary tests, not oracle calls: they do not count
      in ``info["evaluated"]`` or ``info["oracle_calls"]``.

    K = ``n_directions`` (default 48); :mod:`modquad_gym.envs.features` documents every entry
    and its normalisation.

    ## Rewards
    ``r_t = w_sat * (frac_t - frac_{t-1}) - w_module * added_t + w_success * success_t
    - w_invalid * invalid_t``, with frac the fraction of satisfied wrenches. An episode's return
    is therefore ``w_sat * (frac_T - frac_0) - w_module * (n_T - 1) + w_success * success
    - w_invalid * n_invalid``: for a successful episode, fewer modules always earn more
    (w_module > 0), and success beats failure when w_success > w_module * (n_max - 1). Defaults:
    w_sat = 1, w_module = 0.1, w_success = 1, w_invalid = 0.1. ``info["reward_terms"]`` holds the
    four terms of each step.

    ## Starting State
    One module at cell (0, 0) and a task drawn from the task source with ``self.np_random``
    (seeded by ``reset(seed=...)``), or the task given as ``reset(options={"task": task})``
    (a :class:`~modquad_gym.tasks.TaskRequirement` or a (t, 6) wrench array).

    ## Episode End
    * Termination (success): every task wrench is satisfied. If one module already satisfies the
      task at reset, ``info["success"]`` is True there, the mask is all zero, and the next step
      (any action) ends the episode with the success bonus and no module added.
    * Termination (failure): n_max modules without success, no valid action left, or an invalid
      action with ``invalid_action="terminate"``.
    * Truncation: ``max_steps`` steps (default 4 * n_max) without termination; only reachable
      through invalid actions.

    ## Arguments
    * ``tasks``: task source: ``"paper"``, ``"planted"``, ``"screwdriver"``, ``"mixed"``
      (default), a task file path, a TaskRequirement, a list of them, or a generator: any
      callable ``gen(rng) -> TaskRequirement`` (or a (t, 6) wrench array), called with
      ``self.np_random`` at each reset; a result of another kind raises a ValueError there.
      See :func:`modquad_gym.tasks.make_generator`.
    * ``n_max``: the largest number of modules (default 7, as in the paper), 2 to 16.
    * ``module``: the :class:`~modquad_gym.module.ModuleType` of every module (default the
      T-module, eta = pi/4).
    * ``modules``: several module types (or stock names, ``"t45,t45m,flat"``): the env is then
      :class:`~modquad_gym.envs.mixed.MixedAssemblyEnv`, whose action is (cell, type) as one
      ``Discrete(G * G * K)`` and whose observation adds the types (see there); also for tasks
      of kind ``external`` (self-weight). Default None: one type, this class.
    * ``f_max``: maximum thrust per rotor; None (default) uses each task's own f_max.
    * ``reward_weights``: a :class:`~modquad_gym.envs.reward.RewardWeights` or a dict of some
      of ``w_sat``, ``w_module``, ``w_success``, ``w_invalid``.
    * ``invalid_action``: ``"penalise"`` (default) or ``"terminate"``.
    * ``max_steps``: the step limit for truncation (default 4 * n_max, at most 64; the
      registered ``max_episode_steps`` is 64, so ``env.spec`` bounds every episode).
    * ``render_mode``: None, ``"rgb_array"`` (the structure picture, (H, W, 3) uint8),
      ``"human"`` (that picture in a pygame window; the ``viz`` extra) or ``"ansi"`` (a text
      grid). ``gymnasium.wrappers.RecordVideo`` works on ``"rgb_array"`` (needs moviepy).
    * ``n_directions``: K, the support directions of the features (default 48, 12..4096).
    * ``oracle_method``: the oracle's method (default ``"auto"``, exact and certified).
    * ``render_size``: (height, width) of ``rgb_array`` frames (default (256, 256)).
    * ``lookahead``: add the ``"candidates"`` observation (default False: the observation is
      exactly the four entries above).

    ``info`` carries ``n_modules``, ``satisfied_fraction``, ``success`` (and the same as
    ``is_success``, which SB3's ``Monitor``/``EvalCallback`` and RL Zoo read), ``cells`` (list of
    [x, y], initial module first), ``evaluated`` (structures the oracle evaluated this episode:
    the initial one plus one per docking), ``oracle_calls`` (wrench tests this episode),
    ``action_mask``, ``task_name``, ``n_wrenches``, ``invalid_action`` and ``reward_terms``.

    ## Version History
    * v0: initial version; the opt-in ``lookahead`` keyword (``"candidates"`` observation)
      was added later and leaves the default observation unchanged. Later still, actions that
      are not integers of the action space became invalid actions (they used to raise a
      ValueError), and any callable became a task source; observations, rewards and infos of
      valid input are unchanged. ``info["is_success"]``, ``render_mode="human"`` and
      ``max_episode_steps`` at registration were added without changing any episode.
    """

    metadata = {"render_modes": ["human", "rgb_array", "ansi"], "render_fps": 4}

    def __new__(cls, *args: Any, **kwargs: Any):
        if cls is ModQuadAssemblyEnv and kwargs.get("modules") is not None:
            from .mixed import MixedAssemblyEnv  # several module types: (cell, type) actions

            cls = MixedAssemblyEnv
        return super().__new__(cls)

    def __init__(
        self,
        tasks: Any = "mixed",
        n_max: int = 7,
        module: ModuleType | None = None,
        f_max: float | None = None,
        reward_weights: RewardWeights | dict | None = None,
        invalid_action: str = "penalise",
        max_steps: int | None = None,
        render_mode: str | None = None,
        n_directions: int = DEFAULT_N_DIRECTIONS,
        oracle_method: str = "auto",
        render_size: tuple[int, int] = (256, 256),
        lookahead: bool = False,
        modules: Any = None,
    ) -> None:
        if modules is not None:  # only MixedAssemblyEnv takes a palette
            raise ValueError("modules: a palette needs MixedAssemblyEnv (what gym.make builds)")
        n_max = check_int(n_max, "n_max", 2, N_MAX_LIMIT)
        if module is not None and not isinstance(module, ModuleType):
            raise ValueError(f"module must be a ModuleType, got {type(module).__name__}")
        if invalid_action not in INVALID_ACTION_MODES:
            raise ValueError(
                f"invalid_action must be one of {INVALID_ACTION_MODES}, got {invalid_action!r}"
            )
        if render_mode is not None and render_mode not in self.metadata["render_modes"]:
            raise ValueError(
                f"render_mode must be None or one of {self.metadata['render_modes']}, "
                f"got {render_mode!r}"
            )
        if not isinstance(lookahead, (bool, np.bool_)):
            raise ValueError(f"lookahead must be a bool, got {lookahead!r}")
        self.lookahead = bool(lookahead)
        self.n_max = int(n_max)
        if max_steps is None:
            max_steps = 4 * self.n_max
        max_steps = check_int(max_steps, "max_steps", self.n_max - 1, MAX_STEPS_LIMIT)
        self.max_steps = int(max_steps)
        self.module = module if module is not None else Structure([(0, 0)]).module
        self.f_max = None if f_max is None else check_f_max(f_max)
        self.weights = RewardWeights.coerce(reward_weights)
        self.invalid_action = invalid_action
        self.render_mode = render_mode
        self.render_size = tuple(render_size)
        self.n_directions = int(n_directions)
        self.oracle_method = oracle_method
        self.task_source = tasks
        self.generator: Callable[[np.random.Generator], Any] = make_generator(tasks)

        self.radius = self.n_max - 1
        self.side = 2 * self.n_max - 1
        G = self.side
        self._backends: dict[float, _Backend] = {}
        self._memos: dict[tuple[int, float], tuple[Any, dict]] = {}
        probe = self._backend(1.0 if self.f_max is None else self.f_max).features
        self.action_space = spaces.Discrete(G * G)
        self._n_actions = G * G
        self._centre = self.action_of((0, 0))
        obs_spaces = {
            "occupancy": spaces.Box(0.0, 1.0, (G * G,), np.float32),
            "action_mask": spaces.Box(0, 1, (G * G,), np.int8),
            "task": spaces.Box(-1.0, 1.0, (probe.task_size,), np.float32),
            "structure": spaces.Box(-1.0, 1.0, (probe.structure_size,), np.float32),
        }
        if self.lookahead:
            obs_spaces["candidates"] = spaces.Box(
                -1.0, 1.0, (G * G * CANDIDATE_FEATURES,), np.float32
            )
        self.observation_space = spaces.Dict(obs_spaces)
        self._initial_mask = np.zeros(G * G, dtype=np.int8)
        for dx, dy in _STEPS:
            self._initial_mask[self.action_of((dx, dy))] = 1
        self._cells: list[Cell] | None = None
        self._window = None  # pygame display of render_mode="human"
        self._clock = None

    # --- grid <-> actions -----------------------------------------------------------------
    def action_of(self, cell: Cell) -> int:
        """The action that docks a module at grid ``cell`` (x, y); ValueError off the grid."""
        x, y = int(cell[0]), int(cell[1])
        if max(abs(x), abs(y)) > self.radius:
            raise ValueError(f"cell {cell} lies outside the grid [-{self.radius}, {self.radius}]^2")
        return (y + self.radius) * self.side + (x + self.radius)

    def cell_of(self, action: int) -> Cell:
        """The grid cell (x, y) of ``action``."""
        y, x = divmod(int(action), self.side)
        return (x - self.radius, y - self.radius)

    def _parse_action(self, action: Any) -> int | None:
        """The integer action in [0, G * G), or None for anything else (an invalid action; see
        Action Space): never raises."""
        n = self._n_actions
        if type(action) is int or isinstance(action, np.integer):  # the fast, common case
            return int(action) if 0 <= action < n else None
        if isinstance(action, (bool, np.bool_)):
            return None
        try:
            arr = np.asarray(action)
            if arr.size != 1 or arr.dtype.kind not in "iuf":
                return None
            value = arr.reshape(-1)[0]
            if arr.dtype.kind == "f" and not (np.isfinite(value) and value == np.floor(value)):
                return None
            a = int(value)
        except Exception:  # whatever it is, it is not an action
            return None
        return a if 0 <= a < n else None

    # --- state ----------------------------------------------------------------------------
    def _backend(self, f_max: float) -> _Backend:
        b = self._backends.get(f_max)
        if b is None:
            b = _Backend(self.module, self.n_max, f_max, self.n_directions, self.oracle_method)
            self._backends[f_max] = b
        return b

    def _memo_for(self, task: Any, f_max: float) -> tuple[dict, dict]:
        """Per-task memos: evaluations (key -> (n_satisfied, structure vector)) and candidate
        rows (child key -> row): a task that comes back (fixed task lists, files) costs no
        oracle call for structures seen before."""
        ident = (id(task), f_max)
        entry = self._memos.get(ident)
        if entry is None or entry[0] is not task:
            if len(self._memos) >= _MEMO_TASKS:
                self._memos.clear()
            entry = self._memos[ident] = (task, {}, {})
        for memo in entry[1:]:
            if len(memo) >= _CACHE_SIZE:
                memo.clear()
        return entry[1], entry[2]

    @property
    def structure(self) -> Structure:
        """The current structure (cells in docking order, initial module first)."""
        if self._cells is None:
            raise ResetNeeded("call reset() before asking for the structure")
        return Structure(self._cells, module=self.module)

    @property
    def task(self) -> Any:
        """The current task (a TaskRequirement)."""
        if self._cells is None:
            raise ResetNeeded("call reset() before asking for the task")
        return self._task

    def action_masks(self) -> np.ndarray:
        """bool (G * G,): the valid actions now; before ``reset``, those of the initial state."""
        if self._cells is None:
            return self._initial_mask.astype(bool)
        return self._mask.astype(bool)

    def _evaluate(self) -> None:
        """Decide every task wrench for the current structure; update fraction and features."""
        b = self._be
        self._evaluated += 1
        key = normalise(self._cells)
        hit = self._memo.get(key)
        if hit is None:
            cap = b.capability.get(key) or b.capability_of(key)
            per_wrench = np.maximum.reduce(self._WD - cap.h_Wn, axis=1)
            # a wrench beyond the exact support of W in a feature direction (by more than the
            # oracle's tolerance) is certainly infeasible; only the others are tested
            open_ = per_wrench <= cap.slack
            n_open = np.count_nonzero(open_)
            n_sat = 0
            if n_open:
                W = self._W if n_open == len(open_) else self._W[open_]
                n_sat = b.count_feasible(cap, key, W)
            vec = b.features.structure_against(
                cap.head, cap.h_Wn, self._h_Tn, per_wrench, n_sat / len(self._W)
            )
            hit = self._memo[key] = (n_sat, vec)
        n_sat, self._structure_vec = hit
        self._frac = n_sat / len(self._W)
        self._success = n_sat == len(self._W)

    def _update_candidates(self) -> None:
        """Fill the candidate rows of the valid actions (the others stay zero); call after the
        mask is final. Support functions only: no oracle call, nothing counted as evaluated."""
        self._cand[:] = 0.0
        valid = np.flatnonzero(self._mask)
        if len(valid) == 0:
            return
        memo = self._cand_memo
        keys = [normalise([*self._cells, self.cell_of(a)]) for a in valid]
        missing = [k for k in dict.fromkeys(keys) if k not in memo]
        if missing:
            h, slack = self._be.supports_of(missing)
            rows = self._be.features.candidates(h, slack, self._h_Tn, self._WD)
            memo.update(zip(missing, rows))
        self._cand[valid] = [memo[k] for k in keys]

    def _observation(self) -> dict[str, np.ndarray]:
        obs = {
            "occupancy": self._occ.copy(),
            "action_mask": self._mask.copy(),
            "task": self._task_vec.copy(),
            "structure": self._structure_vec.copy(),
        }
        if self.lookahead:
            obs["candidates"] = self._cand.reshape(-1).copy()
        return obs

    def _info(self, invalid: bool = False, terms: dict[str, float] | None = None) -> dict:
        return {
            "n_modules": len(self._cells),
            "satisfied_fraction": self._frac,
            "success": self._success,
            "is_success": self._success,
            "cells": [[x, y] for x, y in self._cells],
            "evaluated": self._evaluated,
            "oracle_calls": self._be.tests - self._calls0,
            "action_mask": self._mask.astype(bool),
            "task_name": self._task_name,
            "n_wrenches": len(self._W),
            "invalid_action": invalid,
            "reward_terms": terms if terms is not None else self.weights.terms(0, 0, 0, 0),
        }

    # --- Gymnasium API --------------------------------------------------------------------
    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[dict[str, np.ndarray], dict]:
        super().reset(seed=seed)
        options = options or {}
        unknown = sorted(set(options) - {"task"})
        if unknown:
            raise ValueError(f"unknown reset options {unknown}; known: ['task']")
        if options.get("task") is not None:
            task = _as_task(options["task"], "options['task']")
        else:
            task = self.generator(self.np_random)
            if not isinstance(task, TaskRequirement):
                name = str(getattr(self.generator, "name", type(self.generator).__name__))
                task = _as_task(task, f"task generator {name!r} returned a bad task", name)
        W = np.asarray(task.wrenches, dtype=float)
        if W.ndim != 2 or W.shape[1] != 6 or len(W) == 0:
            raise ValueError(
                f"task {task.name!r} wrenches must have shape (t >= 1, 6), got {W.shape}"
            )
        if getattr(task, "kind", "total") != "total" and type(self) is ModQuadAssemblyEnv:
            raise ValueError(
                f"task {task.name!r} is of kind {task.kind!r}: make the env with modules=[...] "
                "(e.g. modules=[module]), which decides self-weight"
            )
        f_max = self.f_max if self.f_max is not None else check_f_max(task.f_max)
        self._be = self._backend(f_max)
        self._memo, self._cand_memo = self._memo_for(task, f_max)
        self._task, self._task_name, self._W = task, str(task.name), W
        self._task_vec, self._h_Tn, self._WD = self._be.features.task(W)

        G = self.side
        self._cells = [(0, 0)]
        self._occ = np.zeros(G * G, dtype=np.float32)
        self._occ[self._centre] = 1.0
        self._mask = self._initial_mask.copy()
        self._steps = 0
        self._evaluated = 0
        self._calls0 = self._be.tests
        self._evaluate()
        self._frac0 = self._frac
        self._done = False
        if self._success:  # one module suffices: nothing may be added (see Episode End)
            self._mask[:] = 0
        if self.lookahead:
            self._cand = np.zeros((G * G, CANDIDATE_FEATURES), dtype=np.float32)
            self._update_candidates()
        return self._observation(), self._info()

    def step(self, action: Any) -> tuple[dict[str, np.ndarray], float, bool, bool, dict]:
        if self._cells is None:
            raise ResetNeeded("call reset() before step()")
        if self._done:
            raise ResetNeeded("the episode is over; call reset() before step()")
        a = self._parse_action(action)
        self._steps += 1
        added = invalid = False
        frac_before = self._frac
        if self._success:  # solved at reset: this step (any action) only ends the episode
            terminated = True
        elif a is not None and self._mask[a]:
            added = True
            x, y = self.cell_of(a)
            self._cells.append((x, y))
            self._occ[a] = 1.0
            self._mask[a] = 0
            for dx, dy in _STEPS:
                nx, ny = x + dx, y + dy
                if max(abs(nx), abs(ny)) <= self.radius:
                    b = (ny + self.radius) * self.side + nx + self.radius
                    if not self._occ[b]:
                        self._mask[b] = 1
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

    def render(self) -> np.ndarray | str | None:
        if self.render_mode is None:
            gym.logger.warn("render() called with render_mode=None; pass render_mode to the env")
            return None
        if self._cells is None:
            raise ResetNeeded("call reset() before render()")
        if self.render_mode == "ansi":
            return self._ansi()
        frame = self._frame()
        if self.render_mode == "rgb_array":
            return frame
        self._show(frame)
        return None

    def _frame(self) -> np.ndarray:
        """The structure picture with each wrench's status, (H, W, 3) uint8."""
        from ..oracle import feasible
        from ..viz import structure_image

        s = self.structure
        status = feasible(
            s.configuration_matrix(), self._W, self._be.oracle.f_max, self.oracle_method
        )
        return structure_image(s, size=self.render_size, wrench_status=status)

    def _show(self, frame: np.ndarray) -> None:
        """Draw ``frame`` in a pygame window (``render_mode="human"``, the viz extra)."""
        pygame = import_optional("pygame")
        if self._window is None:
            pygame.init()
            pygame.display.set_caption("ModQuadAssembly")
            self._window = pygame.display.set_mode(frame.shape[1::-1])
            self._clock = pygame.time.Clock()
        pygame.event.pump()
        self._window.blit(pygame.surfarray.make_surface(frame.swapaxes(0, 1)), (0, 0))
        pygame.display.flip()
        self._clock.tick(self.metadata["render_fps"])

    def close(self) -> None:
        if self._window is not None:
            import pygame

            pygame.display.quit()
            pygame.quit()
            self._window = None
        super().close()

    def _ansi(self) -> str:
        rows = [
            f"task {self._task_name!r} (t={len(self._W)}): {len(self._cells)}/{self.n_max} modules,"
            f" satisfied {self._frac:.3f}{' SUCCESS' if self._success else ''}"
        ]
        for y in range(self.radius, -self.radius - 1, -1):
            row = []
            for x in range(-self.radius, self.radius + 1):
                if (x, y) == (0, 0):
                    row.append("@")
                elif self._occ[self.action_of((x, y))]:
                    row.append("#")
                elif self._mask[self.action_of((x, y))]:
                    row.append("+")
                else:
                    row.append(".")
            rows.append(" ".join(row))
        return "\n".join(rows) + "\n"


def _as_task(task: Any, what: str, name: str = "options-task") -> TaskRequirement:
    """A TaskRequirement from a TaskRequirement or a (t, 6) wrench array (named ``name``); for
    anything else a ValueError whose message starts with ``what``."""
    if isinstance(task, TaskRequirement):
        return task
    try:
        arr = np.asarray(task, dtype=float)
    except (TypeError, ValueError):
        arr = None
    if arr is None or arr.ndim != 2 or arr.shape[1] != 6:
        got = type(task).__name__ if arr is None or arr.ndim == 0 else f"shape {arr.shape}"
        raise ValueError(
            f"{what}: expected a TaskRequirement or a (t, 6) wrench array, got {got}"
        ) from None
    try:
        return TaskRequirement(arr, name=name)
    except ValueError as exc:
        raise ValueError(f"{what}: not a valid task: {exc}") from None
