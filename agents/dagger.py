"""Expert in the loop (DAgger): the certified search labels the states the learner visits.

Behaviour cloning (:mod:`.imitation`) learns on the expert's own states only, so a learner's
mistake leads it where no label was ever given. Here the learner drives: on fresh training
tasks its greedy episode runs to the end, and every state it passes gets the expert's label,
the dockings that keep a minimum completion reachable:

* while the structure still fits inside an optimal structure (from the same expert as the
  demonstrations, :func:`~.imitation.expert_targets`), the good actions of
  :func:`~.imitation.good_actions`;
* once it does not (an earlier docking was a mistake), the dockings towards a minimum completion
  of the structure built so far, from the certified search started at it
  (``exhaustive_search(task, start=cells)``, where the search offers it: until then such states
  stay unlabelled).

The states are added to the demonstrations and the policy is cloned again (aggregation), for
``rounds`` rounds. Value targets are the learner's own returns-to-go.
"""

from __future__ import annotations

import inspect
from collections.abc import Sequence
from typing import Any

import numpy as np

from agents.imitation import (
    Demonstrations,
    expert_episode,
    good_actions,
    merge,
)
from modquad_gym.envs.assembly import ModQuadAssemblyEnv
from modquad_gym.search import exhaustive_search, greedy_search


def search_starts_anywhere() -> bool:
    """Whether the certified search can extend a given partial structure (``start=``)."""
    return "start" in inspect.signature(exhaustive_search).parameters


def completion_targets(
    env: ModQuadAssemblyEnv, task: Any, n_max: int, by: str = "certified"
) -> list:
    """Targets (as :func:`~.imitation.placements` gives them, on the episode's own grid) of a
    completion of the current structure: ``by="certified"`` a minimum one, from the certified
    search started at it; ``by="greedy"`` greedy's (:func:`greedy_search` with ``start=``),
    where no certified search finishes (expert iteration at the field's sizes). [] when the
    search cannot start there or no completion of up to ``n_max`` modules works."""
    if by == "certified" and not search_starts_anywhere():
        return []
    palette = env.palette
    kwargs = {"modules": list(palette)} if palette is not None else {}
    kwargs |= {"fault": env.fault} if env.fault is not None else {}
    built = env.structure
    search = exhaustive_search if by == "certified" else greedy_search
    r = search(task, n_max=n_max, start=built, **kwargs)
    if r.structure is None:
        return []
    found = _typed(r.structure, palette)
    shift = _shift(_typed(built, palette), found)
    if shift is None:
        return []
    dx, dy = shift
    return [frozenset(((x + dx, y + dy), k) for (x, y), k in found)]


def _typed(structure, palette) -> list:
    """(cell, palette index) pairs of a structure (index 0 for one type)."""
    if palette is None:
        return [(tuple(c), 0) for c in structure.cells]
    return [(tuple(c), palette.index(m)) for c, m in zip(structure.cells, structure.modules)]


def _shift(built: list, found: list) -> tuple[int, int] | None:
    """The translation that puts ``found`` (a structure containing a translate of ``built``,
    both (cell, type) pairs) over ``built``'s cells, or None."""
    (bx, by), _ = built[0]
    pairs = set(found)
    for (fx, fy), _ in found:
        dx, dy = bx - fx, by - fy
        if all(((x - dx, y - dy), k) in pairs for (x, y), k in built):
            return dx, dy
    return None


def learner_states(
    policy: Any,
    env: ModQuadAssemblyEnv,
    tasks: Sequence[Any],
    n_max: int,
    seed: int = 0,
    expert: Any = "all",
    progress: bool = False,
    completion: str = "certified",
) -> tuple[Demonstrations, dict]:
    """One greedy episode of ``policy`` (an SB3 masked policy) per task, every state it visits
    labelled by the expert (see the module docstring; unlabelled states are left out), and
    how the learner did: its episodes that ended optimal, and its good actions among the
    labelled states. ``completion``: how a state off every target is labelled
    (:func:`completion_targets`' ``by``)."""
    rng = np.random.default_rng(seed)
    rows: dict[str, list[np.ndarray]] = {}
    valid, good, returns = [], [], []
    used = optimal = hits = 0
    for task in _maybe_progress(tasks, progress):
        episode = expert_episode(env, task, n_max, expert, rng)
        if episode is None:
            continue
        n_star, targets, obs = episode
        rewards, labelled, done = [], [], False
        while not done:
            mask = env.action_masks()
            g = good_actions(env, targets)
            if not g.any():  # off every optimum: towards a minimum completion, if any
                targets = completion_targets(env, task, n_max, by=completion)
                g = good_actions(env, targets)
            if g.any():
                for k, v in obs.items():
                    rows.setdefault(k, []).append(v)
                valid.append(mask)
                good.append(g)
                labelled.append(len(rewards))
            action, _ = policy.predict(obs, action_masks=mask, deterministic=True)
            hits += bool(g[int(action)])
            obs, reward, terminated, truncated, info = env.step(int(action))
            rewards.append(reward)
            done = terminated or truncated
        to_go = np.cumsum(rewards[::-1])[::-1]
        returns.extend(to_go[i] for i in labelled)
        used += 1
        optimal += bool(info["success"] and info["n_modules"] == n_star)
    if not valid:
        return merge([]), {}  # raises: nothing to learn
    stats = {"tasks": used, "learner_optimal": round(optimal / used, 4),
             "learner_good": round(hits / len(valid), 4)}  # fmt: skip
    return Demonstrations.stacked(rows, valid, good, returns, used), stats


def _maybe_progress(items: Sequence[Any], progress: bool):
    if not progress:
        return items
    from tqdm.auto import tqdm

    return tqdm(items, desc="learner episodes (DAgger)", unit="task")
