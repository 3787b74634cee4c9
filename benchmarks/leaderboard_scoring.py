"""What the leaderboard scores itself rather than reading it committed: the searches a tier
report did not run (``--rescore-searches``), the anytime search's history (``--anytime-history``)
and an outside agent on every tier (``--solver``), written as its submission file."""

from __future__ import annotations

import sys
from collections.abc import Iterable
from pathlib import Path

from benchmarks.leaderboard_checks import refuse_taken
from benchmarks.leaderboard_entries import ANYTIME, COMMAND, RESCORED, RESULTS, TIERS, read_rows
from modquad_gym.core.interrupts import one_line


def rescore_searches(
    results: Path = RESULTS, progress: bool = True, into: Path | None = None
) -> Path | None:
    """Run the searches that a tier report of ``results`` did not run on that tier's held-out
    suites and write their per-task rows to ``leaderboard_searches.csv`` in ``into`` (default
    ``results``; on a fault tier, those that honour the failure); its path. None, with a line
    saying so, when every report ran every search: nothing to run, nothing written."""
    from modquad_gym.core.outputs import write_csv, write_text
    from modquad_gym.scoring.agents import run_benchmark
    from modquad_gym.scoring.tiers import get_tier, honours_fault
    from modquad_gym.search import SEARCHES

    rows = []
    for name in TIERS:
        tier = get_tier(name)
        have = {r.method for r in read_rows(results / f"tier_{name}" / "benchmark.csv")}
        missing = [m for m in SEARCHES if m not in have and (not tier.fault or honours_fault(m))]
        if missing:
            print(f"{name}: scoring {', '.join(missing)}", file=sys.stderr)
            rows += run_benchmark(tier.load_suites(), missing, tier.n_max, None, None, progress, 1,
                                  tier.modules, tier.name, tier.fault)  # fmt: skip
    if not rows:
        print("every tier report ran every search: nothing to rescore, nothing written",
              file=sys.stderr)  # fmt: skip
        return None
    path = (results if into is None else into) / RESCORED
    write_csv([r.as_csv() for r in rows], path)
    write_text(path.with_suffix(".md"), rescored_note(rows))
    return path


def rescored_note(rows) -> str:
    """What ``results/leaderboard_searches.csv`` holds and how it was made (its provenance)."""
    from modquad_gym.scoring import machine_description

    suites: dict[tuple, list[str]] = {}  # the methods run -> the suites they ran on
    for suite in dict.fromkeys(r.suite for r in rows):
        methods = tuple(dict.fromkeys(r.method for r in rows if r.suite == suite))
        suites.setdefault(methods, []).append(f"`{suite}`")
    what = "; ".join(f"{', '.join(m)} on {', '.join(s)}" for m, s in suites.items())
    return "\n".join([
        "# Searches scored for the leaderboard",
        "",
        f"Made by `{COMMAND} --rescore-searches --force`. Machine: {machine_description()}.",
        "",
        "The searches that a one-run tier report did not run, on that tier's held-out suites, "
        f"one row per method and task in `{RESCORED}` (as `modquad score` writes "
        f"them): {what}.",
        "",
    ])  # fmt: skip


def anytime_history(results: Path = RESULTS, progress: bool = True) -> Path:
    """Run the anytime search on every tier's held-out tasks and write, per task, when its
    best structure so far first had the certified optimum's module count (its history's events) to
    ``leaderboard_anytime.csv`` in ``results``, with a note of the machine beside it."""
    from tqdm import tqdm

    from modquad_gym.core.outputs import write_csv, write_text
    from modquad_gym.scoring import machine_description
    from modquad_gym.scoring.tiers import get_tier
    from modquad_gym.search import anytime_search

    out = []
    for name in TIERS:
        tier = get_tier(name)
        jobs = [(s, t) for s, tasks in tier.load_suites().items() for t in tasks]
        for suite, task in tqdm(jobs, f"anytime history ({name})", disable=not progress):
            optimum = task.meta.get("optimum")
            r = anytime_search(task, n_max=tier.n_max, **tier.search_kwargs())
            at = [e.seconds for e in r.history if optimum is not None and e.n_modules == optimum]
            out.append({"tier": name, "suite": suite, "task": task.name, "optimum": optimum,
                        "in_scope": int(optimum is not None and optimum <= tier.n_max),
                        "n_modules": r.n_modules, "certified": int(r.certified),
                        "seconds": f"{r.seconds:.5f}",
                        "optimal_at": f"{min(at):.5f}" if at else "",
                        "history": ";".join(f"{e.seconds:.5f}:{e.lower_bound}:{e.n_modules}"
                                            for e in r.history)})  # fmt: skip
    path = results / ANYTIME
    write_csv(out, path)
    write_text(path.with_suffix(".md"), "\n".join([
        "# The anytime search's history on the tiers' held-out tasks",
        "",
        f"Made by `{COMMAND} --anytime-history --force`. Machine: {machine_description()}.",
        "",
        "Per task (one row in `leaderboard_anytime.csv`): the anytime search's answer, its wall "
        "time, `optimal_at` (the seconds after which its best structure so far had the "
        "certified optimum's module count) and its `history` (seconds:lower bound:best "
        "structure's modules per event).",
        "",
    ]))  # fmt: skip
    return path


def score_agent(spec: str, tiers: Iterable[str], limit: int | None, seeds: list[int],
                progress: bool) -> list[dict]:  # fmt: skip
    """An outside agent on every tier's held-out suites (the first ``limit`` tasks of each),
    once per seed of ``seeds`` (once when the agent takes no seed): the submission's records
    (:func:`write_submission`), one per (tier, seed, task), the agent's own ``name`` as its
    method. Its constructor runs once per (tier, seed), told that tier's budget, types, fault
    and the seed. A tier where the agent fails is one record with the failure in ``status``;
    the other tiers go on. An import error, or a ``name`` that a committed method has, is a
    ValueError before any work."""
    from modquad_gym.scoring.agents import run_benchmark

    tiers = list(tiers)
    first = _made(spec, tiers[0], seeds[0])  # a bad spec fails now, before any work
    name = first.name
    refuse_taken(name, spec)
    runs = seeds if first.takes_seed else seeds[:1]
    records: list[dict] = []
    for tier_name in tiers:
        status = {"tier": tier_name, "seed": "", "method": name, "status": ""}
        try:
            mine = []
            for seed in runs:
                tier, solver = _tier(tier_name), first
                if (tier_name, seed) != (tiers[0], seeds[0]):
                    solver = _made(spec, tier_name, seed)
                told = seed if first.takes_seed else None  # a seed it takes, or none
                rows = run_benchmark(tier.load_suites(limit), [spec], tier.n_max, None, told,
                                     progress, 1, tier.modules, tier.name, tier.fault,
                                     made={spec: solver})  # fmt: skip
                mine += [{"tier": tier.name, "seed": str(seed), **r.as_csv(), "method": name,
                          "status": ""} for r in rows]  # fmt: skip
            records += mine
        except Exception as err:  # the agent's failure on this tier; the others go on
            failure = f"failed: {type(err).__name__}: {one_line(err)}"
            print(f"{tier_name}: {name} {failure}", file=sys.stderr)
            records.append({**status, "status": failure})
    return records


def _tier(name: str):
    from modquad_gym.scoring.tiers import get_tier

    return get_tier(name)


def _made(spec: str, tier_name: str, seed: int):
    """The outside agent ``spec`` made for one tier (its budget, types and fault) and seed."""
    from modquad_gym.geometry.module import palette
    from modquad_gym.solvers import load_solver
    from modquad_gym.solvers.outside import solver_named

    tier = _tier(tier_name)
    types = palette(tier.modules) if tier.modules else None
    with solver_named("--solver"):  # the command line's option, in its errors
        return load_solver(spec, n_max=tier.n_max, tier=tier.name, modules=types,
                           fault=tier.fault, seed=seed)  # fmt: skip


SUBMISSION_KEYS = ("tier", "seed", "method", "status", "suite", "task", "optimum", "success",
                   "n_modules", "gap", "optimal", "evaluated", "oracle_calls", "seconds",
                   "cells")  # fmt: skip


def write_submission(records: list[dict], path: Path) -> Path:
    """The submission file: one row per (tier, seed, task) as ``modquad score`` writes its rows,
    with the tier, the seed and ``status`` (a tier not scored: one row saying why)."""
    from modquad_gym.core.outputs import write_csv

    write_csv([{k: r.get(k, "") for k in SUBMISSION_KEYS} for r in records], path)
    return path


if __name__ == "__main__":
    from benchmarks.common import refuse_as_script

    raise SystemExit(refuse_as_script("leaderboard_scoring"))
