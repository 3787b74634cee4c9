"""Scores of a model at the field's sizes beside greedy (:mod:`.expert_iteration`'s rounds):
``ppo`` on the scale families' validation draws, its single pass on the current tier's
validation tasks,
the labels' answers per round, and the run's report page."""

from __future__ import annotations

from pathlib import Path

import numpy as np


def score(model: Path, n_max: int, per_family: int, bands, families) -> list[dict]:
    """``ppo`` (its default decoding) of ``model`` and ``greedy`` on the validation draws of
    ``families``
    in ``bands`` (``per_family`` tasks per family and band; module budget ``n_max``, or the
    band where larger)."""
    from modquad_gym.scoring.scale_tasks import draw
    from modquad_gym.search import greedy_search, verified
    from modquad_gym.solvers import make_solver

    rows = []
    for band in bands:
        budget = max(n_max, band)
        ppo = make_solver("ppo", n_max=budget, model=str(model))
        for family in families:
            for i in range(per_family):
                task = draw(family, band, i, validation=True)
                mine, rule = ppo.solve(task), greedy_search(task, n_max=budget, time_limit=60)
                rows.append({"task": task.name, "family": family, "band": band,
                             "ppo": mine.n_modules if verified(mine.structure, task) else None,
                             "greedy": rule.n_modules, "ppo_s": round(mine.seconds, 2),
                             "greedy_s": round(rule.seconds, 2)})  # fmt: skip
    return rows


def current_tier(model: Path, tasks: list) -> dict:
    """The single pass of ``model`` (the policy's own episode, no extra pass) on the current
    tier's validation tasks (certified optima): optimal and success shares, so a round that
    forgets the small tasks shows it."""
    from modquad_gym.search import verified
    from modquad_gym.solvers import make_solver

    ppo = make_solver("ppo", n_max=7, model=str(model), extra_fallbacks=())
    found = [ppo.solve(t) for t in tasks]
    ok = [verified(r.structure, t) for r, t in zip(found, tasks)]
    best = [o and r.n_modules == t.meta["optimum"] for o, r, t in zip(ok, found, tasks)]
    return {"current_optimal": round(float(np.mean(best)), 3),
            "current_success": round(float(np.mean(ok)), 3)}  # fmt: skip


def summary(rows: list[dict]) -> dict:
    """Solved counts, mean modules on the tasks both solved, and wins/ties/losses against
    greedy."""
    both = [r for r in rows if r["ppo"] is not None and r["greedy"] is not None]
    return {
        "tasks": len(rows),
        "ppo_solved": sum(r["ppo"] is not None for r in rows),
        "greedy_solved": sum(r["greedy"] is not None for r in rows),
        "ppo_mean": round(float(np.mean([r["ppo"] for r in both])), 2) if both else None,
        "greedy_mean": round(float(np.mean([r["greedy"] for r in both])), 2) if both else None,
        "fewer": sum(r["ppo"] < r["greedy"] for r in both),
        "equal": sum(r["ppo"] == r["greedy"] for r in both),
        "more": sum(r["ppo"] > r["greedy"] for r in both),
        "ppo_s": round(float(np.mean([r["ppo_s"] for r in rows])), 2),
        "greedy_s": round(float(np.mean([r["greedy_s"] for r in rows])), 2),
    }


def label_summary(labels: list[dict]) -> list[dict]:
    """Per round and family, on its training tasks: mean modules of the default search, greedy
    (where run), the guided search, the single pass and the target (each over the tasks it
    solved), and how often the guided search's answer was smaller than the default search's."""

    def known(r, key) -> bool:  # a module count (rows read back from labels.csv hold text)
        return r.get(key) not in (None, "", "None")

    def mean(rs, key):
        xs = [int(r[key]) for r in rs if known(r, key)]
        return round(float(np.mean(xs)), 2) if xs else ""

    out = []
    groups = {(int(row["round"]), row.get("family", "")): None for row in labels}
    for r, family in sorted(groups):
        rs = [row for row in labels if int(row["round"]) == r and row.get("family", "") == family]
        won = sum(known(x, "guided") and known(x, "search")
                  and int(x["guided"]) < int(x["search"]) for x in rs)  # fmt: skip
        out.append({"round": r, "family": family, "tasks": len(rs), "search": mean(rs, "search"),
                    "greedy": mean(rs, "greedy"), "guided": mean(rs, "guided"),
                    "ppo": mean(rs, "ppo"), "target": mean(rs, "target"),
                    "guided_smaller": won})  # fmt: skip
    return out


def report(rows: list[dict], args, seconds: float, labels=(), made=()) -> str:
    """The page of an expert-iteration run (``args``: its options; ``made``: its rounds)."""
    from modquad_gym.scoring import machine_description, markdown_table

    return "\n".join([
        "# Expert iteration at the field's sizes",
        "",
        f"Made by `python -m agents.expert_iteration {' '.join(args.argv)}` on "
        f"{machine_description()} in {seconds / 60:.1f} min.",
        "",
        ("Round 0 is the start model. " if args.score_start else "")
        + f"Rounds {', '.join(map(str, made))}: {args.tasks} training tasks each, drawn "
        f"in turn from {', '.join(f'{f} {lo}-{hi}' for f, lo, hi in args.draws)} modules; "
        "labels: the smallest of the default search's"
        + (", greedy's (first on ties)" if args.greedy else "")
        + " and the guided search's answer, one expert episode each"
        + (", the learner's own episode labelled towards the label or greedy's completion"
           if args.learner else "")
        + (f", {args.replay} replayed current-tier episodes" if args.replay else "")
        + "; the policy cloned on all rounds' states. Every model is scored by `ppo` (its "
        "default decoding) against `greedy` on the validation draws of "
        f"{', '.join(dict.fromkeys(f for f, _, _ in args.draws))} at "
        f"{', '.join(map(str, args.bands))} modules ({args.per_family} per family and band), "
        f"n_max {args.n_max} (or the band, where larger). `fewer`/`equal`/`more`: tasks where "
        "ppo used fewer, as many or more modules than greedy, of those both solved; "
        "`current_optimal`/`current_success`: on the current tier's 40 validation tasks (n_max 7).",
        "",
        markdown_table(rows),
        "",
        "On each round's training tasks (`labels.csv`): mean modules of the default search "
        f"({args.search_seconds:g} s), the current policy's guided search and single pass, and "
        "of the target (the smallest); `guided_smaller`: tasks where the guided search's answer "
        "was smaller than the default search's.",
        "",
        markdown_table(label_summary(list(labels))),
        "",
    ])  # fmt: skip
