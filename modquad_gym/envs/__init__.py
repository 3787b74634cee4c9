"""Gymnasium environments of modquad_gym, registered by entry-point strings.

``import modquad_gym`` (or ``gym.make("modquad_gym:ModQuadAssembly-v0")``, which imports the
package first) registers these ids with Gymnasium: at once when Gymnasium is loaded, else as
soon as it is imported (so importing the package loads neither Gymnasium nor numpy):

* ``ModQuadAssembly-v0``: :class:`~modquad_gym.envs.assembly.env.ModQuadAssemblyEnv`, every keyword
  of its constructor accepted by ``gym.make``.
* ``ModQuadAssemblyPaper-v0``: the same with ``tasks="paper"`` (the paper's random tasks).
* ``ModQuadAssemblyPlanted-v0``: the same with ``tasks="planted"`` (tasks planted from a
  random structure, so a solution within n_max is known to exist; ``gym.make(id, n_max=N)``
  caps every id's planted sizes at N: :func:`~modquad_gym.tasks.make_generator`).
* ``ModQuadAssemblyMixed-v1``: the same with ``modules="t45,t45m,flat"``: three module types,
  (cell, type) actions (:class:`~modquad_gym.envs.assembly.modules.Palette`), and
  ``tasks="planted-mixed-external"``: the mixed tier's tasks (self-weight tasks planted in
  structures of mixed types, :class:`~modquad_gym.tasks.PlantedMixedTasks`).
* ``ModQuadAssemblyMixed-v0`` (superseded by -v1, kept so that its runs repeat): the palette
  with the default single-type tasks (``tasks="mixed"``).
* ``ModQuadAssemblyLarge-v0``: the same with ``n_max=12`` and ``tasks="planted-large"`` (tasks
  planted in 6-12 modules): the large benchmark tier (:mod:`modquad_gym.scoring.tiers`).
* ``ModQuadAssemblyDynamic-v0``: the same with ``tasks="motions"``: random dynamic tasks
  (:class:`~modquad_gym.dynamics.random_motions.MotionTasks`: motions, off-centre payloads,
  pushes through a tool), each structure decided on its own mass and inertia; the dynamic
  benchmark tier.
* ``ModQuadAssemblyFaultTolerant-v0``: the same with ``fault="rotor"`` and ``n_max=10``: success
  means the structure still exerts every task wrench after any single rotor failure (default
  tasks: a paper-like task's rotor-tolerant minimum is often the intact one, a planted task's
  more than its planted count). No tolerant structure is planted: with a fault, ``task.meta``
  names the planted answer ``intact_*`` (:mod:`~modquad_gym.tasks.planted_meta`).
* ``ModQuadAssemblyScale-v0``: designs at the field's sizes: ``n_max=64``, tasks planted in
  16-64 modules, and the free-faces action encoding (``actions="faces"``,
  :mod:`~modquad_gym.envs.assembly.faces`): one action per free face of the structure (at most
  130), each with a row of ``"candidates"`` features, for policies that score candidates at any
  size.

No id registers a ``max_episode_steps`` (Gymnasium's ``TimeLimit``): the env truncates itself at
its own ``max_steps`` (4 * n_max; ``env.unwrapped.max_steps``), so the limit follows
``gym.make(id, n_max=N)``, and ``env.spec.max_episode_steps`` stays None (so
``gym.make(env.spec, n_max=N)`` adds no ``TimeLimit`` either). ``gym.make(id,
max_episode_steps=M)`` adds Gymnasium's ``TimeLimit``, which can only shorten episodes (the env
still truncates at ``max_steps``; ``max_steps=M`` sets the env's own limit).
``reward_threshold`` is the least return of a successful episode without invalid actions
(:func:`~.assembly.reward.success_threshold`: 0.4 at n_max 7), where success beats every
failure (not at n_max 12 or 64: None there); ``env.spec`` gives the value for the arguments the
env was made with.
"""

from __future__ import annotations

import importlib.abc
import importlib.util
import sys
from typing import TYPE_CHECKING

import lazy_loader

from modquad_gym.envs.assembly.reward import RewardWeights, success_threshold
from modquad_gym.envs.assembly.spec import DEFAULT_N_MAX, ENTRY_POINT

ENV_IDS: dict[str, dict] = {
    "ModQuadAssembly-v0": {},
    "ModQuadAssemblyPaper-v0": {"tasks": "paper"},
    "ModQuadAssemblyPlanted-v0": {"tasks": "planted"},
    "ModQuadAssemblyMixed-v0": {"modules": "t45,t45m,flat"},
    "ModQuadAssemblyMixed-v1": {"modules": "t45,t45m,flat", "tasks": "planted-mixed-external"},
    "ModQuadAssemblyLarge-v0": {"tasks": "planted-large", "n_max": 12},
    "ModQuadAssemblyDynamic-v0": {"tasks": "motions"},
    "ModQuadAssemblyFaultTolerant-v0": {"fault": "rotor", "n_max": 10},
    "ModQuadAssemblyScale-v0": {"tasks": "planted-16-64", "n_max": 64, "actions": "faces"},
}


def register_envs() -> None:
    """Register every id of :data:`ENV_IDS` with Gymnasium; a second call does nothing."""
    import gymnasium as gym

    for env_id, kwargs in ENV_IDS.items():
        if env_id not in gym.registry:
            gym.register(
                id=env_id,
                entry_point=ENTRY_POINT,
                kwargs=dict(kwargs),
                max_episode_steps=None,  # the env's own limit, which follows n_max
                reward_threshold=success_threshold(
                    RewardWeights(), kwargs.get("n_max", DEFAULT_N_MAX)
                ),
            )


def episode_limit(kwargs: dict) -> int:
    """The env's own step limit for these arguments (its default ``max_steps``, 4 * n_max):
    ``env.unwrapped.max_steps`` of ``gym.make(id, **kwargs)``."""
    return kwargs.get("max_steps") or 4 * kwargs.get("n_max", DEFAULT_N_MAX)


class _RegisterAfterGymnasium(importlib.abc.MetaPathFinder):
    """A post-import hook: when ``gymnasium`` is imported (after this package), the ids are
    registered as soon as it has loaded, so ``import modquad_gym`` need not load Gymnasium (and
    numpy) itself. It finds gymnasium's spec as Python would and runs :func:`register_envs`
    after the module's own code; then it leaves ``sys.meta_path``."""

    def find_spec(self, name, path=None, target=None):
        if name != "gymnasium":
            return None
        sys.meta_path.remove(self)
        spec = importlib.util.find_spec(name)
        if spec is None or spec.loader is None:
            return spec
        run = spec.loader.exec_module

        def exec_module(module) -> None:
            run(module)
            register_envs()

        spec.loader.exec_module = exec_module
        return spec


def register_when_gymnasium_loads() -> None:
    """Register the ids now if Gymnasium is loaded, else right after it is imported."""
    if "gymnasium" in sys.modules:
        register_envs()
    elif not any(isinstance(f, _RegisterAfterGymnasium) for f in sys.meta_path):
        sys.meta_path.insert(0, _RegisterAfterGymnasium())


register_when_gymnasium_loads()

_NAMES = {
    "assembly": [
        "AssemblyFeatures", "AssemblyState", "ModQuadAssemblyEnv", "RewardFn", "WeightedReward",
        "episode_return", "unit_directions",
    ],
}  # fmt: skip
__getattr__, __dir__, _ = lazy_loader.attach(__name__, ["assembly", "wrappers"], _NAMES)
__all__ = [
    "ENV_IDS",
    "RewardWeights",
    "episode_limit",
    "register_envs",
    "AssemblyFeatures",
    "AssemblyState",
    "ModQuadAssemblyEnv",
    "RewardFn",
    "WeightedReward",
    "episode_return",
    "unit_directions",
]

if TYPE_CHECKING:
    from modquad_gym.envs.assembly import (
        AssemblyFeatures,
        AssemblyState,
        ModQuadAssemblyEnv,
        RewardFn,
        WeightedReward,
        episode_return,
        unit_directions,
    )
