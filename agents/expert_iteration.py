"""Expert iteration at the field's sizes: the policy cloned towards the best structure that the
default search or its own guided search finds, round after round (ExIt; issue 36, item 2).

    python -m agents.expert_iteration [--rounds 2] [--tasks 48] [--out runs/exit]

Where the certified search cannot go (8-32 modules), the labels come from search: in round r,
``tasks`` fresh training tasks of the one-type scale families (``planted`` and ``torque``, low
force and high torque, :mod:`benchmarks.scale_suites`), each of 8-32 modules and drawn from
``default_rng([EXIT_SEED0, seed, r, i])`` (never a held-out or validation seed), are solved by
the default search (``--search-seconds``) and by the current policy's guided search; the smaller
verified structure is the target, one expert episode towards it (:mod:`.imitation`, an
environment of n_max ``--n-max`` with the policy's exact lookahead) gives labelled states, the
learner's own episode gives more (``--learner``, DAgger: towards the target while its structure
fits in it, else towards greedy's completion of what it built), ``--replay`` certified episodes
of the current tier's training tasks keep the small tasks in view, and the policy is cloned on
every round's states so far. As the policy improves, so does its guided search, and so do the
targets. The model of each round is saved in ``OUT/round-R/`` (size-free: ``modquad solve
--method ppo --model OUT/round-R/model.zip`` acts at any n_max) and scored on validation draws
of the same families (16, 24 and 32 modules), single pass, beside greedy, and on the current
tier's validation tasks; ``OUT/report.md`` and ``OUT/rows.csv`` hold the scores,
``OUT/labels.csv`` every label, and ``OUT/model.zip`` is the last round's model.
"""

from __future__ import annotations

import argparse
import json
import shutil
import time
from pathlib import Path
from typing import Any

import numpy as np

from modquad_gym.core.options import int_option
from modquad_gym.core.outputs import (
    OutputError,
    check_output_dir,
    claim_output_dir,
    write_csv,
    write_text,
)
from modquad_gym.policy.inference import export

EXIT_SEED0 = 7_000_000
"""Training draws of the expert iteration (held-out scale tasks use 5,000,000 + ..., validation
draws 6,000,000 + ..., both as single integers)."""
FAMILIES = ("planted", "torque")
SIZES = (8, 32)
BANDS = (16, 24, 32)
"""Validation bands the rounds are scored on."""
CLONE = {"epochs": 25, "batch_size": 64, "learning_rate": 3e-4}
OUTPUTS = ("model.zip", "model_actor.npz", "config.json", "rows.csv", "report.md", "labels.csv")
"""The files of ``--out`` besides the rounds' folders ``round-R``."""
INTEGER = int_option(-(2**63), 2**63)


def training_task(seed: int, round_: int, i: int):
    """Training task ``i`` of round ``round_``: family by parity, 8-32 modules."""
    from modquad_gym.scoring.scale_tasks import FAMILIES as DRAWS

    rng = np.random.default_rng([EXIT_SEED0, seed, round_, i])
    family = FAMILIES[i % len(FAMILIES)]
    n = int(rng.integers(SIZES[0], SIZES[1] + 1))
    task = DRAWS[family][0](n, rng)
    return type(task)(task.wrenches, name=f"exit-{round_}-{i}-{family}-{n}", f_max=task.f_max,
                      kind=task.kind, meta={"family": family, "planted": n})  # fmt: skip


def label_chunk(job: tuple) -> tuple[Any, list[dict]]:
    """One worker's tasks: each solved by the default search and the policy's guided search,
    one expert episode towards the smaller answer and, with ``learner``, the learner's own
    episode labelled towards it (:func:`agents.dagger.learner_states`, greedy's completion off
    it). (demonstrations, one row per task)."""
    from agents.dagger import learner_states
    from agents.imitation import collect, merge
    from modquad_gym.policy.guided import GuidedSolver
    from modquad_gym.policy.policy import Policy
    from modquad_gym.search import anytime_search

    model, tasks, n_max, search_seconds, budget, seed, learner = job
    policy = Policy(model, n_max=n_max)
    parts, rows = [], []
    for k, task in enumerate(tasks):
        search = anytime_search(task, n_max=n_max, time_limit=search_seconds)
        guided = GuidedSolver(policy, budget=budget).solve(task)
        single = policy.env.structure.n_modules if policy.rollout(task)["success"] else None
        found = [r for r in (search, guided) if r.structure is not None]
        rows.append({"task": task.name, "family": task.meta["family"],
                     "planted": task.meta["planted"], "search": search.n_modules,
                     "bound": search.lower_bound, "guided": guided.n_modules,
                     "ppo": single, "target": None})  # fmt: skip
        if not found:
            continue
        best = min(found, key=lambda r: (r.n_modules, r is guided))
        rows[-1]["target"] = best.n_modules
        target = (best.n_modules, [best.structure.key])
        expert = lambda task, n_max, palette, t=target: t  # noqa: E731
        parts.append(collect(policy.env, [task], n_max, seed=[*seed, k], expert=expert))
        if learner:  # the learner's own states: towards the target, else greedy's completion
            states, _ = learner_states(policy.net, policy.env, [task], n_max, seed=[*seed, k],
                                       expert=expert, completion="greedy")  # fmt: skip
            parts.append(states)
    return (merge(parts) if parts else None), rows


def replay_demos(model: str, n_max: int, n_tasks: int, seed: int):
    """Certified demonstrations of ``n_tasks`` training tasks of the current tier (the default
    model's task source, 7 modules; draws ``default_rng([EXIT_SEED0, seed, 0])``, never a
    validation or held-out seed) in the environment of ``n_max``: cloned beside the scale
    states, so the small tasks the model was trained on are not forgotten."""
    from agents.imitation import collect
    from modquad_gym.policy.policy import Policy
    from modquad_gym.tasks import make_generator

    generate, rng = make_generator("mixed"), np.random.default_rng([EXIT_SEED0, seed, 0])
    tasks = [generate(rng) for _ in range(n_tasks)]
    return collect(Policy(model, n_max=n_max).env, tasks, 7, seed=[EXIT_SEED0, seed, 1])


def load_for_training(model: Path, n_max: int):
    """The MaskablePPO at ``model`` with the spaces of the environment at ``n_max`` (a
    size-free policy: the same weights act at any size)."""
    from sb3_contrib import MaskablePPO

    from modquad_gym.policy.policy import Policy

    env = Policy(model, n_max=n_max).env
    spaces = {"observation_space": env.observation_space, "action_space": env.action_space}
    return MaskablePPO.load(str(model), custom_objects=spaces, device="cpu")


def score(model: Path, n_max: int, per_family: int) -> list[dict]:
    """Single-pass ``ppo`` of ``model`` and ``greedy`` on the validation draws of
    :data:`BANDS` (``per_family`` tasks per family and band)."""
    from modquad_gym.scoring.scale_tasks import draw
    from modquad_gym.search import greedy_search, verified
    from modquad_gym.solvers import make_solver

    ppo = make_solver("ppo", n_max=n_max, model=str(model))
    rows = []
    for band in BANDS:
        for family in FAMILIES:
            for i in range(per_family):
                task = draw(family, band, i, validation=True)
                mine, rule = ppo.solve(task), greedy_search(task, n_max=n_max, time_limit=60)
                rows.append({"task": task.name, "family": family, "band": band,
                             "ppo": mine.n_modules if verified(mine.structure, task) else None,
                             "greedy": rule.n_modules, "ppo_s": round(mine.seconds, 2),
                             "greedy_s": round(rule.seconds, 2)})  # fmt: skip
    return rows


def current_tier(model: Path, tasks: list) -> dict:
    """Single-pass ``ppo`` of ``model`` on the current tier's validation tasks (certified
    optima): optimal and success shares, so a round that forgets the small tasks shows it."""
    from modquad_gym.search import verified
    from modquad_gym.solvers import make_solver

    ppo = make_solver("ppo", n_max=7, model=str(model))
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


def run(args: argparse.Namespace) -> list[dict]:
    """The rounds (module docstring); one summary row per model (round 0: the start model)."""
    from agents.imitation import clone, merge
    from agents.training import shown
    from modquad_gym.core.distributed import map_tasks
    from modquad_gym.scoring.tiers import get_tier, validation_suite

    model = Path(args.model)
    small = validation_suite(get_tier("current"), progress=False)
    demos = replay_demos(str(model), args.n_max, args.replay, args.seed) if args.replay else None
    labels, rows = [], []
    rows.append(
        {
            "round": 0,
            "model": shown(model).as_posix(),
            "states": 0,
            "label_s": 0,
            "clone_s": 0,
            "greedy_good": "",
            **summary(score(model, args.n_max, args.per_family)),
            **current_tier(model, small),
        }  # fmt: skip
    )
    print(rows[-1], flush=True)
    for r in range(1, args.rounds + 1):
        t0 = time.perf_counter()
        tasks = [training_task(args.seed, r, i) for i in range(args.tasks)]
        chunks = [tasks[w :: args.workers] for w in range(args.workers)]
        jobs = [(str(model), c, args.n_max, args.search_seconds, args.budget, [args.seed, r, w],
                 args.learner) for w, c in enumerate(chunks) if c]  # fmt: skip
        parts = map_tasks(label_chunk, jobs, workers=args.workers)
        labels += [{"round": r, **row} for _, chunk in parts for row in chunk]
        demos = merge([d for d in [demos, *(part for part, _ in parts)] if d is not None])
        labelled = time.perf_counter() - t0
        ppo = load_for_training(model, args.n_max)
        history = clone(ppo, demos, seed=args.seed + r, **{**CLONE, "epochs": args.epochs})
        model = args.claim.path(f"round-{r}/model.zip")
        model.parent.mkdir(parents=True, exist_ok=True)
        ppo.save(str(model))
        export(model)  # its actor in NumPy: the scoring below and later solvers act without torch
        args.claim.path(f"round-{r}/config.json")
        write_config(model.parent, args, r, len(demos))
        cloned = time.perf_counter() - t0 - labelled
        rows.append({"round": r, "model": shown(model).as_posix(), "states": len(demos),
                     "label_s": round(labelled), "clone_s": round(cloned),
                     "greedy_good": round(history[-1]["greedy_good"], 3),
                     **summary(score(model, args.n_max, args.per_family)),
                     **current_tier(model, small)})  # fmt: skip
        print(rows[-1], flush=True)
    write_csv(labels, args.claim.path("labels.csv"))
    args.labels = labels
    return rows


def write_config(folder: Path, args: argparse.Namespace, round_: int, states: int) -> None:
    """The start model's config.json with this round's environment and recipe."""
    from agents.training import shown
    from modquad_gym.policy.models import read_model

    config = dict(read_model(args.model).config)
    config["env_kwargs"] = {**config.get("env_kwargs", {}), "n_max": args.n_max}
    config["expert_iteration"] = {
        "command": " ".join(["python -m agents.expert_iteration", *args.argv]),
        "round": round_, "rounds": args.rounds, "states": states,
        "start": shown(args.model).as_posix(), "tasks_per_round": args.tasks,
        "search_seconds": args.search_seconds,
        "budget": args.budget, "seed": args.seed, **CLONE, "epochs": args.epochs,
        "learner": args.learner, "replay": args.replay,
    }  # fmt: skip
    write_text(folder / "config.json", json.dumps(config, indent=2) + "\n")


def label_summary(labels: list[dict]) -> list[dict]:
    """Per round, on its training tasks: mean modules of the default search, the guided search,
    the single pass and the target (each over the tasks it solved), and how often the guided
    search's answer was the smaller one."""

    def mean(rs, key):
        xs = [int(r[key]) for r in rs if r.get(key) not in (None, "", "None")]
        return round(float(np.mean(xs)), 2) if xs else ""

    out = []
    for r in sorted({int(row["round"]) for row in labels}):
        rs = [row for row in labels if int(row["round"]) == r]
        won = sum(mean([x], "guided") != "" and mean([x], "search") != ""
                  and int(x["guided"]) < int(x["search"]) for x in rs)  # fmt: skip
        out.append({"round": r, "tasks": len(rs), "search": mean(rs, "search"),
                    "guided": mean(rs, "guided"), "ppo": mean(rs, "ppo"),
                    "target": mean(rs, "target"), "guided_smaller": won})  # fmt: skip
    return out


def report(
    rows: list[dict], args: argparse.Namespace, seconds: float, labels: list[dict] = ()
) -> str:
    from modquad_gym.scoring import machine_description, markdown_table

    return "\n".join([
        "# Expert iteration at 8-32 modules",
        "",
        f"Made by `python -m agents.expert_iteration {' '.join(args.argv)}` on "
        f"{machine_description()} in {seconds / 60:.1f} min.",
        "",
        "Round 0 is the start model. Each later round: the training tasks' labels (the "
        "smaller of the default search's and the guided search's answer), one expert episode "
        "each"
        + (", the learner's own episode labelled towards the label or greedy's completion"
           if args.learner else "")
        + (f", {args.replay} replayed current-tier episodes" if args.replay else "")
        + "; the policy cloned on all rounds' states. Every model is scored single pass "
        f"(`ppo`) against `greedy` on the validation draws of {', '.join(FAMILIES)} at "
        f"{', '.join(map(str, BANDS))} modules ({args.per_family} per family and band), "
        f"n_max {args.n_max}. `fewer`/`equal`/`more`: tasks where ppo used fewer, as many or more "
        "modules than greedy, of those both solved; `current_optimal`/`current_success`: on "
        "the current tier's 40 validation tasks (n_max 7).",
        "",
        markdown_table(rows),
        "",
        "On each round's training tasks (`labels.csv`): mean modules of the default search "
        f"({args.search_seconds:g} s), the current policy's guided search and single pass, and "
        "of the target (the smaller); `guided_smaller`: tasks where the guided search's answer "
        "was the target.",
        "",
        markdown_table(label_summary(list(labels))),
        "",
    ])  # fmt: skip


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    """The options, each checked before any work (argparse's usage and one error line, exit 2);
    the start model is loaded once to check it."""
    import sys

    from modquad_gym.cli.common import time_limit_option
    from modquad_gym.core.options import int_option, seed_option
    from modquad_gym.policy.models import DEFAULT_MODEL, read_model

    count = int_option(1, 1_000_000)
    p = argparse.ArgumentParser(
        prog="python -m agents.expert_iteration", description=__doc__.split("\n\n")[0]
    )
    p.add_argument(
        "--model", type=Path, default=DEFAULT_MODEL, help="start model (default: shipped)"
    )
    p.add_argument("--rounds", type=int_option(1, 1000), default=2,
                   help="expert-iteration rounds, 1 to 1000 (default 2)")  # fmt: skip
    p.add_argument("--tasks", type=count, default=48, help="training tasks per round (default 48)")
    p.add_argument("--search-seconds", type=time_limit_option, default=4.0, metavar="SECONDS",
                   help="default search per task, in (0, 86400] (default 4)")  # fmt: skip
    p.add_argument(
        "--budget", type=count, default=64, help="guided search's structures per task (64)"
    )
    p.add_argument("--epochs", type=count, default=CLONE["epochs"],
                   help=f"cloning epochs per round (default {CLONE['epochs']})")  # fmt: skip
    p.add_argument("--n-max", type=int_option(SIZES[1], 128), default=40,
                   help=f"module budget, {SIZES[1]} (the largest task) to 128 "
                        "(default 40)")  # fmt: skip
    p.add_argument("--per-family", type=int_option(1, 1000), default=3,
                   help="validation draws per family and band (3)")  # fmt: skip
    p.add_argument("--workers", type=int_option(1, 256), default=2,
                   help="labelling processes (default 2)")  # fmt: skip
    p.add_argument(
        "--learner",
        action=argparse.BooleanOptionalAction,
        default=True,
        help="also label the states of the learner's own episode: towards the "
        "target while it fits, else towards greedy's completion (default on)",
    )
    p.add_argument(
        "--replay",
        type=INTEGER,
        default=800,
        help="certified demonstrations of this "
        "many current-tier training tasks cloned beside the scale states (default 800)",
    )
    p.add_argument("--seed", type=seed_option, default=0, help="seed, 0 to 2**63-1 (default 0)")
    p.add_argument("--out", type=Path, default=Path("runs/exit"))
    p.add_argument(
        "--force",
        action="store_true",
        help="replace the files an earlier run wrote into --out (nothing else there)",
    )
    args = p.parse_args(argv)
    args.argv = list(sys.argv[1:] if argv is None else argv)
    if args.replay < 0:
        p.error(f"--replay {args.replay}: give a number of tasks, 0 or more")
    try:
        check_output_dir(args.out, output_names(args.rounds), args.force)
        read_model(args.model)
    except ValueError as exc:  # OutputError too
        p.error(str(exc) if isinstance(exc, OutputError) else f"--model {args.model}: {exc}")
    return args


def output_names(rounds: int) -> tuple[str, ...]:
    """What a run of ``rounds`` rounds writes into ``--out``."""
    return (*OUTPUTS, *(f"round-{r}" for r in range(1, rounds + 1)))


def main(argv: list[str] | None = None) -> int:
    args = parse_args(argv)
    with claim_output_dir(args.out, output_names(args.rounds), args.force) as claim:
        args.claim = claim
        t0 = time.perf_counter()
        rows = run(args)
        for name in ("model.zip", "model_actor.npz", "config.json"):  # OUT: the last round's
            shutil.copy2(args.out / f"round-{args.rounds}" / name, claim.path(name))
        write_csv(rows, claim.path("rows.csv"))
        text = report(rows, args, time.perf_counter() - t0, args.labels)
        write_text(claim.path("report.md"), text)
    print(f"wrote {args.out / 'report.md'}")
    return 0


if __name__ == "__main__":
    from benchmarks.common import run_command

    raise SystemExit(run_command(main, "python -m agents.expert_iteration"))
