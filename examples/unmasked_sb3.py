"""Algorithms without action masks learn through ``NearestValidAction``: SB3's PPO, A2C and DQN.

Each algorithm trains for ``--steps`` on ``ModQuadAssembly-v0`` (planted tasks) wrapped in
:class:`modquad_gym.envs.wrappers.NearestValidAction`, then plays the held-out planted suite
deterministically (the tasks' certified optima are known). Beside them: uniformly random actions
through the wrapper, and plain PPO *without* the wrapper for the same steps (the failure mode the
wrapper removes). Writes ``OUT/report.md`` and ``OUT/report.csv``::

    python examples/unmasked_sb3.py --steps 30000 --out results/unmasked
"""

from __future__ import annotations

import argparse
import csv
import shlex
import sys
import time
from pathlib import Path

import gymnasium as gym
import numpy as np

import modquad_gym  # noqa: F401 - registers the environments
from modquad_gym.envs.wrappers import NearestValidAction
from modquad_gym.scoring.suites import SUITES_DIR
from modquad_gym.tasks import load_suite

ALGOS = ("ppo", "a2c", "dqn")
SUITE = "heldout_planted"


def make_env(wrapped: bool = True) -> gym.Env:
    env = gym.make("ModQuadAssembly-v0", tasks="planted", n_max=7)
    return NearestValidAction(env) if wrapped else env


def train(algo: str, steps: int, seed: int, wrapped: bool = True):
    """An SB3 model of ``algo`` trained for ``steps`` (default hyperparameters, Dict policy)."""
    import torch
    from stable_baselines3 import A2C, DQN, PPO

    torch.set_num_threads(1)
    cls = {"ppo": PPO, "a2c": A2C, "dqn": DQN}[algo]
    extra = {"learning_starts": 1000, "exploration_fraction": 0.3} if algo == "dqn" else {}
    model = cls("MultiInputPolicy", make_env(wrapped), seed=seed, device="cpu", verbose=0, **extra)
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


def main(argv: list[str] | None = None) -> list[dict]:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--algos", nargs="+", choices=ALGOS, default=list(ALGOS))
    parser.add_argument("--steps", type=int, default=30_000, help="training steps per algorithm")
    parser.add_argument("--tasks", type=int, default=60, help="held-out tasks played")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--out", type=Path, default=None, help="report folder (default: print)")
    args = parser.parse_args(argv)
    tasks = load_suite(SUITES_DIR / f"{SUITE}.json")[: args.tasks]
    rng = np.random.default_rng(args.seed)
    runs = [("random actions + wrapper", "none", lambda o, e: int(rng.integers(e.action_space.n)),
             True)]  # fmt: skip
    for algo in args.algos:
        t0 = time.perf_counter()
        model = train(algo, args.steps, args.seed)
        spent = f"{time.perf_counter() - t0:.0f} s"
        runs.append((f"{algo.upper()} + wrapper", spent, greedy(model), True))
    if "ppo" in args.algos:
        t0 = time.perf_counter()
        plain = train("ppo", args.steps, args.seed, wrapped=False)
        runs.append(("PPO, no wrapper", f"{time.perf_counter() - t0:.0f} s", greedy(plain), False))
    table = [{"agent": name, "training": spent, **play(policy, tasks, wrapped, args.seed)}
             for name, spent, policy, wrapped in runs]  # fmt: skip
    report(table, args, argv if argv is not None else sys.argv[1:])
    return table


def report(table: list[dict], args, argv: list[str]) -> None:
    command = "python examples/unmasked_sb3.py " + shlex.join(argv)
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
    text = "\n".join(lines) + "\n"
    print(text)
    if args.out is not None:
        args.out.mkdir(parents=True, exist_ok=True)
        (args.out / "report.md").write_text(text)
        with open(args.out / "report.csv", "w", newline="") as f:
            writer = csv.DictWriter(f, fieldnames=keys)
            writer.writeheader()
            writer.writerows(table)


if __name__ == "__main__":
    main()
