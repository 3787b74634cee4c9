"""Algorithms without action masks learn through ``NearestValidAction``: SB3's PPO, A2C and DQN.

Each algorithm trains for ``--steps`` on ``ModQuadAssembly-v0`` (planted tasks) wrapped in
:class:`modquad_gym.envs.wrappers.NearestValidAction`, then plays the held-out planted suite
deterministically (the tasks' certified optima are known). Beside them: uniformly random actions
through the wrapper, and plain PPO *without* the wrapper for the same steps (the failure mode the
wrapper removes). Writes ``OUT/report.md`` and ``OUT/report.csv``, refused before any training
when ``--out`` cannot take them or already holds them (unless ``--force``)::

    python examples/unmasked_sb3.py --steps 20000 --out results/unmasked --force
"""

from __future__ import annotations

import argparse
import contextlib
import shlex
import sys
import time

import gymnasium as gym
import numpy as np

import modquad_gym  # noqa: F401 - registers the environments
from modquad_gym.core.interrupts import run_command
from modquad_gym.core.options import OneLineParser, int_option, path_option, seed_option
from modquad_gym.core.outputs import claim_output_dir, write_csv, write_text
from modquad_gym.envs.wrappers import NearestValidAction
from modquad_gym.scoring.suites import SUITES_DIR
from modquad_gym.tasks import load_suite

ALGOS = ("ppo", "a2c", "dqn")
SUITE = "heldout_planted"
PROG = "python examples/unmasked_sb3.py"
OUTPUTS = ("report.md", "report.csv")


def make_env(wrapped: bool = True) -> gym.Env:
    env = gym.make("ModQuadAssembly-v0", tasks="planted", n_max=7)
    return NearestValidAction(env) if wrapped else env


def train(algo: str, steps: int, seed: int, wrapped: bool = True):
    """An SB3 model of ``algo`` trained for ``steps`` (default hyperparameters, Dict policy)."""
    import torch
    from stable_baselines3 import A2C, DQN, PPO
    from stable_baselines3.common.logger import Logger

    torch.set_num_threads(1)
    cls = {"ppo": PPO, "a2c": A2C, "dqn": DQN}[algo]
    extra = {"learning_starts": 1000, "exploration_fraction": 0.3} if algo == "dqn" else {}
    model = cls("MultiInputPolicy", make_env(wrapped), seed=seed, device="cpu", verbose=0, **extra)
    model.set_logger(Logger(folder=None, output_formats=[]))  # logs nothing: no tmp/SB3-* folder
    return model.learn(total_timesteps=steps)


def play(policy, tasks, wrapped: bool = True, seed: int = 0) -> dict:
    """Each task once: success rate, mean modules, share at the certified optimum, invalid
    actions per episode (``policy(obs, env) -> action``)."""
    env = make_env(wrapped)
    rows = []
    for i, task in enumerate(tasks):
        obs, info = env.reset(seed=seed + i, options={"task": task})
        done, invalid = False, 0
        while not done:
            obs, _, terminated, truncated, info = env.step(policy(obs, env))
            invalid += bool(info["invalid_action"])
            done = terminated or truncated
        optimal = info["is_success"] and info["n_modules"] == task.meta["optimum"]
        rows.append((info["is_success"], info["n_modules"], optimal, invalid))
    env.close()
    success, modules, optimal, invalid = (np.array(c, dtype=float) for c in zip(*rows))
    return {
        "success": success.mean(),
        "modules (successes)": modules[success > 0].mean() if success.any() else float("nan"),
        "optimal": optimal.mean(),
        "invalid actions per episode": invalid.mean(),
    }


def greedy(model):
    """The deterministic policy of an SB3 model, as ``policy(obs, env) -> action``."""
    return lambda obs, env: int(model.predict(obs, deterministic=True)[0])


def parse_args(argv: list[str] | None, n_suite: int) -> argparse.Namespace:
    """The options, every number checked as the command line reads it (argparse's error, exit
    2, before any work)."""
    parser = OneLineParser(prog=PROG, description=__doc__.splitlines()[0])
    parser.add_argument("--algos", nargs="+", choices=ALGOS, default=list(ALGOS))
    parser.add_argument("--steps", type=int_option(1), default=20_000,
                        help="training steps per algorithm (default %(default)s)")  # fmt: skip
    parser.add_argument("--tasks", type=int_option(1, n_suite), default=n_suite,
                        help=f"held-out tasks played, 1..{n_suite} (default all)")  # fmt: skip
    parser.add_argument("--seed", type=seed_option, default=0)
    parser.add_argument("--out", type=path_option, default=None,
                        help="report folder (default: print the report only)")  # fmt: skip
    parser.add_argument("--force", action="store_true",
                        help="replace the reports in --out (default: refuse)")  # fmt: skip
    return parser.parse_args(argv)


def main(argv: list[str] | None = None) -> list[dict]:
    suite = load_suite(SUITES_DIR / f"{SUITE}.json")
    args = parse_args(argv, len(suite))
    tasks = suite[: args.tasks]
    with contextlib.ExitStack() as stack:  # --out claimed before training: refused at once
        claim = None
        if args.out is not None:
            claim = stack.enter_context(claim_output_dir(args.out, OUTPUTS, args.force))
        rng = np.random.default_rng(args.seed)
        runs = [("random actions + wrapper", "none",
                 lambda o, e: int(rng.integers(e.action_space.n)), True)]  # fmt: skip
        for algo in args.algos:
            t0 = time.perf_counter()
            model = train(algo, args.steps, args.seed)
            spent = f"{time.perf_counter() - t0:.0f} s"
            runs.append((f"{algo.upper()} + wrapper", spent, greedy(model), True))
        if "ppo" in args.algos:
            t0 = time.perf_counter()
            plain = train("ppo", args.steps, args.seed, wrapped=False)
            runs.append(("PPO, no wrapper", f"{time.perf_counter() - t0:.0f} s", greedy(plain),
                         False))  # fmt: skip
        table = [{"agent": name, "training": spent, **play(policy, tasks, wrapped, args.seed)}
                 for name, spent, policy, wrapped in runs]  # fmt: skip
        text = report(table, args, argv if argv is not None else sys.argv[1:])
        print(text)
        if claim is not None:
            write_text(claim.path("report.md"), text)
            write_csv(table, claim.path("report.csv"))
    return table


def report(table: list[dict], args, argv: list[str]) -> str:
    """The report's Markdown: the command, what was played, and the table."""
    command = f"{PROG} " + shlex.join(argv)
    keys = list(table[0])
    lines = [
        f"Made by `{command}`.",
        "",
        f"# Unmasked algorithms through NearestValidAction ({args.steps:,} training steps each)",
        "",
        f"Deterministic play of the first {args.tasks} tasks of the held-out suite `{SUITE}` "
        '(certified optima known); training on `ModQuadAssembly-v0` with `tasks="planted"`, '
        f"SB3 defaults, seed {args.seed}, one CPU thread. A machine shared by several users: "
        "times are indicative.",
        "",
        "| " + " | ".join(keys) + " |",
        "|" + "---|" * len(keys),
    ]
    for row in table:
        cells = [f"{v:.3g}" if isinstance(v, float) else str(v) for v in row.values()]
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines) + "\n"


if __name__ == "__main__":
    raise SystemExit(run_command(main, PROG))
