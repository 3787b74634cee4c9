"""A policy that acts at any size and palette: one score per candidate docking, shared weights.

The assembly environment with ``lookahead`` on describes every action (a cell, and a module
type with several types) by a row of lookahead features of the child structure it would build
(:mod:`modquad_gym.envs.assembly.lookahead`: support features, and with ``lookahead="exact"``
the exact share, margin and greedy's choice; the row's width is read from the observation
space). :class:`CandidateScorer` turns each row, the
action's neighbourhood on the grid and its position from the structure's centre, and its module
type's descriptor into one logit with the *same* weights for every action (a DeepSets scorer:
each candidate also sees a masked mean and max over all candidates and a summary of the task and
the structure), so the number of actions - the grid size ``(2 n_max - 1)^2`` times the palette
size - is free: one trained network acts at n_max 7, 12 or 64.

Size-free inputs: the environment divides capabilities and deficits by ``n_max`` (so they lie
in [-1, 1]); the scorer multiplies them back (n_max read from the grid's size) into units of
one module's thrust and compresses them with ``symlog(x) = sign(x) log(1 + |x|)``.

:class:`CandidatePolicy` is the sb3-contrib ``MaskableActorCriticPolicy`` built on it (the
scorer's logits are the action logits; the critic reads the summary), so MaskablePPO trains it
as any policy, and :func:`~modquad_gym.policy.models.load_model` rebuilds it for the spaces of
the environment it is asked to act in.
"""

from __future__ import annotations

import math
from typing import Any

import torch
from gymnasium import spaces
from sb3_contrib.common.maskable.policies import MaskableActorCriticPolicy
from stable_baselines3.common.torch_layers import BaseFeaturesExtractor
from torch import nn
from torch.nn import functional as F  # noqa: N812

from modquad_gym.envs.assembly.features import STRUCTURE_SCALARS, TASK_SCALARS
from modquad_gym.policy.inference import TYPE_FEATURES, scaled_entries

CELL_EXTRAS = 9 + 2 + TYPE_FEATURES
"""Per candidate beside its lookahead row: 3 x 3 occupancy patch, offset from the centre,
type."""


def symlog(x: torch.Tensor) -> torch.Tensor:
    return torch.sign(x) * torch.log1p(torch.abs(x))


def mlp(sizes: list[int]) -> nn.Sequential:
    layers: list[nn.Module] = []
    for i in range(len(sizes) - 1):
        layers.append(nn.Linear(sizes[i], sizes[i + 1]))
        if i < len(sizes) - 2:
            layers.append(nn.ReLU())
    return nn.Sequential(*layers)


class CandidateScorer(BaseFeaturesExtractor):
    """Observation -> [one logit per action, the critic's summary (``hidden``)] (see the module
    docstring). Works on observations of any grid size and palette size: only ``task`` and
    ``structure`` must have the sizes of the directions it was built for."""

    def __init__(self, observation_space: spaces.Dict, hidden: int = 64, types=None) -> None:
        n_actions = int(observation_space["action_mask"].shape[0])
        super().__init__(observation_space, features_dim=n_actions + hidden)
        self.width = int(observation_space["candidates"].shape[0]) // n_actions
        task_size = int(observation_space["task"].shape[0])
        self.k = task_size - TASK_SCALARS
        self.hidden = hidden
        task_scaled, structure_scaled = scaled_entries(self.k)
        types = types if types is not None else [[0.0] * TYPE_FEATURES]
        for name, value in (("task_scaled", torch.as_tensor(task_scaled)),
                            ("structure_scaled", torch.as_tensor(structure_scaled)),
                            ("types", torch.as_tensor(types, dtype=torch.float32))):  # fmt: skip
            self.register_buffer(name, value, persistent=False)
        context_in = task_size + 2 * self.k + STRUCTURE_SCALARS + 1
        self.context = mlp([context_in, hidden, hidden])
        self.embed = mlp([self.width + CELL_EXTRAS, hidden, hidden])
        self.mix = nn.Linear(hidden, hidden)
        self.score_cell = nn.Linear(hidden, hidden)
        self.score_pool = nn.Linear(2 * hidden, hidden)
        self.score_out = nn.Linear(hidden, 1)
        self.critic = mlp([3 * hidden, hidden])

    def forward(self, obs: dict[str, torch.Tensor]) -> torch.Tensor:
        occupancy = obs["occupancy"]
        batch, n_cells = occupancy.shape
        side = math.isqrt(n_cells)
        n_max = (side + 1) / 2
        mask = obs["action_mask"] > 0.5
        n_modules = occupancy.sum(dim=1, keepdim=True)
        task = torch.where(self.task_scaled, obs["task"] * n_max, obs["task"])
        structure = torch.where(self.structure_scaled, obs["structure"] * n_max, obs["structure"])
        context = self.context(symlog(torch.cat([task, structure, n_modules], dim=1)))
        # only the valid actions are scored: rows (sample b, action a) of the whole batch
        b, a = mask.nonzero(as_tuple=True)
        cells = self.cell_inputs(obs, occupancy, side, n_max, b, a)
        embedded = F.relu(self.embed(cells) + self.mix(context)[b])
        count = mask.sum(dim=1, keepdim=True).clamp(min=1)
        zeros = embedded.new_zeros(batch, self.hidden)
        mean = zeros.index_add(0, b, embedded) / count
        top = zeros.scatter_reduce(0, b[:, None].expand_as(embedded), embedded, "amax")
        pooled = torch.cat([mean, top], dim=1)
        scores = self.score_out(F.relu(self.score_cell(embedded) + self.score_pool(pooled)[b]))
        logits = occupancy.new_zeros(mask.shape).index_put((b, a), scores.squeeze(-1))
        summary = self.critic(torch.cat([context, pooled], dim=1))
        return torch.cat([logits, summary], dim=1)

    def cell_inputs(self, obs, occupancy, side: int, n_max: float, b, a) -> torch.Tensor:
        """(rows, width + CELL_EXTRAS) for the actions ``a`` of samples ``b``: each one's
        lookahead row (support entries de-normalised; the exact ones, when there, as they are),
        the 3 x 3 occupancy around its cell, its offset from the structure's centre and its
        module type's descriptor."""
        batch, n_cells = occupancy.shape
        rows = obs["candidates"].reshape(batch, -1, self.width)[b, a]
        rows = torch.cat([symlog(rows[:, :1] * n_max), rows[:, 1:2],
                          symlog(rows[:, 2:4] * n_max), rows[:, 4:]], dim=1)  # fmt: skip
        cell, kind = a % n_cells, a // n_cells
        grid = occupancy.reshape(batch, 1, side, side)
        patch = F.unfold(grid, 3, padding=1).transpose(1, 2)[b, cell]  # (rows, 9)
        radius = (side - 1) // 2
        xy = torch.stack([cell % side - radius, cell // side - radius], dim=1).to(occupancy.dtype)
        axis = torch.arange(side, dtype=occupancy.dtype) - radius
        ys, xs = torch.meshgrid(axis, axis, indexing="ij")
        grid_xy = torch.stack([xs.reshape(-1), ys.reshape(-1)], dim=1)  # (cells, 2)
        centre = occupancy @ grid_xy / occupancy.sum(dim=1, keepdim=True).clamp(min=1)
        return torch.cat([rows, patch, symlog(xy - centre[b]), self.types[kind]], dim=1)


class Split(nn.Module):
    """The actor's and critic's parts of the scorer's output (SB3's ``mlp_extractor`` slot)."""

    def __init__(self, hidden: int) -> None:
        super().__init__()
        self.latent_dim_pi = 0  # one logit per action: as many as the observation has
        self.latent_dim_vf = hidden

    def forward(self, features: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        return self.forward_actor(features), self.forward_critic(features)

    def forward_actor(self, features: torch.Tensor) -> torch.Tensor:
        return features[:, : -self.latent_dim_vf]

    def forward_critic(self, features: torch.Tensor) -> torch.Tensor:
        return features[:, -self.latent_dim_vf :]


class CandidatePolicy(MaskableActorCriticPolicy):
    """MaskablePPO's actor-critic on :class:`CandidateScorer`: the scorer's logits are the
    action logits, the critic is a linear read-out of its summary.

    Keywords (``policy_kwargs``): ``hidden`` (width, default 64), ``types`` (the palette's
    :func:`~.inference.type_features`, default one T-module)."""

    size_free = True
    """Its weights do not depend on the number of actions: rebuilt for any environment."""

    def __init__(self, observation_space, action_space, lr_schedule, hidden: int = 64,
                 types: Any = None, **kwargs: Any) -> None:  # fmt: skip
        self.hidden = int(hidden)
        extractor_kwargs = {"hidden": self.hidden, "types": types}
        kwargs.pop("net_arch", None)
        super().__init__(observation_space, action_space, lr_schedule,
                         features_extractor_class=CandidateScorer,
                         features_extractor_kwargs=extractor_kwargs, **kwargs)  # fmt: skip

    def _build_mlp_extractor(self) -> None:
        self.mlp_extractor = Split(self.hidden)

    def _build(self, lr_schedule) -> None:
        self._build_mlp_extractor()
        self.action_net = nn.Identity()
        self.value_net = nn.Linear(self.hidden, 1)
        self.optimizer = self.optimizer_class(
            self.parameters(), lr=lr_schedule(1), **self.optimizer_kwargs
        )

    def _get_constructor_parameters(self) -> dict[str, Any]:
        data = super()._get_constructor_parameters()
        data.update(hidden=self.hidden, types=self.features_extractor_kwargs["types"])
        for key in ("features_extractor_class", "features_extractor_kwargs", "net_arch"):
            data.pop(key, None)
        return data
