"""Speed of ModQuadAssembly-v0: steps per second with random masked actions, a fresh task every
episode, in one process pinned to one core; and the cost per step as a function of task size t.

Run ``python -m benchmarks.env`` (``--help`` for options). Writes
``results/env_benchmark.md`` and ``results/env_benchmark.csv``.

What is timed: ``env.step`` and ``env.reset`` (which draws a fresh task from the generator) on the
unwrapped environment, with the random choice among valid actions included. Each row first runs
``--warmup`` steps (reported as the cold rate: zonotopes and supports of new structures are built
then) and then times ``--steps`` steps with the per-structure caches warm, which is the regime of
training (there are only 1,067 structures of at most 7 modules up to translation).

The "resets counted" row times the default configuration as a user gets it,
``gym.make("modquad_gym:ModQuadAssembly-v0")`` (default task source, wrappers included), with
random masked actions read from the observation, every ``reset`` inside the timed loop and its
cost reported apart. Next to it, one MaskablePPO update (``.train()`` on a 256-step rollout of the
same env, the hyperparameters of ``train.py``) is timed in the same run, so the env's cost can be
read against the learner's.

The lookahead table (``--lookahead-steps``) times the default env id with each ``lookahead``
(off, the support rows, ``"exact"``: the exact one-step lookahead of every child) in the same
run, resets counted, and gives each as a ratio to the default (off), at each n_max of
``--lookahead-n-max`` (beyond 7 on tasks planted in n_max / 4 to n_max modules, as the scale
benchmarks; the grid encoding, as the learned solvers act).

The encodings table (``--scale``, :mod:`benchmarks.env_scale`) compares the grid and the
free-faces action encodings at n_max 16, 32 and 64, resets counted (issue 26's goal: 2,000
steps/s at n_max 64 on one core).
"""

from __future__ import annotations

import argparse
from pathlib import Path

from benchmarks.common import (
    Distinct,
    HelpFormatter,
    add_force,
    machine_description,
    parse_bench_args,
    run_main,
    write_csv,
)
from benchmarks.env_measure import (
    FAMILIES,
    PPO_RECIPE,
    SIZES,
    measure,
    measure_default,
    measure_lookahead,
    pin_to_one_core,
    ppo_update_seconds,
)
from benchmarks.env_report import load_average, report, verdict
from benchmarks.env_scale import ENCODINGS, measure_encoding
from modquad_gym.core.options import OneLineParser, int_option, path_option, seed_option
from modquad_gym.core.outputs import write_text


def parse_args(argv: list[str] | None) -> argparse.Namespace:
    parser = OneLineParser(
        prog="python -m benchmarks.env",
        description=__doc__.split("\n\n")[0],
        formatter_class=HelpFormatter,
    )
    parser.add_argument("--steps", type=int_option(1), default=5000, help="timed steps per row")
    parser.add_argument(
        "--warmup", type=int_option(0), default=5000, help="untimed warm-up steps per row"
    )
    parser.add_argument("--seed", type=seed_option, default=0, help="task seed")
    parser.add_argument(
        "--n-max", type=int_option(2, 16), default=7, help="n_max of the env in the task-size rows"
    )
    parser.add_argument(
        "--sizes", type=int_option(1, 100_000), nargs="*", action=Distinct, default=list(SIZES),
        help="task sizes t to measure",
    )  # fmt: skip
    parser.add_argument(
        "--default-steps", type=int_option(0), default=20000,
        help="timed steps of the default configuration, resets counted (0: skip that row; "
        "default 20000)",
    )  # fmt: skip
    parser.add_argument(
        "--scale", type=int_option(2, 128), nargs="*", action=Distinct, default=[16, 32, 64, 128],
        help="n_max values of the encodings table (grid vs faces; none: skip it)",
    )  # fmt: skip
    parser.add_argument(
        "--scale-steps", type=int_option(1), default=3000, help="timed steps per encodings row"
    )
    parser.add_argument(
        "--scale-warmup", type=int_option(0), default=300, help="untimed steps per encodings row"
    )
    parser.add_argument(
        "--lookahead-steps", type=int_option(0), default=2000,
        help="timed steps per lookahead row (off, support, exact; 0: skip that table)",
    )  # fmt: skip
    parser.add_argument(
        "--lookahead-n-max", type=int_option(2, 128), nargs="+", action=Distinct, default=[7],
        help="n_max values of the lookahead table (timed steps: --lookahead-steps at 7, a "
        "tenth of them beyond)",
    )  # fmt: skip
    parser.add_argument("--no-ppo", action="store_true", help="skip the PPO update timing")
    parser.add_argument("--machine-note", default="", help="said after the machine line")
    parser.add_argument("--out", type=path_option, default=Path("results"), help="report folder")
    add_force(parser)
    args = parse_bench_args(parser, argv, ("env_benchmark.md", "env_benchmark.csv"))
    if not (args.default_steps or args.sizes or args.scale or args.lookahead_steps):
        parser.error(
            "nothing to measure: give --sizes, --scale, --default-steps > 0 or "
            "--lookahead-steps > 0"
        )
    return args


def main(argv: list[str] | None = None) -> list[dict]:
    args = parse_args(argv)
    args.load_start = load_average()
    pinning = pin_to_one_core()
    default = None
    if args.default_steps:
        default = measure_default(args.default_steps, args.warmup, args.seed)
        if not args.no_ppo:
            update_s, _ = ppo_update_seconds(args.seed)
            n = PPO_RECIPE["n_steps"]
            default["ppo_update_ms"] = 1e3 * update_s
            default["env_ms_per_rollout"] = 1e3 * n / default["steps_per_s"]
            default["env_over_update"] = default["env_ms_per_rollout"] / default["ppo_update_ms"]
        print(f"default, resets counted: {default['steps_per_s']:.0f} steps/s", flush=True)
    lookahead = []
    if args.lookahead_steps:
        for n_max in args.lookahead_n_max:
            steps = args.lookahead_steps if n_max <= 7 else max(args.lookahead_steps // 10, 1)
            warmup = min(args.warmup, 500) if n_max <= 7 else min(args.warmup, 50)
            lookahead += measure_lookahead(steps, warmup, args.seed, n_max)
        for row in lookahead:
            print(f"n_max {row['n_max']} lookahead={row['lookahead']}: "
                  f"{row['cpu_steps_per_s']:.0f} steps/CPU s")  # fmt: skip
    rows = []
    for family in FAMILIES:
        for t in args.sizes:
            row = measure(family, t, args.steps, args.warmup, args.seed, args.n_max)
            print(
                f"{family:8s} t={t:4d}: {row['steps_per_s']:8.0f} steps/s "
                f"({row['us_per_step']:.0f} us/step, cold {row['cold_steps_per_s']:.0f}; "
                f"goal {row['goal']})",
                flush=True,
            )
            rows.append(row)
    if rows:
        print(verdict(rows, machine_description()))
    scale = []
    for n_max in args.scale:
        for actions in ENCODINGS:
            row = measure_encoding(actions, n_max, args.scale_steps, args.scale_warmup, args.seed)
            print(
                f"{actions:5s} n_max={n_max:2d}: {row['steps_per_s']:7.0f} steps/s "
                f"({row['cpu_steps_per_s']:.0f} per CPU s, {row['actions']} actions)",
                flush=True,
            )
            scale.append(row)
    every = ([default] if default else []) + lookahead + rows + scale
    keys = list(dict.fromkeys(k for r in every for k in r))  # the default row has its own
    write_csv([{k: r.get(k, "") for k in keys} for r in every], args.out / "env_benchmark.csv")
    text = report(rows, default, scale, args, pinning, lookahead)
    write_text(args.out / "env_benchmark.md", text)
    print(f"wrote {args.out / 'env_benchmark.md'} and {args.out / 'env_benchmark.csv'}")
    return every


if __name__ == "__main__":
    raise SystemExit(run_main(main, "env"))
