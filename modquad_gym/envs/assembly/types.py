"""The typed state of one assembly episode and the context its transitions read (what Jumanji
keeps in ``types.py``).

States are immutable: frozen dataclasses whose arrays are read-only. A transition never edits one,
:meth:`AssemblyState.but` makes the next one, so a reward function sees the state before and
after a step side by side and a planner can branch from any stored state (``env.restore``).
What a transition needs besides the state (the grid, the module set, the evaluator and the
episode's memos of decisions) is an :class:`Episode`, passed explicitly.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from modquad_gym.geometry.structure import Cell


@dataclass(frozen=True)
class TaskArrays:
    """One episode's task as the env uses it.

    Attributes:
        requirement: the task (a :class:`~modquad_gym.tasks.TaskRequirement`, or a
            :class:`~modquad_gym.dynamics.DynamicTask`).
        name: its name.
        W: wrenches (t, 6) (a dynamic task's: those of one structure, :mod:`.dynamic`).
        vec: the task feature vector (float32).
        h_Tn: the task's support on the feature directions, divided by denom (K,).
        WD: each wrench's projections on the directions, divided by denom (t, K).
        kind: the task's kind, a label (``"total"``, ``"external"``, ``"dynamic"``).
        lift_n: per direction, the normalised change of WD per kg of structure, when every
            wrench gains the same ``c M e_z`` for a structure of M kg (the weight of an
            ``external`` task; None when nothing is added).
        lift: that c (m/s^2; 0 when nothing is added).
        per_structure: the task's wrenches depend on the structure otherwise (a dynamic
            task's inertial forces): the arrays are one structure's own (:mod:`.dynamic`).
    """

    requirement: Any
    name: str
    W: np.ndarray
    vec: np.ndarray
    h_Tn: np.ndarray  # noqa: N815 (the features' notation)
    WD: np.ndarray
    kind: str = "total"
    lift_n: np.ndarray | None = None
    lift: float = 0.0
    per_structure: bool = False


@dataclass(frozen=True)
class Rules:
    """How episodes run (fixed at construction).

    Attributes:
        n_max: the largest number of modules.
        max_steps: the step limit for truncation.
        invalid_action: ``"penalise"`` or ``"terminate"``.
        lookahead: False, or which ``"candidates"`` rows states carry: True (support rows),
            ``"exact"`` (support rows and the exact lookahead, :mod:`.lookahead`).
        top_k: None, or the exact lookahead's shortlist: the valid actions per state
            (:func:`.lookahead.shortlisted`).
    """

    n_max: int
    max_steps: int
    invalid_action: str = "penalise"
    lookahead: bool | str = False
    top_k: int | None = None


@dataclass(frozen=True)
class Episode:
    """The context of one episode's transitions: everything but the state.

    Attributes:
        rules: the :class:`Rules`.
        actions: the action encoding (:class:`~.grid.Grid` or :class:`~.faces.Faces`).
        modules: the module set (:class:`~.modules.OneType` or :class:`~.modules.Palette`).
        evaluator: the :class:`~.evaluator.StructureEvaluator` of the episode's f_max.
        memo: the task's decisions, key -> (n_satisfied, structure vector) (shared by every
            episode of the same task object: a structure met again costs no oracle call).
        cand_memo: the task's lookahead rows, child key -> row.
        exact_memo: the task's exact lookahead entries, child key -> (share, margin)
            (``lookahead="exact"``).
        walk_memo: the optimal vertices of the walks of the current state's children, child
            key -> (tight columns, column bounds) per wrench (where the walks of the chosen
            child's own children start).
    """

    rules: Rules
    actions: Any
    modules: Any
    evaluator: Any
    memo: dict
    cand_memo: dict
    exact_memo: dict = field(default_factory=dict)
    walk_memo: dict = field(default_factory=dict)


@dataclass(frozen=True)
class AssemblyState:
    """Everything that changes during an episode.

    Attributes:
        task: the task arrays.
        cells: module cells in docking order, the initial module first.
        types: palette index of each module (the mixed env; empty for one type).
        occupancy: int8 (G * G,), 1 where a module sits on the encoding's grid.
        mask: int8, 1 for valid actions.
        structure_vec: float32 structure features against the task.
        frac: fraction of task wrenches the structure satisfies (exact oracle).
        success: every wrench satisfied.
        steps: steps taken this episode.
        evaluated: structures evaluated this episode (memo hits included).
        oracle_calls: wrench-structure tests made this episode.
        terminated, truncated: how the episode ended (both False while it runs).
        types_onehot: int8 (G * G * K,) type one-hot (the mixed env), else None.
        candidates: float32 rows of k entries: one per action (actions, k) in the faces
            encoding; in the grid's (with ``lookahead``) one per valid action (valid, k), in
            action order (the others are zero), so a state a planner keeps stays small at
            n_max 128 (G * G = 65,025 actions a type); else None.
        faces: the faces encoding's free faces, as grid cell indices in action order, else
            None.
        sites: the faces encoding's module cells as grid indices, in docking order, else None.
        free: the encoding's mask of the state when the lookahead's shortlist cut ``mask``
            (``lookahead_top_k``), else None.
    """

    task: TaskArrays
    cells: tuple[Cell, ...]
    occupancy: np.ndarray
    mask: np.ndarray
    structure_vec: np.ndarray
    frac: float
    success: bool
    steps: int = 0
    evaluated: int = 1
    oracle_calls: int = 0
    terminated: bool = False
    truncated: bool = False
    types: tuple[int, ...] = ()
    types_onehot: np.ndarray | None = None
    candidates: np.ndarray | None = field(default=None)
    faces: np.ndarray | None = None
    sites: np.ndarray | None = None
    free: np.ndarray | None = None

    @property
    def done(self) -> bool:
        """The episode is over (terminated or truncated)."""
        return self.terminated or self.truncated

    @property
    def n_modules(self) -> int:
        return len(self.cells)

    def __post_init__(self) -> None:
        for name in _ARRAYS:
            _freeze(getattr(self, name))

    def but(self, **changes: Any) -> AssemblyState:
        """A copy with ``changes`` (arrays not named are shared; every array is read-only).
        Same as ``dataclasses.replace`` without re-running ``__init__`` (the hot path)."""
        for name in _ARRAYS:
            if name in changes:
                _freeze(changes[name])
        new = object.__new__(AssemblyState)
        object.__setattr__(new, "__dict__", {**self.__dict__, **changes})
        return new

    def info(self, invalid: bool, terms: dict[str, float]) -> dict:
        """The env's ``info`` of this state (see the env's docstring for the keys)."""
        return {
            "n_modules": len(self.cells),
            "satisfied_fraction": self.frac,
            "success": self.success,
            "is_success": self.success,
            "cells": [[x, y] for x, y in self.cells],
            "evaluated": self.evaluated,
            "oracle_calls": self.oracle_calls,
            "action_mask": self.mask.astype(bool),
            "task_name": self.task.name,
            "n_wrenches": len(self.task.W),
            "invalid_action": invalid,
            "reward_terms": terms,
        }


_ARRAYS = ("occupancy", "mask", "structure_vec", "types_onehot", "candidates", "faces", "sites",
           "free")  # fmt: skip


def _freeze(array: np.ndarray | None) -> None:
    if array is not None:
        array.flags.writeable = False
