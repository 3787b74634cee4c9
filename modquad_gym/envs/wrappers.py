"""Wrappers for algorithms that cannot use action masks (SB3's PPO, A2C and DQN, the RL Zoo).

The environments mask their actions: most of the grid is not a valid docking at any step, and
an invalid action only costs a penalty. MaskablePPO (sb3-contrib) reads the mask; other
algorithms spend their episodes on invalid actions and learn nothing.
:class:`NearestValidAction` makes every action valid instead, so that any algorithm for a
``Discrete`` action space learns the design problem:

    env = NearestValidAction(gym.make("ModQuadAssembly-v0"))

It records its construction (``gymnasium.utils.RecordConstructorArgs``), so ``env.spec`` names
it and ``gym.make(env.spec)`` rebuilds the wrapped environment, and ``check_env`` runs on it.

In the RL Zoo, name it in the hyperparameter file (:data:`RL_ZOO_CONFIG`, shipped with the
package)::

    env_wrapper:
      - modquad_gym.envs.wrappers.NearestValidAction
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np

from modquad_gym.envs.assembly.inputs import parse_action

__all__ = ["RL_ZOO_CONFIG", "NearestValidAction"]

RL_ZOO_CONFIG = Path(__file__).resolve().parents[1] / "data" / "rl_zoo" / "ppo.yml"
"""The RL Baselines3 Zoo hyperparameter file for ``ModQuadAssembly-v0`` with plain PPO through
:class:`NearestValidAction`, installed with the package: ``python -m rl_zoo3.train --algo ppo
--env ModQuadAssembly-v0 --gym-packages modquad_gym --conf-file "$(python -c 'from
modquad_gym.envs.wrappers import RL_ZOO_CONFIG; print(RL_ZOO_CONFIG)')"``."""


class NearestValidAction(gym.Wrapper, gym.utils.RecordConstructorArgs):
    """Replace an action that cannot dock by the valid action whose grid cell is nearest to its
    cell (Euclidean distance on the grid; a module of the same type first, in the several-type
    environment; ties to the lowest action index). A valid action is kept as it is, so a policy
    that has learned the mask loses nothing. Anything that is not an action of the space (a
    float, -1, ...) counts as the centre cell.

    Spaces are those of the wrapped environment (the observation keeps ``"action_mask"``).
    ``info["requested_action"]`` and ``info["applied_action"]`` say what was asked and done.
    The assembly env's mask is never all zero, so the applied action is always a valid one:
    where one module already satisfies the task, it is one of the start's neighbours and that
    step ends the episode (any action does); after the episode is over the env raises
    ``ResetNeeded``. Only an all-zero mask (no assembly env gives one) passes an action through.
    It wraps the grid encoding only (``actions="grid"``: a cell per action); another env, or
    ``actions="faces"`` (``ModQuadAssemblyScale-v0``), is a ValueError.
    """

    def __init__(self, env: gym.Env) -> None:
        gym.utils.RecordConstructorArgs.__init__(self)
        gym.Wrapper.__init__(self, env)
        actions = getattr(env.unwrapped, "actions", None)
        if actions != "grid":  # the faces encoding has no fixed cell per action
            raise ValueError(
                f"NearestValidAction needs an assembly env with actions='grid', got "
                f"actions={actions!r} ({env.unwrapped})"
            )
        grid = env.unwrapped.grid
        index = np.arange(grid.n_actions)
        y, x = np.divmod(index % grid.n_cells, grid.side)
        self._xy = np.stack([x, y], axis=1).astype(float)
        self._type = index // grid.n_cells
        self._centre = grid.centre
        self._far = 4.0 * grid.side**2  # more than any squared distance on the grid

    def valid_action(self, action: Any) -> int:
        """The action that :meth:`step` applies for ``action``."""
        mask = np.asarray(self.env.unwrapped.action_masks(), dtype=bool)
        a = parse_action(action, len(mask))
        if a is not None and mask[a]:
            return a
        valid = np.flatnonzero(mask)
        if a is None:
            a = self._centre
        if not len(valid):
            return a
        distance = ((self._xy[valid] - self._xy[a]) ** 2).sum(axis=1)
        distance += self._far * (self._type[valid] != self._type[a])
        return int(valid[np.argmin(distance)])

    def step(self, action: Any):
        applied = self.valid_action(action)
        obs, reward, terminated, truncated, info = self.env.step(applied)
        info["requested_action"], info["applied_action"] = action, applied
        return obs, reward, terminated, truncated, info
