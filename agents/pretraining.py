"""Before PPO: behaviour cloning on expert episodes, then the expert in the loop (DAgger).

1. Expert demonstrations: ``demo_tasks`` training tasks from the tier's task source, drawn from
   ``default_rng([seed, 1])`` (disjoint from the validation and held-out seeds); for each, the
   optimal structures from the certified search and one expert episode towards them
   (:mod:`.imitation`), on ``workers`` processes; the policy is cloned on them (``bc_epochs``).
2. ``dagger_rounds`` rounds (:mod:`.dagger`): ``dagger_tasks`` fresh tasks per round (from
   ``default_rng([seed, 2, round])``), the learner's greedy episode on each, every state it
   visits labelled by the expert, added to the demonstrations; cloned again
   (``dagger_epochs``).
"""

from __future__ import annotations

import time
from pathlib import Path
from typing import Any

from agents.config import IMITATION, TrainConfig


def pretrain(model: Any, config: TrainConfig, log_dir: Path) -> dict:
    """Expert demonstrations, cloning, DAgger rounds of ``model``'s policy (TensorBoard scalars
    ``bc/loss`` and ``bc/greedy_good`` per epoch in ``log_dir``). Returns what the config
    records about it."""
    import numpy as np
    from torch.utils.tensorboard import SummaryWriter

    from agents.dagger import learner_states, search_starts_anywhere
    from agents.imitation import clone, collect_parallel, merge
    from modquad_gym.envs.assembly import ModQuadAssemblyEnv
    from modquad_gym.tasks import make_generator

    t0 = time.perf_counter()
    generator = make_generator(config.source)
    rng = np.random.default_rng([config.seed, 1])  # never a validation or held-out seed
    tasks = [generator(rng) for _ in range(config.demo_tasks)]
    demos = collect_parallel(
        tasks,
        config.env_kwargs_full,
        config.max_modules,
        seed=config.seed,
        workers=config.workers,
        progress=config.progress,
        expert=config.expert,
    )
    collect_s = time.perf_counter() - t0
    writer = SummaryWriter(str(log_dir))
    epoch0 = 0

    def cloned(demos, epochs: int, seed) -> list[dict]:
        nonlocal epoch0
        history = clone(model, demos, epochs=epochs, batch_size=IMITATION["bc_batch_size"],
                        learning_rate=IMITATION["bc_learning_rate"], seed=seed,
                        progress=config.progress, log=log)  # fmt: skip
        epoch0 += epochs
        return history

    def log(epoch: int, stats: dict) -> None:
        for key, value in stats.items():
            writer.add_scalar(f"bc/{key}", value, epoch0 + epoch)

    t1 = time.perf_counter()
    expert_episodes, expert_states = demos.n_tasks, len(demos)
    history = cloned(demos, config.bc_epochs, config.seed)
    clone_s = time.perf_counter() - t1
    t2 = time.perf_counter()
    env = ModQuadAssemblyEnv(**config.env_kwargs_full)
    dagger = []
    for r in range(config.dagger_rounds):
        rng = np.random.default_rng([config.seed, 2, r])
        fresh = [generator(rng) for _ in range(config.dagger_tasks)]
        visited, stats = learner_states(model.policy, env, fresh, config.max_modules,
                                        seed=[config.seed, 2, r], expert=config.expert,
                                        progress=config.progress)  # fmt: skip
        demos = merge([demos, visited])
        history = cloned(demos, IMITATION["dagger_epochs"], config.seed + 1000 * (r + 1))
        dagger.append({"round": r, **stats, "states": len(visited),
                       "greedy_good_after": round(history[-1]["greedy_good"], 4)})  # fmt: skip
    writer.close()
    return {
        "demo_tasks": config.demo_tasks,
        "expert": config.expert,
        "expert_episodes": expert_episodes,
        "states": expert_states,
        "epochs": config.bc_epochs,
        "batch_size": IMITATION["bc_batch_size"],
        "learning_rate": IMITATION["bc_learning_rate"],
        "task_seed": f"default_rng([{config.seed}, 1])",
        "collect_seconds": round(collect_s, 1),
        "clone_seconds": round(clone_s, 1),
        "dagger_tasks": config.dagger_tasks,
        "dagger": dagger,
        "dagger_off_path_labels": search_starts_anywhere(),
        "dagger_seconds": round(time.perf_counter() - t2, 1),
        "final_loss": round(history[-1]["loss"], 4),
        "final_greedy_good": round(history[-1]["greedy_good"], 4),
    }
