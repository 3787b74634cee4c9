"""The assembly environment as a package (after Jumanji's layout): :mod:`.env` the Gymnasium
API, :mod:`.transitions` the state transitions, :mod:`.grid` and :mod:`.faces` the two action
encodings (grid cells, or the structure's free faces) and their masks,
:mod:`.types` the episode state, :mod:`.reward` the reward functions, :mod:`.features` the
observation blocks, :mod:`.lookahead` the per-action candidate rows, :mod:`.evaluator` the exact
decisions (by :meth:`modquad_gym.oracle.WrenchOracle.screened`) and their caches,
:mod:`.viewer` the pictures, :mod:`.spec` the Gymnasium spec of the env's arguments,
:mod:`.inputs` the input cleaning, :mod:`.modules` the module set (one type or a palette),
:mod:`.dynamic` dynamic tasks (each structure's own wrenches).

Where to add: a reward term in :mod:`.reward` (:class:`WeightedReward.terms`), an observation
feature in :mod:`.features` (:func:`observation_blocks`), a module set's env behaviour in
:mod:`.modules`."""

from typing import TYPE_CHECKING

import lazy_loader

_NAMES = {
    "env": ["ENCODINGS", "MAX_STEPS_LIMIT", "N_MAX_LIMIT", "ModQuadAssemblyEnv"],
    "faces": ["FACE_FEATURES", "Faces"],
    "features": ["CANDIDATE_FEATURES", "AssemblyFeatures", "ObservationBlock", "unit_directions"],
    "inputs": ["INVALID_ACTION_MODES", "as_task"],  # as_task: the tasks layer's
    "modules": ["OneType", "Palette"],
    "reward": ["RewardFn", "RewardWeights", "WeightedReward", "episode_return"],
    "spec": ["DEFAULT_N_MAX", "ENTRY_POINT", "ArgumentSpec"],
    "types": ["AssemblyState", "Episode", "Rules", "TaskArrays"],
    "viewer": ["AssemblyViewer"],
}
"""The public names, by the module that defines them (loaded on first use: registering the
environments imports only :mod:`.reward` and :mod:`.spec`)."""

__getattr__, __dir__, _ = lazy_loader.attach(__name__, submod_attrs=_NAMES)

__all__ = [
    "ArgumentSpec",
    "AssemblyFeatures",
    "AssemblyState",
    "AssemblyViewer",
    "CANDIDATE_FEATURES",
    "DEFAULT_N_MAX",
    "ENCODINGS",
    "ENTRY_POINT",
    "Episode",
    "FACE_FEATURES",
    "Faces",
    "INVALID_ACTION_MODES",
    "MAX_STEPS_LIMIT",
    "ModQuadAssemblyEnv",
    "N_MAX_LIMIT",
    "ObservationBlock",
    "OneType",
    "Palette",
    "RewardFn",
    "RewardWeights",
    "Rules",
    "TaskArrays",
    "WeightedReward",
    "as_task",
    "episode_return",
    "unit_directions",
]

if TYPE_CHECKING:
    from modquad_gym.envs.assembly.env import (
        ENCODINGS,
        MAX_STEPS_LIMIT,
        N_MAX_LIMIT,
        ModQuadAssemblyEnv,
    )
    from modquad_gym.envs.assembly.faces import FACE_FEATURES, Faces
    from modquad_gym.envs.assembly.features import (
        CANDIDATE_FEATURES,
        AssemblyFeatures,
        ObservationBlock,
        unit_directions,
    )
    from modquad_gym.envs.assembly.inputs import INVALID_ACTION_MODES, as_task
    from modquad_gym.envs.assembly.modules import OneType, Palette
    from modquad_gym.envs.assembly.reward import (
        RewardFn,
        RewardWeights,
        WeightedReward,
        episode_return,
    )
    from modquad_gym.envs.assembly.spec import DEFAULT_N_MAX, ENTRY_POINT, ArgumentSpec
    from modquad_gym.envs.assembly.types import AssemblyState, Episode, Rules, TaskArrays
    from modquad_gym.envs.assembly.viewer import AssemblyViewer
