"""The Gymnasium environment ``ModQuadAssembly-v0``: build a structure module by module. Split as
in Jumanji: the Gymnasium API, thin over the pure :mod:`.transitions` of an immutable
:class:`~.types.AssemblyState`, with its parts passed in (task generator, module set, reward,
viewer; observation blocks of :mod:`.features`, decisions of :mod:`.evaluator`)."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium import spaces
from gymnasium.error import ResetNeeded

from modquad_gym.core.validation import check_int
from modquad_gym.envs.assembly.evaluator import StructureEvaluator, TaskMemos
from modquad_gym.envs.assembly.faces import Faces
from modquad_gym.envs.assembly.features import (
    DEFAULT_N_DIRECTIONS,
    MAX_N_DIRECTIONS,
    AssemblyFeatures,
    ObservationBlock,
)
from modquad_gym.envs.assembly.grid import Grid
from modquad_gym.envs.assembly.inputs import (
    check_env_f_max,
    check_oracle_method,
    check_render_mode,
    check_render_size,
    draw_task,
    make_encoding,
    make_rules,
    make_viewer,
    one_task,
    parse_action,
    reset_options,
    task_source,
)
from modquad_gym.envs.assembly.modules import make_module_set
from modquad_gym.envs.assembly.restore import Restorer
from modquad_gym.envs.assembly.reward import RewardFn, make_reward, reset_terms, step_reward
from modquad_gym.envs.assembly.spec import DEFAULT_N_MAX, ArgumentSpec
from modquad_gym.envs.assembly.transitions import initial_state, satisfied, transition
from modquad_gym.envs.assembly.types import AssemblyState, Episode
from modquad_gym.envs.assembly.viewer import RENDER_FPS, AssemblyViewer
from modquad_gym.geometry.module import ModuleType
from modquad_gym.geometry.structure import Cell, Structure
from modquad_gym.oracle.faults import check_fault, check_fault_margin
from modquad_gym.tasks.planted_meta import fault_meta
from modquad_gym.tasks.reserved import warn_reserved

N_MAX_LIMIT = 128  # the searches' limit (grid encoding: 255^2 actions; faces: 258)
DEFAULT_TASKS = "mixed"  # the default task source
MAX_STEPS_LIMIT = 4 * N_MAX_LIMIT  # the largest max_steps
ENCODINGS = {"grid": Grid, "faces": Faces}  # the action encodings (:mod:`.grid`, .faces)


class ModQuadAssemblyEnv(ArgumentSpec, gym.Env[dict[str, np.ndarray], np.int64]):
    """Assemble the smallest modular multirotor (H-ModQuad) that can exert a task's wrenches.

    ## Description
    A task is a set of t wrenches w = [f; tau] (body frame, SI units; f_max per rotor) that the
    robot must be able to produce. The agent starts from one module and docks one more per step
    on a square grid. A structure satisfies a wrench when it lies in its feasible-wrench zonotope
    W = {A u : 0 <= u <= f_max}, decided exactly by :class:`~modquad_gym.oracle.WrenchOracle`.
    The goal is to satisfy every wrench with as few modules as possible (paper Problem 1).

    Make it with ``gym.make("modquad_gym:ModQuadAssembly-v0", **kwargs)`` (the prefix imports
    ``modquad_gym``, which registers the ids) or ``gym.make("ModQuadAssembly-v0")`` after it.

    ## Action Space
    ``Discrete(G * G)`` with G = 2 * n_max - 1: one action per grid cell (x, y), with x and y in
    [-(n_max - 1), n_max - 1] around the initial module at (0, 0):
    ``a = (y + n_max - 1) * G + (x + n_max - 1)``. Action a is *valid* when its cell is empty and
    4-adjacent to the structure; a valid action docks a module there. The mask of valid actions
    is exposed three ways: ``action_masks()`` (bool, also before ``reset``, for sb3-contrib's
    MaskablePPO), ``obs["action_mask"]`` and ``info["action_mask"]``. The mask is never all
    zero, so masked sampling always has a choice: in a terminal state it still marks the cells
    where a module could dock (no step follows a terminal state; a vector env's autoreset step
    ignores the action it is given), and in the rare task that one module already satisfies it
    marks the four neighbours of the start (any action then ends the episode, see below).

    With ``actions="faces"`` (``ModQuadAssemblyScale-v0``) the actions are the structure's free
    faces instead, in the grid's row-major order: ``Discrete(2 n_max + 2)`` (times K types),
    valid exactly for the current faces, and the observation is ``"action_mask"``,
    ``"candidates"`` (one row of features per action), ``"task"`` and ``"structure"``; see
    :mod:`~modquad_gym.envs.assembly.faces`. Both encodings make the same episodes (the same
    structures, rewards and infos) for the same dockings.

    Every other action is *invalid*, and an invalid action never raises: it leaves the
    structure unchanged and costs ``w_invalid`` (``invalid_action="penalise"``) or also ends the
    episode (``"terminate"``), with ``info["invalid_action"]`` True. Invalid are an empty cell
    that is not adjacent, an occupied cell, and anything that is not an integer in
    ``[0, G * G)``: -1, G * G, 2.5, nan, True, None, "3", [1, 2], ... A one-element integer
    array or a whole-number float (3.0, ``np.array([3.0])``) counts as that integer.

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
    * ``"candidates"`` (G * G * k,) in [-1, 1], only with ``lookahead`` on: row a
      (``candidates.reshape(G * G, k)[a]``) describes the child that action a would build (zero
      for invalid actions, never all zero for valid ones): with True (k = 5) from its support
      function alone (no oracle call); with ``"exact"`` (k = 8) also its exact satisfied share,
      clipped mean margin and greedy's choice (:mod:`.lookahead`; counted in ``oracle_calls``).

    K = ``n_directions`` (default 48); :mod:`.features` documents every entry and its scale.

    ## Rewards
    ``r_t = w_sat * (frac_t - frac_{t-1}) - w_module * added_t + w_success * success_t
    - w_invalid * invalid_t``, with frac the fraction of satisfied wrenches. An episode's return
    is therefore ``w_sat * (frac_T - frac_0) - w_module * (n_T - 1) + w_success * success
    - w_invalid * n_invalid``: for a successful episode, fewer modules always earn more
    (w_module > 0), and success beats failure when w_success > w_module * (n_max - 1). Defaults:
    w_sat = 1, w_module = 0.1, w_success = 1, w_invalid = 0.1; ``info["reward_terms"]`` has the
    terms. ``env.spec.reward_threshold``: the return every success without invalid actions
    reaches (0.4 at n_max 7; :func:`~.reward.success_threshold`).

    ## Starting State
    One module at cell (0, 0) and a task drawn from the task source with ``self.np_random``
    (seeded by ``reset(seed=...)``), or the task given as ``reset(options={"task": task})``
    (a TaskRequirement, a DynamicTask, a (t, 6) wrench array, a file or ``"example:NAME"``).

    ## Episode End
    * Termination (success): every task wrench is satisfied. If one module already satisfies the
      task at reset, ``info["success"]`` is True there and the next step (any action, none
      counted invalid) ends the episode with the success bonus and no module added.
    * Termination (failure): n_max modules without success, no valid action left, or an invalid
      action with ``invalid_action="terminate"``.
    * Truncation: the env itself truncates (``truncated`` True, ``terminated`` False) the step
      that reaches ``max_steps`` steps (default 4 * n_max) without termination: only invalid
      actions get there (valid ones terminate within n_max - 1 steps). No id registers a
      ``TimeLimit`` (``env.spec.max_episode_steps`` is None): the limit follows ``gym.make(id,
      n_max=N)``; one from ``max_episode_steps=`` can only shorten episodes (:mod:`.spec`).

    ## Arguments
    * ``tasks``: task source: ``"paper"``, ``"planted"``, ``"screwdriver"``, ``"mixed"`` (default),
      a task file path, a shipped example (``"example:screwdriver"``), a TaskRequirement, a
      DynamicTask (a motion: each structure decided on its own rotor wrenches, :mod:`.dynamic`), a
      list of them, or a generator: any callable ``gen(rng) -> TaskRequirement`` (or DynamicTask, or
      (t, 6) wrench array), called with ``self.np_random`` at each reset (another result:
      ValueError); see :func:`modquad_gym.tasks.make_generator`. A named source plants its tasks in
      at most n_max modules (``ModQuadAssemblyScale-v0`` at n_max=20: 16-20): one exists, intact.
    * ``task``: one task instead of ``tasks`` (a task file, ``"example:NAME"``, a
      TaskRequirement or a DynamicTask); a family of tasks or a suite is refused with a
      ValueError that names ``tasks=``.
    * ``n_max``: the largest number of modules (default 7, as in the paper), 2 to 128.
    * ``module``: the ``ModuleType`` of every module (default the T-module, eta = pi/4).
    * ``modules``: several module types (stock names ``"t45,t45m,flat"`` or ModuleType objects)
      or a module set (:class:`~.modules.Palette`, :class:`~.modules.OneType`): each action then
      docks a module *of a type*, type-major (``a = k * G * G + c`` on the grid;
      ``action_of(cell, k)``, ``type_of(a)``); the observation adds ``"types"`` (type-major
      one-hot, K > 1 types), tasks of kind ``external`` are decided with the structure's weight
      and ``info`` adds ``modules`` and ``mass_kg`` (see :mod:`.modules`). Default: one type.
    * ``initial_type``: with a palette, the first module's type index (default 0) or
      ``"random"`` (drawn at each reset); ``reset(options={"initial_type": ...})`` for one episode.
    * ``f_max``: maximum thrust per rotor, 1e-9 to 1e12; None (default) uses each task's own.
    * ``reward_weights``: a :class:`~.reward.RewardWeights` or a dict of some of ``w_sat``,
      ``w_module``, ``w_success``, ``w_invalid`` (the default reward).
    * ``reward``: any :class:`~.reward.RewardFn` (default :class:`~.reward.WeightedReward`).
    * ``viewer``: an :class:`~.viewer.AssemblyViewer` whose grid holds the env's (default one).
    * ``invalid_action``: ``"penalise"`` (default) or ``"terminate"``.
    * ``max_steps``: the step limit for truncation (default 4 * n_max; n_max - 1 to 512 = 4 * 128).
    * ``render_mode``: None, ``"rgb_array"`` (the structure picture, (H, W, 3) uint8; its strip
      shows each task wrench satisfied or not, as the env decides), ``"human"`` (that picture in
      a pygame window at each ``reset`` and ``step``; the ``viz`` extra) or ``"ansi"`` (a text
      grid). ``gymnasium.wrappers.RecordVideo`` works on ``"rgb_array"`` (needs moviepy).
    * ``actions``: the action encoding, ``"grid"`` (default) or ``"faces"`` (above).
    * ``n_directions``: K, the support directions of the features (default 48, 12..4096).
    * ``oracle_method``: the oracle's method (default ``"auto"``, exact and certified).
    * ``fault``: None (default), ``"rotor"``, ``"module"``, ``"rotor2"`` or ``"rotor+module"``:
      a wrench counts only if it survives ANY such failure (a planted answer: ``intact_*`` keys).
    * ``fault_margin``: with ``fault``, the worst margin a wrench must keep after the failure
      (default 0; :func:`~modquad_gym.oracle.faults.fault_margin`), in [0, 1).
    * ``render_size``: (height, width) of ``rgb_array`` frames, 16..4096 each, default (256, 256).
    * ``lookahead``: add the ``"candidates"`` observation (default False): True (support rows)
      or ``"exact"`` (the exact one-step lookahead too; slower: every child is decided).
      ``lookahead_top_k=k`` with ``"exact"``: the k best actions by support bounds stay valid.

    ``info`` carries ``n_modules``, ``satisfied_fraction``, ``success`` (and the same as
    ``is_success``, which SB3's ``Monitor``/``EvalCallback`` and RL Zoo read), ``cells`` (list of
    [x, y], initial module first), ``evaluated`` (structures the oracle evaluated this episode:
    the initial one plus one per docking), ``oracle_calls`` (wrench tests this episode),
    ``action_mask``, ``task_name``, ``n_wrenches``, ``invalid_action`` and ``reward_terms``.
    No answer in ``info`` (``task_name`` names the generator); ``task.meta`` is for benchmarks.

    Changes between versions are listed in the repository's ``CHANGELOG.md``.
    """

    metadata = {"render_modes": ["human", "rgb_array", "ansi"], "render_fps": RENDER_FPS}

    def __init__(
        self,
        # the task source
        tasks: Any = DEFAULT_TASKS,
        task: Any = None,
        f_max: float | None = None,
        # the module set
        module: ModuleType | None = None,
        modules: Any = None,
        initial_type: Any = None,
        # the episode rules
        n_max: int = DEFAULT_N_MAX,
        max_steps: int | None = None,
        invalid_action: str = "penalise",
        # the actions, the observation and the decisions
        actions: str = "grid",
        n_directions: int = DEFAULT_N_DIRECTIONS,
        lookahead: bool | str = False,
        lookahead_top_k: int | None = None,
        oracle_method: str = "auto",
        fault: str | None = None,
        fault_margin: float = 0.0,
        # the reward
        reward_weights: Any = None,
        reward: RewardFn | None = None,
        # the pictures
        render_mode: str | None = None,
        render_size: tuple[int, int] = (256, 256),
        viewer: AssemblyViewer | None = None,
    ) -> None:
        tasks = one_task(task, tasks, DEFAULT_TASKS)
        self.module_set = make_module_set(module, modules, initial_type)
        self.rules = make_rules(n_max, max_steps, invalid_action, lookahead, N_MAX_LIMIT,
                                lookahead_top_k)  # fmt: skip
        self.encoding: Grid | Faces = make_encoding(actions, ENCODINGS)(self.n_max, self.n_types)
        check_render_mode(render_mode, self.metadata)
        self.f_max = None if f_max is None else check_env_f_max(f_max)
        self.task_source = tasks
        self.generator: Callable[[np.random.Generator], Any] = task_source(tasks, self.n_max)
        self.n_directions = check_int(n_directions, "n_directions", 12, MAX_N_DIRECTIONS)
        self.oracle_method = check_oracle_method(oracle_method)
        self.fault = None if fault is None else check_fault(fault)
        self.fault_margin = check_fault_margin(fault_margin, self.fault)
        self.reward: RewardFn = make_reward(reward, reward_weights)
        self.render_mode = render_mode
        radius = self.n_max if self.actions == "faces" else self.n_max - 1  # faces reach n_max
        size = check_render_size(render_size)
        self.viewer = make_viewer(viewer, radius, self.n_max, size, self.palette)

        self.evaluators: dict[float, StructureEvaluator] = {}  # per f_max, across episodes
        self._memos = TaskMemos()
        probe = self._evaluator(1.0 if self.f_max is None else self.f_max).features
        self._blocks = self.make_blocks(probe)
        self.action_space = spaces.Discrete(self.encoding.n_actions)
        self.observation_space = spaces.Dict({b.name: b.space() for b in self._blocks})
        self._readers = [(b.name, b.value) for b in self._blocks]
        self._state: AssemblyState | None = None
        self._episode: Episode | None = None
        self._restorer = Restorer()  # the states handed out

    def make_blocks(self, features: AssemblyFeatures) -> list[ObservationBlock]:
        """The observation's blocks, in order; override to add a feature (append an
        :class:`~.features.ObservationBlock`): the spaces follow from the blocks."""
        return self.encoding.blocks(features, self.n_types, self.lookahead)

    # --- the parts' settings, by name -----------------------------------------------------
    n_max = property(lambda self: self.rules.n_max, doc="The largest number of modules.")
    max_steps = property(lambda self: self.rules.max_steps, doc="The step limit.")
    invalid_action = property(lambda self: self.rules.invalid_action, doc="Its mode.")
    lookahead = property(lambda self: self.rules.lookahead, doc="False, True or 'exact'.")
    module = property(lambda self: self.module_set.module, doc="The (first) module type.")
    palette = property(lambda self: self.module_set.palette, doc="The types, or None (one).")
    n_types = property(lambda self: self.module_set.n_types, doc="The number of types.")
    radius = property(lambda self: self.n_max - 1, doc="n_max - 1, the largest |x|, |y|.")
    side = property(lambda self: 2 * self.n_max - 1, doc="G = 2 n_max - 1, cells a side.")
    actions = property(lambda self: self.encoding.name, doc="The action encoding's name.")
    render_size = property(lambda self: self.viewer.size, doc="(height, width) of frames.")
    weights = property(lambda self: getattr(self.reward, "weights", None), doc="Reward weights.")
    initial_type = property(lambda self: getattr(self.module_set, "initial_type", None))

    # --- cells <-> actions --------------------------------------------------------------
    @property
    def grid(self) -> Grid:
        """The grid encoding (``actions="grid"``): cells <-> actions in every state."""
        if not isinstance(self.encoding, Grid):
            raise AttributeError("faces encoding: use env.action_of, env.cell_of, env.type_of")
        return self.encoding

    def action_of(self, cell: Cell, type_index: int = 0) -> int:
        """The action that docks a module (of palette type ``type_index``) at ``cell`` (x, y);
        ValueError off the grid (faces: where ``cell`` is not a free face now)."""
        return self.encoding.state_action_of(self._state, cell, type_index)

    def cell_of(self, action: int) -> Cell:
        """The cell (x, y) where ``action`` docks (faces: in the current state)."""
        return self.encoding.state_cell_of(self._state, action)

    def type_of(self, action: int) -> int:
        """The palette index of the type that ``action`` docks (0 for one type)."""
        return self.encoding.type_of(action)

    # --- state ----------------------------------------------------------------------------
    def _evaluator(self, f_max: float) -> StructureEvaluator:
        """The evaluator of ``f_max`` (kept across episodes: its caches make steps fast)."""
        if f_max not in self.evaluators:
            ev = self.module_set.evaluator(self.n_max, f_max, self.n_directions, self.oracle_method)
            ev.fault, ev.fault_margin = self.fault, self.fault_margin
            self.evaluators[f_max] = ev
        return self.evaluators[f_max]

    def _require(self, what: str) -> AssemblyState:
        if self._state is None:
            raise ResetNeeded(f"call reset() before {what}")
        return self._state

    state = property(lambda self: self._restorer.issue(self._require("asking for the state")),
                     doc="The episode's current :class:`~.types.AssemblyState`.")  # fmt: skip
    evaluator = property(lambda self: None if self._episode is None else self._episode.evaluator,
                         doc="The episode's evaluator (None before ``reset``).")  # fmt: skip

    def restore(self, state: AssemblyState) -> dict[str, np.ndarray]:
        """Continue the episode from ``state`` (one ``env.state`` returned: planners branch from
        it) and return its observation; a state its dockings do not give: ValueError (.restore)."""
        self._restorer.check(self._episode, self._require("restore()"), state)
        self._state = state
        return self._observation()

    @property
    def structure(self) -> Structure:
        """The current structure (cells in docking order, initial module first, with types)."""
        s = self._require("asking for the structure")
        return self.module_set.structure(s.cells, s.types)

    @property
    def task(self) -> Any:
        """The current task (a TaskRequirement or a DynamicTask)."""
        return self._require("asking for the task").task.requirement

    def action_masks(self) -> np.ndarray:
        """bool: the valid actions now; before ``reset``, those of the initial state."""
        mask = self.encoding.initial_mask if self._state is None else self._state.mask
        return mask.astype(bool)

    def _observation(self) -> dict[str, np.ndarray]:
        return {name: read(self._state) for name, read in self._readers}

    def _info(self, invalid: bool = False, terms: dict[str, float] | None = None) -> dict:
        terms = reset_terms(self.reward, self._state) if terms is None else terms
        return {**self._state.info(invalid, terms), **self.module_set.info(self._state.types)}

    # --- Gymnasium API --------------------------------------------------------------------
    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[dict[str, np.ndarray], dict]:
        """Gymnasium's reset. Bad ``options`` raise ValueError before the env reseeds, leaving it
        as it was; a task source that fails to draw ends the episode (``step`` asks for reset)."""
        options = reset_options(options, self.module_set, self.f_max)  # with its task checked
        warn_reserved(self, seed)  # a validation or held-out seed: once per env (tasks.reserved)
        super().reset(seed=seed)
        self._state = self._episode = None
        types = self.module_set.start(options, self.np_random)  # before the task (the seed)
        if (task := options["task"]) is None:  # a given task, else one drawn
            task = draw_task(self.generator, self.np_random, self.module_set)
        f_max = self.f_max if self.f_max is not None else check_env_f_max(task.f_max)
        evaluator = self._evaluator(f_max)
        memos = self._memos.of(task, f_max)  # by the source's task: its memos outlive the copy
        task = fault_meta(task, self.fault)  # with a fault, the planted count bounds nothing
        self._episode = Episode(self.rules, self.encoding, self.module_set, evaluator, *memos)
        arrays = evaluator.task_arrays(task, self.module_set.key(((0, 0),), types))
        self._state = initial_state(self._episode, arrays, types)
        if self.render_mode == "human":  # Gymnasium's convention: human mode draws itself
            self.render()
        return self._observation(), self._info()

    def step(self, action: Any) -> tuple[dict[str, np.ndarray], float, bool, bool, dict]:
        state = self._require("step()")
        if state.done:
            raise ResetNeeded("the episode is over; call reset() before step()")
        a = parse_action(action, self.encoding.n_actions)
        valid = state.success or (a is not None and bool(state.mask[a]))
        self._state = nxt = transition(self._episode, state, a, valid)
        reward, terms = step_reward(self.reward, state, a, nxt, valid)
        info = self._info(not valid, terms)
        if self.render_mode == "human":
            self.render()
        return self._observation(), reward, nxt.terminated, nxt.truncated, info

    def render(self) -> np.ndarray | str | None:
        if self.render_mode is None:
            gym.logger.warn("render() called with render_mode=None; pass render_mode to the env")
            return None
        state = self._require("render()")
        status = None if self.render_mode == "ansi" else satisfied(self._episode, state)
        valid = self.encoding.valid_cells(state)
        return self.viewer.render(self.render_mode, state, self.structure, status, valid)

    def close(self) -> None:
        self.viewer.close()
        super().close()
