"""PPO with group-relative advantages: the policy's own ``group_size`` sampled episodes of one
training task, each judged against the mean of its group.

After cloning the policy is optimal on most tasks, and a critic cannot tell from a state how
many modules its task really needs, so GAE's advantages are mostly the critic's error: PPO's
updates move the policy at random around its start. Sampling several episodes of the same task
gives each a baseline that knows the task: the group's mean return (the multi-sample REINFORCE
baseline of Kool et al. 2019, POMO's shared baseline, GRPO's group-relative advantage). Where
the group ends alike the advantages are zero and nothing moves; where the policy is unsure,
the episodes with fewer modules (or a success) get positive advantages, scaled by the group's
standard deviation. The update itself is sb3-contrib's MaskablePPO (clipped ratios, epochs,
minibatches, value loss; advantages not normalised again) and :mod:`.anchored_ppo`'s KL term.

:class:`GroupPPO` (built by :func:`group_ppo_class`) overrides ``collect_rollouts`` only once
:meth:`~GroupPPO.set_sampler` gave it an environment (then :func:`collect_groups` fills the
rollout); else it is plain (anchored) MaskablePPO.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from agents.anchored_ppo import anchored_ppo_class
from modquad_gym.tasks.reserved import reserved_draws


def group_advantages(returns: np.ndarray) -> np.ndarray:
    """Each episode's return minus its group's mean, over the group's standard deviation (0 for
    a group that ended alike)."""
    returns = np.asarray(returns, dtype=float)
    spread = returns.std()
    if spread < 1e-9:
        return np.zeros_like(returns)
    return (returns - returns.mean()) / spread


def group_ppo_class():
    """:class:`GroupPPO`, built on first use so importing this module needs no SB3."""
    AnchoredPPO = anchored_ppo_class()

    class GroupPPO(AnchoredPPO):
        """Anchored MaskablePPO that, given a sampler, fills each rollout with groups of
        sampled episodes and their group-relative advantages."""

        def __init__(self, *args: Any, **kwargs: Any) -> None:
            super().__init__(*args, **kwargs)
            self.sampler = None

        def _excluded_save_params(self) -> list[str]:
            return [*super()._excluded_save_params(), "sampler"]

        def set_sampler(self, env: Any, group_size: int, seed: Any) -> None:
            """Sample groups of ``group_size`` episodes in ``env`` (an assembly env whose task
            generator gives the training tasks), tasks drawn with ``default_rng(seed)``."""
            rng = np.random.default_rng(seed)
            with reserved_draws():  # a random number: its tasks come from rng, not this seed
                env.reset(seed=int(rng.integers(2**31)))  # seeds the env's own draws (start types)
            self.sampler = (env, int(group_size), rng)
            self.normalize_advantage = False  # the groups scale their own

        def collect_rollouts(self, env: Any, callback: Any, rollout_buffer: Any,
                             n_rollout_steps: int, use_masking: bool = True) -> bool:  # fmt: skip
            if self.sampler is None:
                return super().collect_rollouts(
                    env, callback, rollout_buffer, n_rollout_steps, use_masking
                )
            return collect_groups(self, callback, rollout_buffer)

    return GroupPPO


def collect_groups(model: Any, callback: Any, rollout_buffer: Any) -> bool:
    """Fill ``rollout_buffer`` with groups of episodes from ``model``'s sampler, each step with
    its episode's group-relative advantage; the callbacks see every ``n_envs`` steps as one
    vectorised step. False when a callback stops the run."""
    model.policy.set_training_mode(False)
    rollout_buffer.reset()
    callback.on_rollout_start()
    n_envs = rollout_buffer.n_envs
    need = rollout_buffer.buffer_size * n_envs
    rows: list[tuple] = []
    since_callback = 0
    while len(rows) < need:
        group = sample_group(model.policy, *model.sampler)
        for episode, advantage in zip(group, group_advantages([g[1] for g in group])):
            steps, to_go = episode[0], episode[2]
            rows += [(*step, advantage, g) for step, g in zip(steps, to_go)]
            since_callback += len(steps)
        while since_callback >= n_envs:  # the callbacks count vectorised steps
            since_callback -= n_envs
            model.num_timesteps += n_envs
            if not callback.on_step():
                return False
    fill_buffer(rollout_buffer, rows[:need], n_envs)
    callback.on_rollout_end()
    return True


def sample_group(policy: Any, env: Any, size: int, rng: np.random.Generator) -> list[tuple]:
    """``size`` episodes of ``policy`` sampled on one fresh task of ``env``'s generator:
    (steps, return, returns to go), a step being (obs, mask, action, value, log_prob,
    episode_start)."""
    import torch

    task = env.generator(rng)
    out = []
    for _ in range(size):
        obs, _ = env.reset(options={"task": task})
        steps, rewards, done = [], [], False
        while not done:
            mask = env.action_masks()
            with torch.no_grad():
                obs_t, _ = policy.obs_to_tensor(obs)
                action, value, log_prob = policy(obs_t, action_masks=mask)
            a = int(action[0])
            steps.append((obs, mask, a, value, log_prob, not steps))
            obs, reward, terminated, truncated, _ = env.step(a)
            rewards.append(reward)
            done = terminated or truncated
        to_go = np.cumsum(rewards[::-1])[::-1]
        out.append((steps, float(to_go[0]), to_go))
    return out


def fill_buffer(buffer: Any, rows: list[tuple], n_envs: int) -> None:
    """The rollout buffer from ``rows`` (one per step, ``n_envs`` to a buffer row) and their
    advantages and returns to go."""
    import torch

    for r in range(0, len(rows), n_envs):
        part = rows[r : r + n_envs]
        obs = {k: np.stack([p[0][k] for p in part]) for k in part[0][0]}
        buffer.add(
            obs,
            np.array([[p[2]] for p in part]),
            np.zeros(n_envs, dtype=np.float32),  # rewards: the returns are set below
            np.array([p[5] for p in part], dtype=np.float32),
            torch.cat([p[3].reshape(1) for p in part]),
            torch.cat([p[4].reshape(1) for p in part]),
            action_masks=np.stack([p[1] for p in part]),
        )
    shape = (len(rows) // n_envs, n_envs)
    buffer.advantages = np.array([p[6] for p in rows], dtype=np.float32).reshape(shape)
    buffer.returns = np.array([p[7] for p in rows], dtype=np.float32).reshape(shape)
