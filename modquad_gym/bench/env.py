"""Speed of ModQuadAssembly-v0: steps per second with random masked actions, a fresh task every
episode, in one process pinned to one core; and the cost per step as a function of task size t.

Run ``python -m modquad_gym.bench.env`` (``--help`` for options). Writes
``results/env_benchmark.md`` and ``results/env_benchmark.csv``.

What is timed: ``env.step`` and ``env.reset`` (which draws a fresh task from the generator) on the
unwrapped environment, with the random choice among valid actions included. Each row first runs
``--warmup`` steps (reported as the cold rate: zonotopes and supports of new structures are built
then) and then times ``--steps`` steps with the per-structure caches warm, which is the regime of
training (there are only 1,067 structures of at most 7 modules up to translation).
"""

from __future__ import annotations

import argparse
import os
import time
from pathlib import Path

import numpy as np

from ..envs import ModQuadAssemblyEnv
from ..outputs import write_text
from ..tasks import PaperTasks, PlantedTasks
from . import machine_description, markdown_table, write_csv

SIZES = (1, 8, 32, 80, 200)
FAMILIES = {"paper": PaperTasks, "planted": PlantedTasks}
TARGET = 5000.0


def run_steps(env: ModQuadAssemblyEnv, n: int, rng: np.random.Generator) -> tuple[float, dict]:
    """Play ``n`` steps with random valid actions (reset on episode end); (seconds, counters)."""
    episodes = invalid = 0
    calls0 = sum(ev.tests for ev in env.evaluators.values())
    start = time.perf_counter()
    for _ in range(n):
        valid = np.flatnonzero(env.state.mask)
        a = int(valid[rng.integers(len(valid))]) if len(valid) else 0
        _, _, term, trunc, info = env.step(a)
        invalid += info["invalid_action"]
        if term or trunc:
            env.reset()
            episodes += 1
    seconds = time.perf_counter() - start
    calls = sum(ev.tests for ev in env.evaluators.values()) - calls0
    return seconds, {"episodes": episodes, "oracle_calls": calls}


def measure(family: str, t: int, steps: int, warmup: int, seed: int, n_max: int) -> dict:
    """One benchmark row: the given task family with exactly t wrenches per task."""
    env = ModQuadAssemblyEnv(tasks=FAMILIES[family](n_wrenches=t), n_max=n_max)
    rng = np.random.default_rng(seed)
    env.reset(seed=seed)
    cold_s, _ = run_steps(env, warmup, rng)
    warm_s, counts = run_steps(env, steps, rng)
    return {
        "tasks": family,
        "t": t,
        "steps_per_s": steps / warm_s,
        "us_per_step": 1e6 * warm_s / steps,
        "cold_steps_per_s": warmup / cold_s if warmup else float("nan"),
        "episodes": counts["episodes"],
        "oracle_tests_per_step": counts["oracle_calls"] / steps,
        "goal": "met" if steps / warm_s >= TARGET else "NOT met",
    }


def pin_to_one_core() -> str:
    """Pin this process to one core (Linux); say which."""
    if hasattr(os, "sched_setaffinity"):
        core = min(os.sched_getaffinity(0))
        os.sched_setaffinity(0, {core})
        return f"pinned to core {core}"
    return "not pinned (no sched_setaffinity on this platform)"


def verdict(rows: list[dict], machine: str) -> str:
    """One line: is the issue's goal (>= TARGET steps/s) met, for which rows, on which machine."""
    met = [f"{r['tasks']} t={r['t']}" for r in rows if r["goal"] == "met"]
    missed = [f"{r['tasks']} t={r['t']}" for r in rows if r["goal"] != "met"]
    if not missed:
        head = f"Goal ({TARGET:,.0f} steps/s): met for every row"
    elif not met:
        head = f"Goal ({TARGET:,.0f} steps/s): NOT met for any row"
    else:
        head = (
            f"Goal ({TARGET:,.0f} steps/s): met for {', '.join(met)}; "
            f"NOT met for {', '.join(missed)}"
        )
    return f"{head} (on {machine})."


def report(rows: list[dict], args: argparse.Namespace, pinning: str) -> str:
    machine = machine_description()
    lines = [
        "# ModQuadAssembly-v0 speed",
        "",
        f"Machine: {machine}; one process, {pinning}.",
        f"Command: `python -m modquad_gym.bench.env --steps {args.steps} --warmup {args.warmup} "
        f"--seed {args.seed} --n-max {args.n_max}`",
        "",
        "Random valid (masked) actions, a fresh task drawn every episode from the family with "
        "exactly t wrenches, unwrapped env (``gym.make`` adds Gymnasium's checker wrappers). "
        "`steps_per_s` is measured after a warm-up of the per-structure caches; "
        "`cold_steps_per_s` is the warm-up itself. `oracle_tests_per_step` counts wrenches sent "
        "to the exact oracle (the others are rejected by the support-function features).",
        "",
        f"Goal of issue 5: at least {TARGET:,.0f} steps/s in one process on one core with random "
        "masked actions and a fresh task every episode (column `goal`).",
        "",
        f"**{verdict(rows, machine)}**",
        "",
        markdown_table(rows),
        "",
    ]
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> list[dict]:
    parser = argparse.ArgumentParser(
        prog="python -m modquad_gym.bench.env", description=__doc__.split("\n\n")[0]
    )
    parser.add_argument("--steps", type=int, default=5000, help="timed steps per row")
    parser.add_argument("--warmup", type=int, default=5000, help="untimed warm-up steps per row")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--n-max", type=int, default=7)
    parser.add_argument(
        "--sizes", type=int, nargs="+", default=list(SIZES), help="task sizes t to measure"
    )
    parser.add_argument("--out", type=Path, default=Path("results"), help="report folder")
    args = parser.parse_args(argv)
    if args.steps < 1 or args.warmup < 0:
        parser.error("--steps must be >= 1 and --warmup >= 0")
    pinning = pin_to_one_core()
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
    print(verdict(rows, machine_description()))
    write_csv(rows, args.out / "env_benchmark.csv")
    write_text(args.out / "env_benchmark.md", report(rows, args, pinning))
    print(f"wrote {args.out / 'env_benchmark.md'} and {args.out / 'env_benchmark.csv'}")
    return rows


if __name__ == "__main__":
    main()
