"""Bring your own agent: play ModQuadAssembly-v0, use the shipped model, score an agent.

Run it from the repository root: ``python examples/byo_agent.py`` (tests run it too). Then score
the agent below on the held-out suites, against the certified optimum, with one command::

    modquad bench agents --solver examples.byo_agent:LargestSupportAgent \\
        --methods exhaustive centrosymmetric --out my_scores

(``--solver`` imports ``package.module:Name`` from the working folder or the installed
packages; the report is ``my_scores/benchmark.md`` and ``my_scores/benchmark.csv``.)
"""

from __future__ import annotations

import gymnasium as gym
import numpy as np

import modquad_gym as mq
from modquad_gym.envs import ModQuadAssemblyEnv


def masked_random_episode(seed: int = 0) -> dict:
    """The reset/step loop: pick a valid action from the mask until the episode ends."""
    env = gym.make("ModQuadAssembly-v0", tasks="planted", n_max=7)
    obs, info = env.reset(seed=seed)  # seeding: reset(seed=...) once, then plain reset()
    rng = np.random.default_rng(seed)
    terminated = truncated = False
    while not (terminated or truncated):
        mask = env.unwrapped.action_masks()  # also obs["action_mask"] and info["action_mask"]
        action = rng.choice(np.flatnonzero(mask)) if mask.any() else 0
        obs, reward, terminated, truncated, info = env.step(action)
    env.close()
    return info  # info["is_success"], info["n_modules"], info["cells"], info["evaluated"]


def shipped_model_episode(seed: int = 0) -> dict | None:
    """Load the package's MaskablePPO model and predict with the action mask (train extra)."""
    try:
        from sb3_contrib import MaskablePPO
    except ImportError:
        return None  # pip install 'modquad_gym[train]'
    from modquad_gym.policy import DEFAULT_MODEL

    model = MaskablePPO.load(DEFAULT_MODEL, device="cpu")  # trained with the lookahead rows
    env = gym.make("ModQuadAssembly-v0", tasks="planted", n_max=7, lookahead=True)
    obs, info = env.reset(seed=seed)
    done = False
    while not done:
        action, _ = model.predict(
            obs, action_masks=env.unwrapped.action_masks(), deterministic=True
        )
        obs, reward, terminated, truncated, info = env.step(action)
        done = terminated or truncated
    env.close()
    return info


def vector_envs(seed: int = 0, n: int = 2) -> np.ndarray:
    """Vector envs: ``gym.make_vec`` (sync or async); seed once, masks through ``call``."""
    envs = gym.make_vec("ModQuadAssembly-v0", num_envs=n, vectorization_mode="sync", n_max=7)
    obs, infos = envs.reset(seed=seed)  # env i gets seed + i
    masks = np.stack(envs.call("action_masks"))
    actions = np.array([np.flatnonzero(m)[0] for m in masks])
    obs, rewards, terminated, truncated, infos = envs.step(actions)
    envs.close()
    return rewards


class LargestSupportAgent:
    """A small agent with the solver interface: ``name`` and ``solve(task)``.

    It grows the structure one docking at a time, always taking the docking whose structure
    satisfies the most task wrenches (ties: the first valid action), as an outside agent would
    with its own policy. ``solve`` may return a Structure, a list of cells, a
    :class:`modquad_gym.search.SearchResult` or None; the benchmark verifies it exactly.
    """

    name = "largest-support"

    def __init__(self, n_max: int = 7) -> None:
        self.env = ModQuadAssemblyEnv(n_max=n_max)

    def solve(self, task) -> mq.Structure | None:
        obs, info = self.env.reset(options={"task": task})
        done = False
        while not done:
            valid = np.flatnonzero(self.env.action_masks())
            if len(valid) == 0:
                break
            scores = [self._satisfied(task, info["cells"], a) for a in valid]
            obs, _, terminated, truncated, info = self.env.step(int(valid[int(np.argmax(scores))]))
            done = terminated or truncated
        return mq.Structure(info["cells"]) if info["is_success"] else None

    def _satisfied(self, task, cells: list, action: int) -> int:
        s = mq.Structure([*map(tuple, cells), self.env.cell_of(action)])
        return int(mq.feasible(s.configuration_matrix(), task.wrenches, task.f_max).sum())


def main() -> int:
    info = masked_random_episode()
    print(f"masked random: success={info['is_success']} modules={info['n_modules']}")
    info = shipped_model_episode()
    if info is not None:
        print(f"shipped PPO:   success={info['is_success']} modules={info['n_modules']}")
    print(f"vector envs:   rewards {vector_envs()}")
    task = mq.TaskRequirement.load("examples/screwdriver.json")
    structure = LargestSupportAgent().solve(task)
    optimum = mq.exhaustive_search(task, n_max=7)
    found = structure.n_modules if structure else None
    print(
        f"own agent:     {found} modules on {task.name!r} (certified optimum {optimum.n_modules})"
    )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
