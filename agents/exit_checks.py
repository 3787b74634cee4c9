"""Checks of an expert-iteration run (:mod:`agents.expert_iteration`) before any work: the start
model acts at the labelling budget, and the replayed demonstrations fit in memory.

Each raises ValueError (a :class:`~modquad_gym.core.resources.ResourceError` for memory) naming
the option, which the command line prints as one line with exit code 2.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

REPLAY_N_MAX = 7
"""Largest structure of a replayed task (the current tier's n_max): its expert episode docks at
most ``REPLAY_N_MAX - 1`` modules, one labelled state each."""
MAX_REPLAY = 10**7
"""Most replayed tasks, as ``train.py --demo-tasks`` allows; memory bounds it first on most
machines (:func:`check_start`)."""


def check_start(model: Path, n_max: int, replay: int) -> None:
    """The start ``model`` acts in the labelling environment of ``n_max`` (a grid MLP trained
    at a smaller n_max does not), and ``replay`` tasks' demonstrations in that environment fit
    in memory (:func:`replay_bytes`)."""
    from modquad_gym.core.resources import check_memory
    from modquad_gym.policy.policy import Policy

    env = Policy(model, n_max=n_max).env
    try:
        check_memory(replay_bytes(env, replay),
                     f"--replay {replay} (its demonstrations at --n-max {n_max})")  # fmt: skip
    finally:
        env.close()


def replay_bytes(env: Any, n_tasks: int) -> int:
    """Bytes that ``n_tasks`` replayed tasks' states may hold in ``env`` (the labelling
    environment): at most ``REPLAY_N_MAX - 1`` states a task, each its observation arrays, its
    valid and good action masks (one byte an action) and its return (float32); twice, as each
    round merges them with its own states into new arrays while the old ones are held."""
    observation = sum(int(np.prod(s.shape)) * s.dtype.itemsize
                      for s in env.observation_space.spaces.values())  # fmt: skip
    state = observation + 2 * int(env.action_space.n) + 4
    return 2 * n_tasks * (REPLAY_N_MAX - 1) * state
