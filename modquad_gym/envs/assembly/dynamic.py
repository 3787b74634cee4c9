"""Dynamic tasks in the assembly environment: each structure decided on its own rotor wrenches.

A :class:`~modquad_gym.dynamics.DynamicTask` (a motion, an optional payload and exerted
wrenches) asks the rotors of a structure S for ``task.rotor_wrenches(S)``, which depend on S's
mass and inertia. So the env keeps no episode-wide wrench set for it: every structure it meets
(the current one, and with ``lookahead=True`` each child) gets its own :class:`~.types.TaskArrays`
(kind ``"dynamic"``) made from its own wrenches, and is decided on those by the same exact,
screened oracle call as a static task (:meth:`~.evaluator.StructureEvaluator.evaluate`). The
state carries the current structure's arrays, so the ``"task"`` observation, ``info["n_wrenches"]``
(the trajectory's samples) and the rendered wrenches are those of the current structure.

Why not a cheaper bound: success must equal the oracle's decision on the structure's own wrenches
(:func:`modquad_gym.verified`); recomputing k x 6 wrenches and their projections per structure
costs little beside the oracle.
"""

from __future__ import annotations

from dataclasses import replace
from typing import Any

import numpy as np

from modquad_gym.dynamics import DynamicTask
from modquad_gym.envs.assembly.types import TaskArrays


def own_arrays(evaluator: Any, task: TaskArrays, key: Any) -> TaskArrays:
    """The arrays of the dynamic ``task`` for the structure ``key`` of ``evaluator``: its own
    rotor wrenches (mass and inertia) and their features."""
    structure = evaluator.structure_of(key)
    W = np.asarray(task.requirement.rotor_wrenches(structure), dtype=float)
    vec, h_Tn, WD = evaluator.features.task(W)
    return replace(task, W=W, vec=vec, h_Tn=h_Tn, WD=WD)


def start_arrays(evaluator: Any, task: DynamicTask, key: Any) -> TaskArrays:
    """The :class:`~.types.TaskArrays` an episode of the dynamic ``task`` starts with: the
    wrenches of its initial structure ``key``."""
    template = TaskArrays(task, str(task.name), np.zeros((0, 6)), None, None, None, task.kind,
                          per_structure=True)  # fmt: skip
    return own_arrays(evaluator, template, key)
