"""Bring your own agent: play ModQuadAssembly-v0, use the shipped model, score an agent.

Run it from the repository root: ``python examples/byo_agent.py`` (tests run it too). Then score
the agent below on a tier's held-out suites, against the certified optimum, with one command::

    modquad score --solver examples.byo_agent:LargestSupportAgent --out my_scores

(``--solver`` imports ``package.module:Name`` from the working folder or the installed
packages; ``--tier large`` (or mixed, dynamic) picks a tier; the report is
``my_scores/benchmark.md`` and ``my_scores/benchmark.csv``, the agent beside the searches.)

The protocol: the benchmark makes the class with the keywords it takes among ``n_max``, ``tier``
and ``modules`` (the tier's budget, name and module types), then calls ``solve(task,
evaluator)`` per task. The task comes without its meta (no optimum); the evaluator
(:class:`modquad_gym.solvers.Evaluator`) decides structures with the exact oracle and counts
each new one, so the report's configurations and oracle calls are the benchmark's count.
"""

from __future__ import annotations

import gymnasium as gym
import numpy as np

import modquad_gym as mq
from modquad_gym.solvers import Evaluator


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

    model = MaskablePPO.load(DEFAULT_MODEL, device="cpu")  # trained with the exact lookahead rows
    env = gym.make("ModQuadAssembly-v0", tasks="planted", n_max=7, lookahead="exact")
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
    """A small agent with the solver interface: ``name`` and ``solve(task, evaluator)``.

    It grows the structure one module at a time, always taking the docking whose structure
    satisfies the most task wrenches, asking the evaluator it is handed (the exact oracle,
    counted by the benchmark). ``solve`` may return a Structure, a list of cells, a
    :class:`modquad_gym.search.SearchResult` or None; the benchmark verifies it exactly.
    """

    name = "largest-support"

    def __init__(self, n_max: int = 7, tier: str | None = None) -> None:
        self.n_max = n_max  # the tier's budget, told by the benchmark
        self.tier = tier

    def solve(self, task, evaluator: Evaluator) -> mq.Structure | None:
        structure = mq.Structure([(0, 0)], module=evaluator.modules[0])
        while not evaluator.evaluate(structure):
            if structure.n_modules >= min(self.n_max, evaluator.n_max):
                return None
            children = [structure.with_cells(c) for c in structure.attachable_cells()]
            structure = max(children, key=lambda s: int(evaluator.feasible(s).sum()))
        return structure


def main() -> int:
    info = masked_random_episode()
    print(f"masked random: success={info['is_success']} modules={info['n_modules']}")
    info = shipped_model_episode()
    if info is not None:
        print(f"shipped PPO:   success={info['is_success']} modules={info['n_modules']}")
    print(f"vector envs:   rewards {vector_envs()}")
    task = mq.TaskRequirement.load("examples/screwdriver.json")
    evaluator = Evaluator(task, n_max=7)  # what the benchmark hands the agent, per task
    structure = LargestSupportAgent().solve(task, evaluator)
    optimum = mq.exhaustive_search(task, n_max=7)
    found = structure.n_modules if structure else None
    print(
        f"own agent:     {found} modules on {task.name!r} (certified optimum {optimum.n_modules}"
        f"; {evaluator.evaluated} configurations evaluated, exhaustive {optimum.evaluated})"
    )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
