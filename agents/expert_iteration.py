"""Expert iteration at the field's sizes: the policy cloned towards the best structure that the
default search or its own guided search finds, round after round (ExIt; issue 36, item 2).

    python -m agents.expert_iteration [--rounds 2] [--tasks 48] [--out runs/exit]

Where the certified search cannot go, the labels come from search: in round r, ``tasks`` fresh
training tasks of the one-type scale families (``--draws``: ``planted``, ``torque`` (low force,
high torque) or ``payload``, :mod:`benchmarks.scale_suites`; default 8-32 modules of planted and
torque), drawn from ``default_rng([EXIT_SEED0, seed, r, i])`` (never a held-out or validation
seed), are solved by the default search (``--search-seconds``), the current policy's guided
search and, with ``--greedy``, greedy; the smallest verified structure is the target. An expert
episode towards it (:mod:`.imitation`, n_max ``--n-max``, the exact lookahead) gives labelled
states, the learner's own episode more (``--learner``, DAgger: towards the target while its
structure fits in it, else towards greedy's completion of what it built), ``--replay`` certified
episodes of the current tier's training tasks keep the small tasks in view, and the policy is
cloned on every round's states so far; as it improves, so do its guided search and the targets.
A run continues another from its model (``--model OUT/model.zip --first-round R``: fresh draws,
its model kept, not its states). Each round's model is saved in ``OUT/round-R/`` (size-free: it
acts at any n_max) and scored by ``ppo`` beside greedy on validation draws of the same families
(``--bands``), and single pass on the current tier's validation tasks: ``OUT/report.md``,
``OUT/rows.csv``; ``OUT/labels.csv`` every label; ``OUT/model.zip`` the last.
"""

from __future__ import annotations

import argparse
import json
import shutil
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np

from agents.exit_checks import MAX_REPLAY, REPLAY_N_MAX, check_start
from agents.scale_scores import current_tier, report, score, summary
from benchmarks.common import Distinct
from modquad_gym.core.options import OneLineParser, int_option, path_option
from modquad_gym.core.outputs import (
    OutputError,
    check_output_dir,
    claim_output_dir,
    write_csv,
    write_text,
)
from modquad_gym.policy.inference import export
from modquad_gym.policy.models import UNTRUSTED

EXIT_SEED0 = 7_000_000
"""Training draws of the expert iteration (held-out scale tasks use 5,000,000 + ..., validation
draws 6,000,000 + ..., both as single integers)."""
FAMILIES = ("planted", "torque")
SIZES = (8, 32)
DRAWS = tuple((family, *SIZES) for family in FAMILIES)
"""Default training draws: (family, fewest, most planted modules), taken in turn (task ``i``
from entry ``i % len``: an entry given twice is drawn twice as often)."""
BANDS = (16, 24, 32)
"""Validation bands the rounds are scored on."""
CLONE = {"epochs": 25, "batch_size": 64, "learning_rate": 3e-4}
INTEGER = int_option(-(2**63), 2**63)
OUTPUTS = ("model.zip", "model_actor.npz", "config.json", "rows.csv", "report.md", "labels.csv")
"""The files of ``--out`` besides the rounds' folders ``round-R``."""


def training_task(seed: int, round_: int, i: int, draws=DRAWS):
    """Training task ``i`` of round ``round_``: entry ``i % len(draws)`` of ``draws`` (family,
    fewest and most planted modules; :data:`DRAWS`)."""
    from modquad_gym.scoring.scale_tasks import FAMILIES as MAKERS

    rng = np.random.default_rng([EXIT_SEED0, seed, round_, i])
    family, low, high = draws[i % len(draws)]
    n = int(rng.integers(low, high + 1))
    task = MAKERS[family][0](n, rng)
    return type(task)(task.wrenches, name=f"exit-{round_}-{i}-{family}-{n}", f_max=task.f_max,
                      kind=task.kind, meta={"family": family, "planted": n})  # fmt: skip


def label_chunk(job: tuple) -> tuple[Any, list[dict]]:
    """One worker's tasks: each solved by the default search and the policy's guided search
    (with ``greedy``, by greedy too, which wins ties: the policy keeps what greedy has unless
    a search finds better), one expert episode towards the smallest answer and, with
    ``learner``, the learner's own episode labelled towards it
    (:func:`agents.dagger.learner_states`, greedy's completion off it). (demonstrations, one
    row per task)."""
    from agents.dagger import learner_states
    from agents.imitation import collect, merge
    from modquad_gym.policy.guided import GuidedSolver
    from modquad_gym.policy.policy import Policy
    from modquad_gym.search import anytime_search, greedy_search

    model, tasks, n_max, search_seconds, budget, seed, learner, with_greedy = job
    policy = Policy(model, n_max=n_max)
    parts, rows = [], []
    for k, task in enumerate(tasks):
        rule = greedy_search(task, n_max=n_max, time_limit=60) if with_greedy else None
        search = anytime_search(task, n_max=n_max, time_limit=search_seconds)
        guided = GuidedSolver(policy, budget=budget).solve(task)
        single = policy.env.structure.n_modules if policy.rollout(task)["success"] else None
        found = [r for r in (rule, search, guided) if r is not None and r.structure is not None]
        rows.append({"task": task.name, "family": task.meta["family"],
                     "planted": task.meta["planted"], "search": search.n_modules,
                     "bound": search.lower_bound, "guided": guided.n_modules,
                     "greedy": rule.n_modules if rule is not None else None,
                     "ppo": single, "target": None})  # fmt: skip
        if not found:
            continue
        best = min(found, key=lambda r: r.n_modules)  # ties: the first (greedy, then search)
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
    env = Policy(model, n_max=n_max).env
    return collect(env, tasks, REPLAY_N_MAX, seed=[EXIT_SEED0, seed, 1])


def load_for_training(model: Path, n_max: int):
    """The MaskablePPO at ``model`` with the spaces of the environment at ``n_max`` (a
    size-free policy: the same weights act at any size), naming no TensorBoard folder."""
    from sb3_contrib import MaskablePPO

    from modquad_gym.policy.policy import Policy

    env = Policy(model, n_max=n_max).env
    spaces = {"observation_space": env.observation_space, "action_space": env.action_space}
    return MaskablePPO.load(str(model), custom_objects=spaces, device="cpu", tensorboard_log=None)


def run(args: argparse.Namespace) -> list[dict]:
    """The rounds (module docstring); one summary row per model (round 0: the start model)."""
    from agents.imitation import clone, merge
    from agents.training import shown
    from modquad_gym.core.distributed import map_tasks
    from modquad_gym.scoring.tiers import get_tier, validation_suite

    model = Path(args.model)
    small = validation_suite(get_tier("current"), progress=False)
    demos = replay_demos(str(model), args.n_max, args.replay, args.seed) if args.replay else None
    families = list(dict.fromkeys(family for family, _, _ in args.draws))
    scores = lambda m: summary(score(m, args.n_max, args.per_family, args.bands, families))  # noqa: E731
    labels, rows = [], []
    if args.score_start:
        rows.append({"round": 0, "model": shown(model).as_posix(), "states": 0, "label_s": 0,
                     "clone_s": 0, "greedy_good": "", **scores(model),
                     **current_tier(model, small)})  # fmt: skip
        print(rows[-1], flush=True)
    for r in rounds(args):
        t0 = time.perf_counter()
        tasks = [training_task(args.seed, r, i, args.draws) for i in range(args.tasks)]
        chunks = [tasks[w :: args.workers] for w in range(args.workers)]
        jobs = [(str(model), c, args.n_max, args.search_seconds, args.budget, [args.seed, r, w],
                 args.learner, args.greedy) for w, c in enumerate(chunks) if c]  # fmt: skip
        parts = map_tasks(label_chunk, jobs, workers=args.workers)
        labels += [{"round": r, **row} for _, chunk in parts for row in chunk]
        demos = merge([d for d in [demos, *(part for part, _ in parts)] if d is not None])
        labelled = time.perf_counter() - t0
        ppo = load_for_training(model, args.n_max)
        history = clone(ppo, demos, seed=args.seed + r, **recipe(args))
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
                     **scores(model), **current_tier(model, small)})  # fmt: skip
        print(rows[-1], flush=True)
    write_csv(labels, args.claim.path("labels.csv"))
    args.labels = labels
    return rows


def recipe(args: argparse.Namespace) -> dict:
    """The cloning recipe of each round: :data:`CLONE` with the run's epochs and rate."""
    rate = getattr(args, "learning_rate", CLONE["learning_rate"])
    return {**CLONE, "epochs": args.epochs, "learning_rate": rate}


def rounds(args: argparse.Namespace) -> range:
    """The rounds this run makes (``--first-round`` on): a later run that starts from an
    earlier one's model continues its numbering, so its training draws are fresh."""
    return range(args.first_round, args.first_round + args.rounds)


def write_config(folder: Path, args: argparse.Namespace, round_: int, states: int) -> None:
    """The start model's config.json with this round's environment and recipe."""
    from agents.training import shown
    from modquad_gym.policy.models import read_model

    config = dict(read_model(args.model).config)
    earlier = config.get("expert_iteration")  # a warm start: how its start model was made
    config["env_kwargs"] = {**config.get("env_kwargs", {}), "n_max": args.n_max}
    config["expert_iteration"] = {
        "command": " ".join(["python -m agents.expert_iteration", *args.argv]),
        "round": round_, "rounds": args.rounds, "states": states,
        "start": shown(args.model).as_posix(), "tasks_per_round": args.tasks,
        "search_seconds": args.search_seconds,
        "budget": args.budget, "seed": args.seed, **recipe(args),
        "learner": args.learner, "replay": args.replay,
        "draws": [f"{f}:{lo}-{hi}" for f, lo, hi in getattr(args, "draws", DRAWS)],
        "greedy_labels": getattr(args, "greedy", False),
        **({"start_made_by": earlier} if earlier else {}),
    }  # fmt: skip
    write_text(folder / "config.json", json.dumps(config, indent=2) + "\n")


def draw_option(text: str) -> tuple[str, int, int]:
    """``FAMILY:LOW-HIGH`` -> (family, low, high); argparse reports a ValueError's message."""
    family, _, sizes = text.partition(":")
    low, _, high = (sizes if sizes.isascii() else "").partition("-")  # ASCII digits only
    if family not in ("planted", "torque", "payload"):
        raise argparse.ArgumentTypeError(f"{text}: family planted, torque or payload")
    if not (low.isdecimal() and high.isdecimal() and 2 <= int(low) <= int(high) <= 128):
        raise argparse.ArgumentTypeError(f"{text}: sizes LOW-HIGH with 2 <= LOW <= HIGH <= 128")
    return family, int(low), int(high)


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    """The options, each checked before any work (one error line, exit 2);
    the start model is loaded once to check it."""
    p = OneLineParser(
        prog="python -m agents.expert_iteration", description=__doc__.split("\n\n")[0]
    )
    _round_options(p)
    _draw_options(p)
    _run_options(p)
    args = p.parse_args(argv)
    args.argv = list(sys.argv[1:] if argv is None else argv)
    _check_args(p, args)
    return args


def _round_options(p: argparse.ArgumentParser) -> None:
    """What one round does: its start model, tasks, searches and cloning."""
    from modquad_gym.cli.common import time_limit_option
    from modquad_gym.core.options import real_option
    from modquad_gym.policy.models import DEFAULT_MODEL

    count = int_option(1, 1_000_000)
    p.add_argument(
        "--model", type=path_option, default=DEFAULT_MODEL, help="start model (default: shipped)"
    )
    p.add_argument("--rounds", type=int_option(1, 1000), default=2,
                   help="expert-iteration rounds, 1 to 1000 (default 2)")  # fmt: skip
    p.add_argument("--tasks", type=count, default=48, help="training tasks per round (default 48)")
    p.add_argument("--search-seconds", type=time_limit_option, default=4.0, metavar="SECONDS",
                   help="default search per task, in (0, 86400] (default 4)")  # fmt: skip
    p.add_argument(
        "--budget", type=count, default=64, help="guided search's structures per task (default 64)"
    )
    p.add_argument("--epochs", type=count, default=CLONE["epochs"],
                   help=f"cloning epochs per round (default {CLONE['epochs']})")  # fmt: skip
    p.add_argument("--learning-rate", type=real_option, default=CLONE["learning_rate"],
                   help=f"cloning learning rate (default {CLONE['learning_rate']:g}; smaller "
                        "for a warm start that should move less)")  # fmt: skip
    p.add_argument("--n-max", type=int_option(8, 128), default=40,
                   help="module budget of the labelling environment, 8 to 128 (default 40; "
                        "a task with no structure within it gives no label)")  # fmt: skip


def _draw_options(p: argparse.ArgumentParser) -> None:
    """Which tasks are drawn and labelled, and where the models are scored."""
    p.add_argument(
        "--draws",
        type=draw_option,
        nargs="+",
        default=list(DRAWS),
        metavar="FAMILY:LOW-HIGH",
        help="training draws taken in turn: a one-type scale family (planted, "
        "torque, payload) and its planted sizes, 2 to 128; one given twice "
        "is drawn twice as often (default planted:8-32 torque:8-32)",
    )
    p.add_argument(
        "--greedy",
        action=argparse.BooleanOptionalAction,
        default=False,
        help="also solve each training task by greedy and count its answer among "
        "the labels, first on ties (default off)",
    )
    p.add_argument(
        "--bands",
        type=int_option(2, 128),
        nargs="+",
        action=Distinct,  # each band's draws would be scored twice
        default=list(BANDS),
        help="validation bands each model is scored on (default 16 24 32)",
    )
    p.add_argument(
        "--first-round",
        type=int_option(1, 1_000_000),
        default=1,
        help="number of this run's first round: continue an earlier run from its "
        "model (--model) with fresh draws (default 1)",
    )
    p.add_argument(
        "--score-start",
        action=argparse.BooleanOptionalAction,
        default=True,
        help="score the start model too, as round 0 (default on)",
    )
    p.add_argument("--per-family", type=int_option(1, 1000), default=3,
                   help="validation draws per family and band (default 3)")  # fmt: skip
    p.add_argument("--trust-model", action="store_true", help="train a --model that is not "
                   f"shipped, which unpickles it ({UNTRUSTED}): only a file you trust")  # fmt: skip


def _run_options(p: argparse.ArgumentParser) -> None:
    """How the run labels (workers, the learner's states, replay), its seed and its folder."""
    from modquad_gym.core.options import seed_option

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
        help="certified demonstrations of this many current-tier training tasks cloned beside "
        f"the scale states, 0 to {MAX_REPLAY:,} and what memory holds (default 800)",
    )
    p.add_argument("--seed", type=seed_option, default=0, help="seed, 0 to 2**63-1 (default 0)")
    p.add_argument("--out", type=path_option, default=Path("runs/exit"),
                   help="run folder (default runs/exit)")  # fmt: skip
    p.add_argument(
        "--force",
        action="store_true",
        help="replace the files an earlier run wrote into --out (nothing else there)",
    )


def _check_args(p: argparse.ArgumentParser, args: argparse.Namespace) -> None:
    """What argparse cannot check alone: ranges across options, ``--out``, the start model
    (loaded once, at ``--n-max``, and trusted) and the replay's memory; each failure is
    ``p.error``'s one line and exit 2."""
    from modquad_gym.policy.models import check_trusted

    if not 0 < args.learning_rate <= 1:
        p.error(f"--learning-rate {args.learning_rate:g}: give a rate in (0, 1]")
    if not 0 <= args.replay <= MAX_REPLAY:
        p.error(f"--replay {args.replay}: give a number of tasks, 0 to {MAX_REPLAY:,}")
    try:
        check_output_dir(args.out, output_names(args), args.force)
        check_start(args.model, args.n_max, args.replay)
        check_trusted(args.model, args.trust_model, "--model", "training it further")
    except ValueError as exc:  # OutputError and ResourceError too
        named = isinstance(exc, OutputError) or str(exc).startswith(("--model", "--replay"))
        p.error(str(exc) if named else f"--model {args.model}: {exc}")


def output_names(args: argparse.Namespace) -> tuple[str, ...]:
    """What a run writes into ``--out``."""
    return (*OUTPUTS, *(f"round-{r}" for r in rounds(args)))


def main(argv: list[str] | None = None) -> int:
    args = parse_args(argv)
    with claim_output_dir(args.out, output_names(args), args.force) as claim:
        args.claim = claim
        t0 = time.perf_counter()
        rows = run(args)
        for name in ("model.zip", "model_actor.npz", "config.json"):  # OUT: the last round's
            shutil.copy2(args.out / f"round-{rounds(args)[-1]}" / name, claim.path(name))
        write_csv(rows, claim.path("rows.csv"))
        text = report(rows, args, time.perf_counter() - t0, args.labels, rounds(args))
        write_text(claim.path("report.md"), text)
    print(f"wrote {args.out / 'report.md'}")
    return 0


if __name__ == "__main__":
    from benchmarks.common import run_command

    raise SystemExit(run_command(main, "python -m agents.expert_iteration"))
