"""What ``env.restore(state)`` accepts: a state the environment itself makes for the current task.

A state's primary fields are its task (the episode's, by identity), its docking sequence
(``cells``, ``types``), its step count and its end flags; every other field follows from them.
:func:`check_restore` replays the dockings through the action encoding (each module docked to
the ones before it, on the grid, of a type of the set), recomputes the derived fields as a step
does (:mod:`.transitions`; the memoised decisions make that about one step's cost, and the
recomputation writes no memo, so the next step is the same as without it), and refuses a state
whose fields differ, in one line naming the field. Masks, cells and counts are compared
exactly, float arrays (features, lookahead rows, task arrays) within :data:`ROW_TOL` (a
recomputation may differ by round-off). Where round-off can order two equal children either way
(the shortlist's cut, greedy's flag), a choice between children equal within :data:`ROW_TOL` is
accepted. ``oracle_calls`` counts work that depends on the memos' history: it is checked to be
a count, not recomputed.

A state object the environment handed out (``env.state``) is known by identity
(:class:`Restorer`): restoring it again costs nothing (a guided search restores one a node).
States are immutable (frozen, read-only arrays), so an edit makes a copy, which is recomputed;
unlocking an array to edit it in place is not looked for (some arrays are the memos' own, so
that edits the environment itself).
"""

from __future__ import annotations

import weakref
from collections import ChainMap
from dataclasses import replace
from typing import Any

import numpy as np

from modquad_gym.envs.assembly.bounds import margin_bound
from modquad_gym.envs.assembly.lookahead import ranking, shortlisted
from modquad_gym.envs.assembly.transitions import decided_fields
from modquad_gym.envs.assembly.types import AssemblyState, Episode
from modquad_gym.search.baselines import TIE_DECIMALS

ROW_TOL = 1e-5
"""Float fields of a restored state may differ from their recomputation by this much (float32
features in [-1, 1]; a recomputation differs by round-off, ~1e-7)."""
EXACT = ("occupancy", "free", "faces", "sites", "types_onehot")
"""Integer arrays compared exactly (the mask too, but for the shortlist's near ties)."""


ISSUED = 4096
"""Handed-out states a :class:`Restorer` keeps track of (cleared when full)."""


class Restorer:
    """An environment's check of restored states: the state objects it handed out pass at once
    (weak references by identity), any other by :func:`check_restore`."""

    def __init__(self) -> None:
        self.issued: dict[int, weakref.ref] = {}

    def issue(self, state: AssemblyState) -> AssemblyState:
        """``state``, remembered as handed out."""
        if len(self.issued) >= ISSUED:
            self.issued.clear()
        self.issued[id(state)] = weakref.ref(state)
        return state

    def check(self, ep: Episode, current: AssemblyState, state: Any) -> None:
        """As :func:`check_restore`; a handed-out state of the current task at once."""
        if isinstance(state, AssemblyState) and state.task.requirement is current.task.requirement:
            known = self.issued.get(id(state))
            if known is not None and known() is state:
                return
        check_restore(ep, current, state)


def check_restore(ep: Episode, current: AssemblyState, state: Any) -> None:
    """``state`` may continue the episode ``ep`` whose state is ``current``: an AssemblyState of
    this episode's task, made by an environment of the same shape, whose derived fields are
    those the environment computes from its dockings (module doc); else a one-line ValueError
    naming the field."""
    if not isinstance(state, AssemblyState):
        raise ValueError(
            f"restore: state must be an AssemblyState (one env.state returned), "
            f"got {type(state).__name__}"
        )
    if state.task.requirement is not current.task.requirement:
        raise ValueError("restore: the state belongs to an episode of another task")
    n_actions, n_max = ep.actions.n_actions, ep.rules.n_max
    same_shape = (
        np.shape(state.mask) == (n_actions,)
        and isinstance(state.cells, tuple)
        and 0 < len(state.cells) <= n_max
        and layout(state) == layout(current)
    )
    if not same_shape:
        raise ValueError(
            f"restore: the state was made by another environment ({len(state.cells or ())} "
            f"modules, {np.size(state.mask)} actions; this one: n_max {n_max}, {n_actions} "
            "actions, its module types and lookahead)"
        )
    rows = n_actions if current.faces is not None else np.count_nonzero(state.mask)
    if state.candidates is not None and len(state.candidates) != rows:  # an edited state
        raise ValueError(
            f"restore: the state has {len(state.candidates)} lookahead rows for {rows} actions"
        )
    view = replace(ep, memo=ChainMap({}, ep.memo), cand_memo=ChainMap({}, ep.cand_memo),
                   exact_memo=ChainMap({}, ep.exact_memo),
                   walk_memo=ChainMap({}, ep.walk_memo))  # fmt: skip
    docked = replayed(view, state)
    check_counts(ep, state, docked)
    for name, same in compared(view, state, docked).items():
        if not same:
            raise ValueError(
                f"restore: the state's {name} is not what the environment computes for its "
                f"{len(state.cells)} docked modules"
            )


def layout(state: Any) -> list[tuple]:
    """What every state of one environment shares: its arrays' dtypes and shapes (the
    lookahead rows' width, not their count, which follows the valid actions)."""
    arrays = (state.mask, state.occupancy, state.structure_vec, state.types_onehot)
    rows = state.candidates
    return [(np.asarray(a).dtype, np.shape(a)) for a in arrays] + [
        (np.asarray(rows).dtype, np.shape(rows)[1:])
    ]


def replayed(ep: Episode, state: AssemblyState) -> AssemblyState:
    """The state the encoding makes by docking ``state``'s modules in order from the one at
    (0, 0), with the decided fields of that structure (the encoding's own mask: no
    shortlist, no lookahead rows); ValueError naming ``cells`` or ``types`` when no sequence
    of actions docks them."""
    cells, types, n_types = state.cells, state.types, ep.modules.n_types
    if not isinstance(types, tuple) or len(types) != (len(cells) if n_types > 1 else 0):
        raise ValueError(f"restore: the state's types {types!r} do not match its cells")
    if any(not _index(k) or not 0 <= k < n_types for k in types):
        raise ValueError(f"restore: the state's types {types!r} name no type of the {n_types}")
    bad = [c for c in cells if not (type(c) is tuple and len(c) == 2 and all(map(_index, c)))]
    if bad or cells[0] != (0, 0):
        raise ValueError(
            f"restore: the state's cells must be (x, y) integer pairs from (0, 0), got {cells!r}"
        )
    task = ep.evaluator.task_arrays(state.task.requirement, ep.modules.key(cells[:1], types[:1]))
    s = AssemblyState(task, cells[:1], structure_vec=None, frac=0.0, success=False,
                      types=types[:1], **ep.actions.initial_fields(types[:1]))  # fmt: skip
    for i in range(1, len(cells)):
        try:
            a = ep.actions.state_action_of(s, cells[i], types[i] if types else 0)
        except ValueError:
            a = None
        if a is None or not s.mask[a]:
            raise ValueError(
                f"restore: the state's cells: module {i + 1} at {cells[i]} is not docked to "
                "the modules before it on the grid (no action docks it there)"
            )
        s = s.but(cells=cells[: i + 1], types=types[: i + 1], **ep.actions.docked_fields(s, a))
    return s.but(**decided_fields(ep, s, cells, types))


def _index(value: Any) -> bool:
    return isinstance(value, (int, np.integer)) and not isinstance(value, (bool, np.bool_))


def check_counts(ep: Episode, state: AssemblyState, docked: AssemblyState) -> None:
    """``steps``, ``evaluated``, ``oracle_calls``, ``terminated`` and ``truncated`` are what
    some sequence of steps docking ``state``'s modules gives (see the env's "Episode End"):
    ValueError naming the first that is not."""
    rules, n = ep.rules, len(state.cells)
    for name in ("steps", "evaluated", "oracle_calls"):
        value = getattr(state, name)
        if not _index(value) or value < 0:
            raise ValueError(f"restore: the state's {name} must be a count, got {value!r}")
    for name in ("terminated", "truncated"):
        if not isinstance(getattr(state, name), (bool, np.bool_)):
            raise ValueError(f"restore: the state's {name} must be a bool")
    if state.evaluated != n:  # the initial structure and one per docking
        raise ValueError(f"restore: the state's evaluated ({state.evaluated}) is not {n}")
    idle = state.steps - (n - 1)  # steps that docked nothing
    if not 0 <= idle <= rules.max_steps - (n - 1):
        raise ValueError(
            f"restore: the state's steps ({state.steps}) cannot follow its {n - 1} dockings "
            f"within max_steps {rules.max_steps}"
        )
    ended = n > 1 and (docked.success or n >= rules.n_max or not docked.mask.any())
    if ended:  # the docking ended it: nothing after it
        want = (True, False), idle == 0 or rules.invalid_action == "penalise"
    elif docked.success or rules.invalid_action == "terminate":  # one step that docks nothing
        want = (idle == 1, False), idle <= 1  # ends it (solved at reset, or an invalid action)
    else:
        want = (False, state.steps >= rules.max_steps), True
    (terminated, truncated), possible = want
    if not possible:
        raise ValueError(
            f"restore: the state's steps ({state.steps}) cannot follow its {n - 1} dockings "
            f"with invalid_action={rules.invalid_action!r}"
        )
    if bool(state.terminated) != terminated:
        raise ValueError(
            f"restore: the state's terminated ({state.terminated}) does not follow its "
            f"{n} modules and {state.steps} steps"
        )
    if bool(state.truncated) != truncated:
        raise ValueError(
            f"restore: the state's truncated ({state.truncated}) does not follow its "
            f"{state.steps} steps (max_steps {rules.max_steps})"
        )


def compared(ep: Episode, state: AssemblyState, docked: AssemblyState) -> dict[str, bool]:
    """Per derived field of ``state``, whether it is the one recomputed from ``docked`` (the
    replayed structure, :func:`replayed`), in the order they are checked."""
    task, want = state.task, docked.task
    same = {
        "task": (task.name, task.kind, task.lift, task.per_structure)
        == (want.name, want.kind, want.lift, want.per_structure)
        and all(_close(getattr(task, k), getattr(want, k)) for k in ("W", "vec", "h_Tn", "WD",
                                                                      "lift_n")),
        "frac": state.frac == docked.frac,
        "success": isinstance(state.success, (bool, np.bool_))
        and bool(state.success) == bool(docked.success),
        "structure_vec": _close(state.structure_vec, docked.structure_vec),
    }  # fmt: skip
    expected, bounds = docked, {}
    if ep.rules.top_k is not None:
        expected, bounds = shortlisted(ep, docked)
    same["mask"] = np.array_equal(state.mask, expected.mask) or near_tie(ep, state, expected)
    for name in EXACT:
        a, b = getattr(state, name), getattr(expected, name)
        same[name] = (a is None) == (b is None) and (a is None or _equal(a, b))
    if not all(same.values()):
        return same
    if np.array_equal(state.mask, expected.mask):
        rows = ep.actions.candidates(ep, expected, bounds)
    else:  # the shortlist of a near tie: the rows of the state's own cut
        rows = ep.actions.candidates(ep, expected.but(mask=state.mask))
    same["candidates"] = (rows is None) == (state.candidates is None) and (
        rows is None or same_rows(ep, state.candidates, rows)
    )
    return same


def near_tie(ep: Episode, state: AssemblyState, expected: AssemblyState) -> bool:
    """``state``'s mask is a shortlist of ``expected``'s free actions of the right size whose
    differing actions tie with the last kept one within :data:`ROW_TOL` (round-off decides
    between equal children)."""
    free = expected.free
    if free is None or state.mask.dtype != free.dtype or np.any(state.mask > free):
        return False
    if np.count_nonzero(state.mask) != np.count_nonzero(expected.mask):
        return False
    valid = np.flatnonzero(free)
    order, bounds = ranking(ep, expected.but(mask=free, free=None), valid)
    share = dict(zip(order.tolist(), bounds.share))
    margin = dict(zip(order.tolist(), np.round(margin_bound(bounds.gamma), TIE_DECIMALS)))
    last = int(order[ep.rules.top_k - 1])
    return all(
        abs(share[a] - share[last]) <= ROW_TOL and abs(margin[a] - margin[last]) <= ROW_TOL
        for a in np.flatnonzero(state.mask != expected.mask).tolist()
    )


def same_rows(ep: Episode, got: np.ndarray, want: np.ndarray) -> bool:
    """The lookahead rows ``got`` are ``want`` within :data:`ROW_TOL`; greedy's flag (the last
    column with the exact lookahead) may sit on another child whose share and margin equal
    those of the flagged one within it."""
    if got.dtype != want.dtype or got.shape != want.shape:
        return False
    if ep.rules.lookahead != "exact":
        return _close(got, want)
    flags, wanted = got[:, -1], want[:, -1]
    if not _close(got[:, :-1], want[:, :-1]) or not np.isin(flags, (0.0, 1.0)).all():
        return False
    if np.array_equal(flags, wanted):
        return True
    a, b = np.flatnonzero(flags), np.flatnonzero(wanted)
    return len(a) == len(b) == 1 and _close(want[a[0], -3:-1], want[b[0], -3:-1])


def _close(a: Any, b: Any) -> bool:
    if a is None or b is None:
        return a is None and b is None
    a, b = np.asarray(a), np.asarray(b)
    return a.shape == b.shape and bool(np.allclose(a, b, rtol=1e-6, atol=ROW_TOL))


def _equal(a: np.ndarray, b: np.ndarray) -> bool:
    return np.asarray(a).dtype == np.asarray(b).dtype and np.array_equal(a, b)
