"""The environment at the field's sizes (issue 26): the two action encodings side by side.

For each n_max and encoding (``actions="grid"``: one action per cell of the (2 n_max - 1)^2 grid;
``actions="faces"``: one per free face, at most 2 n_max + 2, :mod:`modquad_gym.envs.assembly.faces`)
the environment made by ``gym.make("ModQuadAssemblyScale-v0", actions=..., n_max=...)`` plays
random masked actions from ``obs["action_mask"]`` with every reset in the timed loop, on tasks
planted in n_max / 4 to n_max modules. Besides speed, each row gives what a learner meets: the
action count, the observation's entries per step and the weights of a policy's last layer
(64 units, one logit per action).
"""

from __future__ import annotations

import time

import gymnasium as gym
import numpy as np

from benchmarks.common import markdown_table
from modquad_gym.tasks import PlantedTasks

SCALE_ID = "modquad_gym:ModQuadAssemblyScale-v0"
SCALE_TARGETS = {64: 2000.0, 128: 800.0}
"""Issues 26 and 35's goals: steps/s at n_max 64 and 128, random masked actions, resets counted,
one core."""
ENCODINGS = ("grid", "faces")


def play_timed(env: gym.Env, steps: int, warmup: int, seed: int) -> dict:
    """Random masked actions from ``obs["action_mask"]`` on ``env`` (a ``gym.make`` env), every
    reset inside the timed loop (and timed apart): wall and CPU rates after ``warmup`` steps."""
    rng = np.random.default_rng(seed)
    obs, _ = env.reset(seed=seed)
    reset_s = 0.0
    episodes = 0
    start, cpu = time.perf_counter(), time.process_time()
    for i in range(warmup + steps):
        if i == warmup:
            start, cpu, reset_s, episodes = time.perf_counter(), time.process_time(), 0.0, 0
        valid = np.flatnonzero(obs["action_mask"])
        a = int(valid[rng.integers(len(valid))]) if len(valid) else 0
        obs, _, term, trunc, _ = env.step(a)
        if term or trunc:
            t0 = time.perf_counter()
            obs, _ = env.reset()
            reset_s += time.perf_counter() - t0
            episodes += 1
    seconds = time.perf_counter() - start
    cpu_s = time.process_time() - cpu
    return {
        "steps_per_s": steps / seconds,
        "cpu_steps_per_s": steps / cpu_s,
        "us_per_step": 1e6 * (seconds - reset_s) / steps,
        "us_per_reset": 1e6 * reset_s / max(episodes, 1),
        "steps_per_episode": steps / max(episodes, 1),
    }


def scale_tasks(n_max: int) -> PlantedTasks:
    """Tasks planted in n_max / 4 to n_max modules (16-64 at n_max 64, as the Scale id)."""
    return PlantedTasks(n_modules=(max(2, n_max // 4), n_max), name=f"planted-{n_max}")


def measure_encoding(actions: str, n_max: int, steps: int, warmup: int, seed: int) -> dict:
    """One row: the encoding ``actions`` at ``n_max`` (see the module docstring)."""
    env = gym.make(SCALE_ID, actions=actions, n_max=n_max, tasks=scale_tasks(n_max),
                   max_episode_steps=4 * n_max)  # fmt: skip
    n_actions = int(env.action_space.n)
    row = {
        "encoding": actions,
        "n_max": n_max,
        "actions": n_actions,
        "obs_entries": sum(int(space.shape[0]) for space in env.observation_space.values()),
        "head_weights": 65 * n_actions,
    }
    row.update(play_timed(env, steps, warmup, seed))
    env.close()
    if n_max in SCALE_TARGETS:
        row["goal"] = "met" if row["steps_per_s"] >= SCALE_TARGETS[n_max] else "NOT met"
    return row


def scale_section(rows: list[dict]) -> list[str]:
    """The report's lines for the encodings table."""
    at64 = {r["encoding"]: r for r in rows if r["n_max"] == 64}
    head = ""
    for r in rows:
        if r["encoding"] == "faces" and r["n_max"] in SCALE_TARGETS:
            head += (
                f"**At n_max {r['n_max']} the faces encoding ran {r['steps_per_s']:,.0f} steps/s "
                f"({r['cpu_steps_per_s']:,.0f} per CPU second): goal "
                f"({SCALE_TARGETS[r['n_max']]:,.0f}) {r['goal']}.** "
            )
    if "faces" in at64:
        r = at64["faces"]
        if "grid" in at64:
            ratio = r["cpu_steps_per_s"] / at64["grid"]["cpu_steps_per_s"]
            head += f"Faces / grid at n_max 64, per CPU second: {ratio:.2f}. "
    return [
        "## The encodings at the field's sizes (issue 26)",
        "",
        f"`gym.make({SCALE_ID!r}, actions=..., n_max=...)`, tasks planted in n_max / 4 to "
        "n_max modules, random masked actions from `obs['action_mask']`, every reset in the "
        "timed loop. `actions`: the action count; `obs_entries`: numbers in one observation; "
        "`head_weights`: weights of a policy's last layer (64 units and a bias per logit). "
        + head
        + "Both encodings decide the same structures (the same oracle calls); the grid's "
        "learner sees (2 n_max - 1)^2 logits and observation entries twice that, which no "
        "network trained at one size can reuse at another; the faces encoding's candidate rows "
        "can be scored with shared weights at any size. `ModQuadAssemblyScale-v0` uses the faces "
        "encoding.",
        "",
        markdown_table(rows),
        "",
    ]


if __name__ == "__main__":
    from benchmarks.common import refuse_as_script

    raise SystemExit(refuse_as_script("env_scale"))
