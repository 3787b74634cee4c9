"""The env speed benchmark, the measurements: the task families and sizes, random masked
actions timed on the unwrapped env and on the default ``gym.make`` env (resets counted), the
lookahead rows, one MaskablePPO update, and pinning the process to one core.

Run through :mod:`benchmarks.env` (``python -m benchmarks.env``), which describes what is timed;
the report page is :mod:`.env_report`.
"""

from __future__ import annotations

import os
import time

import gymnasium as gym
import numpy as np

from benchmarks.env_scale import play_timed, scale_tasks
from modquad_gym.core.extras import import_optional
from modquad_gym.envs import ModQuadAssemblyEnv
from modquad_gym.policy.models import TOP_K
from modquad_gym.tasks import PaperTasks, PlantedTasks

SIZES = (1, 8, 32, 80, 200)
FAMILIES = {"paper": PaperTasks, "planted": PlantedTasks}
TARGET = 5000.0
DEFAULT_ID = "modquad_gym:ModQuadAssembly-v0"
PPO_RECIPE = {"n_steps": 256, "batch_size": 128, "n_epochs": 8, "net_arch": [256, 256]}
"""The rollout and update sizes of ``train.py``'s HYPERPARAMETERS (what the update timing uses)."""


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


def measure_default(steps: int, warmup: int, seed: int) -> dict:
    """The "resets counted" row: the default env from ``gym.make``, random masked actions from
    ``obs["action_mask"]``, resets timed inside the loop (and apart)."""
    env = gym.make(DEFAULT_ID)
    row = {"config": f"gym.make({DEFAULT_ID!r}), resets counted"}
    row.update(play_timed(env, steps, warmup, seed))
    oracles = [ev.oracle for ev in env.unwrapped.evaluators.values()]
    row["oracle_fallback_wrenches"] = sum(o.fallback for o in oracles)
    row["goal"] = "met" if row["steps_per_s"] >= TARGET else "NOT met"
    return row


LOOKAHEADS = ((False, None), (True, None), ("exact", None), ("exact", TOP_K))
"""(lookahead, lookahead_top_k) of the rows: off, the support rows, the exact lookahead of every
child, and the shipped policy's observation (the exact lookahead of its shortlist)."""
EXACT_TARGETS = {7: 1500.0, 64: 300.0}
"""Issue 48's goals for the shipped policy's observation: steps per CPU second at n_max 7, 64."""


def measure_lookahead(steps: int, warmup: int, seed: int, n_max: int = 7) -> list[dict]:
    """The lookahead rows at ``n_max``: the default env id with each of :data:`LOOKAHEADS`,
    resets counted, as ratios to the first (off)."""
    rows = []
    tasks = {} if n_max == 7 else {"tasks": scale_tasks(n_max)}
    for lookahead, top_k in LOOKAHEADS:
        shortlist = {"lookahead_top_k": top_k} if top_k else {}
        env = gym.make(DEFAULT_ID, lookahead=lookahead, n_max=n_max, **tasks, **shortlist)
        row = {"n_max": n_max, "lookahead": repr(lookahead), "top_k": top_k}
        row.update(play_timed(env, steps, warmup, seed))
        row["oracle_tests_per_step"] = sum(ev.tests for ev in env.unwrapped.evaluators.values()) / (
            warmup + steps
        )
        rows.append(row)
    for row in rows:
        row["cpu_rate_over_off"] = row["cpu_steps_per_s"] / rows[0]["cpu_steps_per_s"]
    if n_max in EXACT_TARGETS:
        met = rows[-1]["cpu_steps_per_s"] >= EXACT_TARGETS[n_max]
        rows[-1]["goal"] = f"{EXACT_TARGETS[n_max]:,.0f}: {'met' if met else 'NOT met'}"
    return rows


def ppo_update_seconds(seed: int) -> tuple[float, float]:
    """(seconds of one MaskablePPO ``.train()``, seconds of the 256-step rollout before it) on
    the default env, timed with a callback around SB3's own ``learn``."""
    sb3 = import_optional("sb3_contrib")
    callbacks = import_optional("stable_baselines3.common.callbacks")
    logger = import_optional("stable_baselines3.common.logger")

    class Clock(callbacks.BaseCallback):
        def _on_rollout_start(self) -> None:
            self.t0 = time.perf_counter()

        def _on_rollout_end(self) -> None:
            self.t1 = time.perf_counter()

        def _on_step(self) -> bool:
            return True

    hp = dict(PPO_RECIPE)
    policy_kwargs = {"net_arch": hp.pop("net_arch")}
    model = sb3.MaskablePPO(
        "MultiInputPolicy", gym.make(DEFAULT_ID), policy_kwargs=policy_kwargs, seed=seed,
        device="cpu", verbose=0, **hp,
    )  # fmt: skip
    model.set_logger(logger.Logger(folder=None, output_formats=[]))  # no tmp/SB3-<date> folder
    clock = Clock()
    model.learn(total_timesteps=hp["n_steps"], callback=clock)
    return time.perf_counter() - clock.t1, clock.t1 - clock.t0


def pin_to_one_core() -> str:
    """Pin this process to one core (Linux); say which."""
    if hasattr(os, "sched_setaffinity"):
        core = min(os.sched_getaffinity(0))
        os.sched_setaffinity(0, {core})
        return f"pinned to core {core}"
    return "not pinned (no sched_setaffinity on this platform)"


if __name__ == "__main__":
    from benchmarks.common import refuse_as_script

    raise SystemExit(refuse_as_script("env_measure"))
