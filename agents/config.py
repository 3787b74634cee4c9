"""The training config: one run's settings, each field also a ``train.py`` option.

:class:`TrainConfig` holds one run's settings (the defaults are the recipe; a tier's ``recipe``
changes fields, :mod:`modquad_gym.scoring.tiers`). Each field is made by :func:`option`: its
help, group, choices and integer limits live on the field, and :mod:`agents.cli` derives the
command line from them. :mod:`agents.training` runs a config.
"""

from __future__ import annotations

import json
import shlex
from dataclasses import MISSING, dataclass, field, fields
from pathlib import Path
from typing import Any

from agents.checks import (
    MAX_N_ENVS,
    MAX_STEPS,
    check_hyperparameters,
    check_numbers,
    check_tier_keys,
    check_training_seed,
    check_used,
)
from agents.imitation import EXPERTS
from modquad_gym.core.options import MAX_SEED, seed_option
from modquad_gym.scoring.tiers import TIERS, get_tier
from modquad_gym.tasks import GENERATORS

HYPERPARAMETERS = {
    "learning_rate": 1e-4,
    "n_steps": 256,
    "batch_size": 128,
    "n_epochs": 8,
    "gamma": 1.0,
    "gae_lambda": 0.95,
    "clip_range": 0.2,
    "ent_coef": 0.005,
    "vf_coef": 0.5,
    "max_grad_norm": 0.5,
    "target_kl": None,
    "kl_coef": 0.0,
    "net_arch": [256, 256],
    "hidden": 64,
}
"""MaskablePPO hyperparameters of the recipe (fine-tuning after behaviour cloning); ``net_arch``
shapes the ``mlp`` architecture, ``hidden`` the ``candidates`` one; ``target_kl`` (None: off)
ends an update's epochs once the policy has moved that far from the one that collected the
rollout; ``kl_coef`` (0: off) weighs a KL term towards the cloned policy in the loss
(:mod:`.anchored_ppo`). What each was worth: docs/learned-designer.md."""
CRITIC_WARMUP = 0
"""PPO steps at the start during which only the critic learns (:mod:`.training`); off in the
recipe (measured: docs/learned-designer.md)."""
ADVANTAGES = ("gae", "group")
"""How PPO's advantages are estimated (:mod:`.group_ppo`)."""
FOCUS = {"focus_tasks": 0, "focus_percent": 50}
"""Where PPO trains (:mod:`.focus`): fresh tasks the cloned policy plays first, and the share of
PPO's episodes on those it missed."""
IMITATION = {"demo_tasks": 6_000, "bc_epochs": 30, "bc_batch_size": 256, "bc_learning_rate": 1e-3,
             "dagger_rounds": 3, "dagger_epochs": 10}  # fmt: skip
"""Behaviour-cloning settings of the recipe (see :mod:`.imitation`) and of the expert in the
loop (:mod:`.dagger`: rounds, cloning epochs after each round; fresh tasks per round default
to a tenth of the demonstration tasks)."""
ARCHITECTURES = ("candidates", "mlp")
"""Policy networks: ``candidates`` scores each candidate docking with shared weights
(:mod:`modquad_gym.policy.network`: any n_max, any palette; the env's lookahead rows), ``mlp``
is SB3's MultiInputPolicy over the whole observation (one grid size)."""
LOOKAHEAD = "exact"
"""The lookahead rows the ``candidates`` network sees: the exact one-step lookahead (each
child's exact share, margin and greedy's choice, :mod:`modquad_gym.envs.assembly.lookahead`);
``--env-kwargs '{"lookahead": true}'`` trains on the support rows alone, as models before it."""
DEFAULT_TIMESTEPS = 20_000
EVAL_FREQ_FLOOR = 512
"""Fewest steps between two validation passes when ``eval_freq`` is left to the run (a pass
plays every validation task: more often would cost more than the PPO steps between)."""
VEC_ENVS = ("dummy", "subproc")


def option(default: Any, help: str, group: str = "recipe", **argparse: Any) -> Any:
    """A :class:`TrainConfig` field that is also the ``train.py`` option ``--name``
    (:mod:`agents.cli` derives the option from the field): its help (``{recipe}`` stands for
    the tiers' recipes of it), its group of ``--help``, an integer's ``limits`` (low, high;
    :func:`~agents.checks.check_numbers`) and argparse keywords besides the type and default,
    which come from the field."""
    metadata = {"help": help, "group": group, **argparse}
    if isinstance(default, dict):
        return field(default_factory=dict, metadata=metadata)
    return field(default=default, metadata=metadata)


@dataclass(frozen=True)
class TrainConfig:
    """One training run. Fields left None take the tier's value (``task_source``, ``n_max`` and
    the tier's ``recipe``), then the recipe's; ``eval_freq`` defaults to ``timesteps / 20``, at
    least :data:`EVAL_FREQ_FLOOR` (:meth:`eval_every`).
    Every field is a ``train.py`` option (``--n-envs`` for ``n_envs``; ``--no-progress`` for
    ``progress``). A field set away from its default that the run would not use
    (:func:`~agents.checks.check_used`: ``critic_warmup`` with ``bc_epochs=0``, ...) and an
    ``env_kwargs`` key the tier or another field sets are refused (ValueError), as
    ``train.py`` refuses them."""

    out: Path = option(
        None,
        "run folder for model.zip, config.json, evaluations.npz and report/ (default "
        "runs/ppo-seed<seed>; runs/<tier>-seed<seed> on other tiers; runs/ppo-seeds with "
        "--seeds; runs/quick with --quick)",
        "run",
    )
    tier: str = option(
        "current",
        "benchmark tier: its environment, task source, n_max and held-out suites",
        "run",
        choices=tuple(TIERS),
    )
    seed: int = option(
        0, "training seed; env i uses seed + i", "run", type=seed_option, limits=(0, MAX_SEED)
    )
    timesteps: int | None = option(
        None,
        f"total PPO environment steps (default {DEFAULT_TIMESTEPS}; {{recipe}})",
        limits=(1, MAX_STEPS),
    )
    n_envs: int = option(2, "parallel environments", limits=(1, MAX_N_ENVS))
    vec_env: str = option(
        "dummy", "vectorised env class (dummy: faster on 2 cores)", choices=VEC_ENVS
    )
    task_source: str | None = option(
        None,
        "a task generator name (planted, paper, mixed, planted-large, ...) or a task/suite "
        "file (default: the tier's: mixed on current)",
    )
    n_max: int | None = option(
        None,
        "largest structure in modules (default: the tier's, 7 on current)",
        limits=(1, 10**4),
    )
    demo_tasks: int | None = option(
        None,
        "training tasks with an expert episode each for behaviour cloning (default "
        f"{IMITATION['demo_tasks']}; {{recipe}})",
        "imitation",
        limits=(1, 10**7),
    )
    bc_epochs: int = option(
        IMITATION["bc_epochs"],
        "behaviour-cloning epochs before PPO; 0: PPO alone from scratch",
        "imitation",
        limits=(0, 10**5),
    )
    expert: str | None = option(
        None,
        "what the expert docks towards: all optimal structures, or one, the first the "
        "certified search finds (default all; {recipe})",
        "imitation",
        choices=EXPERTS,
    )
    architecture: str = option(
        "candidates",
        "policy network: candidates (one score per candidate docking, shared weights: acts at "
        "any n_max and palette; the env's lookahead rows) or mlp (SB3's MultiInputPolicy, one "
        "grid size)",
        choices=ARCHITECTURES,
    )
    dagger_rounds: int = option(
        IMITATION["dagger_rounds"],
        "rounds of the expert in the loop after cloning: the learner's own episodes on fresh "
        "tasks, every state labelled by the certified search, cloned again; 0: none",
        "imitation",
        limits=(0, 10**4),
    )
    dagger_tasks: int | None = option(
        None,
        "fresh training tasks per DAgger round (default a tenth of --demo-tasks)",
        "imitation",
        limits=(1, 10**7),
    )
    workers: int = option(
        2, "processes that collect the expert demonstrations", "imitation", limits=(1, 1024)
    )
    resume: Path | None = option(
        None,
        "continue PPO from this model .zip with its own hyperparameters (no behaviour cloning, "
        "critic warm-up or focus tasks: those options are refused with it)",
        "run",
    )
    init_from: Path | None = option(
        None,
        "start PPO from this model's policy (e.g. runs/<run>/train/cloned_model.zip: "
        "another RL recipe from the same cloned start) with this run's hyperparameters and a "
        "step-0 evaluation; no cloning",
        "run",
    )
    focus_tasks: int = option(
        FOCUS["focus_tasks"],
        "fresh training tasks the cloned policy plays before PPO; the ones it does not solve "
        "optimally get --focus-percent of PPO's episodes; 0: none",
        limits=(0, 10**7),
    )
    focus_percent: int = option(
        FOCUS["focus_percent"],
        "percent of PPO's episodes on the tasks the cloned policy missed (the rest fresh)",
        limits=(0, 100),
    )
    advantage: str = option(
        "gae",
        "PPO's advantages: gae (the critic's, SB3's) or group (each training task sampled "
        "--group-size times, each episode against its group's mean return: agents/group_ppo.py)",
        choices=ADVANTAGES,
    )
    group_size: int = option(
        8, "sampled episodes per training task with --advantage group", limits=(2, 1024)
    )
    critic_warmup: int = option(
        CRITIC_WARMUP,
        "PPO steps at the start during which only the critic learns (the cloned actor is "
        "frozen), so the first policy updates follow fitted advantages; 0: none (the recipe)",
        limits=(0, MAX_STEPS),
    )
    eval_freq: int | None = option(
        None,
        f"evaluate every this many total steps (default timesteps / 20, at least "
        f"{EVAL_FREQ_FLOOR})",
        limits=(1, MAX_STEPS),
    )
    n_eval: int = option(
        100,
        "validation tasks (certified; the kept model solves the most optimally)",
        limits=(1, 100_000),
    )
    checkpoint_freq: int = option(
        50_000,
        "checkpoint every this many total steps, under --tensorboard",
        limits=(1, MAX_STEPS),
    )
    tensorboard: Path = option(
        Path("runs"), "TensorBoard logs and checkpoints (runs/ is gitignored)", "run"
    )
    threads: int = option(1, "torch threads", limits=(1, 1024))
    progress: bool = option(True, "no progress bars", "run")
    env_kwargs: dict = option(
        {},
        'extra env keywords as a JSON object, e.g. \'{"reward_weights": {"w_module": 0.2}}\'; '
        "not tasks or n_max (--task-source, --n-max), nor the tier's module, modules, "
        "initial_type or fault (--tier)",
    )
    hyperparameters: dict = option(
        {},
        "MaskablePPO hyperparameters overriding the recipe, as a JSON object, e.g. "
        f"'{{\"ent_coef\": 0.02}}'; known: {', '.join(HYPERPARAMETERS)} (target_kl null: off; "
        "net_arch sizes --architecture mlp, hidden candidates; none with --resume)",
    )

    def __post_init__(self) -> None:
        for name in ("env_kwargs", "hyperparameters"):
            value = getattr(self, name)
            if not isinstance(value, dict) or not all(isinstance(k, str) for k in value):
                raise TypeError(f"--{name.replace('_', '-')} must be a JSON object (a dict with "
                                f"string keys), got {value!r}")  # fmt: skip
        for name, value in self._filled().items():
            if getattr(self, name) is None:
                object.__setattr__(self, name, value)
        if self.expert not in EXPERTS:
            raise ValueError(f"expert must be one of {EXPERTS}, got {self.expert!r}")
        if self.architecture not in ARCHITECTURES:
            raise ValueError(
                f"architecture must be one of {ARCHITECTURES}, got {self.architecture!r}"
            )
        unknown = sorted(set(self.hyperparameters) - set(HYPERPARAMETERS))
        if unknown:
            raise ValueError(
                f"--hyperparameters: unknown keys {unknown}; known: {sorted(HYPERPARAMETERS)}"
            )
        check_numbers(self)  # every number in range, named by its train.py option
        check_training_seed(self.seed, self.n_envs)  # no validation or held-out task
        check_hyperparameters(self.hyperparameters)
        hp = self.ppo_hyperparameters()
        if hp["kl_coef"] and not hp["ent_coef"]:
            raise ValueError("--hyperparameters: kl_coef > 0 needs ent_coef > 0 (anchored_ppo)")
        if self.advantage not in ADVANTAGES:
            raise ValueError(f"advantage must be one of {ADVANTAGES}, got {self.advantage!r}")
        if self.resume is not None and self.init_from is not None:
            raise ValueError("--init-from starts a new PPO run: not with --resume")
        if self.resume is not None and self.advantage != "gae":
            raise ValueError("--advantage group: not with --resume (a new run's option)")
        check_tier_keys(self.env_kwargs, self.tier)  # tasks, n_max, modules, fault: not here
        check_used(self, self.asked())
        if self.critic_warmup and self.critic_warmup >= self.timesteps:
            raise ValueError(
                f"--critic-warmup {self.critic_warmup}: not below --timesteps {self.timesteps} "
                "(the cloned actor would stay frozen for the whole PPO stage)"
            )

    def _filled(self) -> dict[str, Any]:
        """What the fields left None take: the tier's recipe, then the recipe's defaults (the
        DAgger tasks a tenth of the demonstration tasks)."""
        filled = {"timesteps": DEFAULT_TIMESTEPS, "demo_tasks": IMITATION["demo_tasks"],
                  "expert": "all", **get_tier(self.tier).recipe}  # fmt: skip
        demo_tasks = filled["demo_tasks"] if self.demo_tasks is None else self.demo_tasks
        tenth = max(1, demo_tasks // 10) if isinstance(demo_tasks, int) else None  # else refused
        return {**filled, "dagger_tasks": tenth}

    def asked(self) -> list[str]:
        """The fields set away from what this config takes unasked (each field's default, or
        what a field left None takes: :meth:`_filled`): what the caller asked for."""
        unasked = {f.name: f.default_factory() if f.default is MISSING else f.default
                   for f in fields(self)} | self._filled()  # fmt: skip
        return [f.name for f in fields(self) if not _same(getattr(self, f.name), unasked[f.name])]

    @property
    def source(self) -> str:
        """The training task source (the tier's unless given)."""
        return self.task_source or get_tier(self.tier).source or "mixed"

    @property
    def max_modules(self) -> int:
        return self.n_max if self.n_max is not None else get_tier(self.tier).n_max

    @property
    def env_kwargs_full(self) -> dict:
        """The training environment's keywords (what the model's config.json records): on a
        tier of several module types its palette, each episode starting with a random type."""
        return {"tasks": self.source, "n_max": self.max_modules, **self.eval_env_kwargs,
                **({"initial_type": "random"} if get_tier(self.tier).modules else {})}  # fmt: skip

    @property
    def eval_env_kwargs(self) -> dict:
        """Keywords of the validation environment besides its tasks and n_max (episodes start
        with the first type, as :class:`~.ppo.PPOSolver` does first)."""
        tier = get_tier(self.tier)
        lookahead = {"lookahead": LOOKAHEAD} if self.architecture == "candidates" else {}
        return {**({"modules": tier.modules} if tier.modules else {}), **lookahead,
                **({"fault": tier.fault} if tier.fault else {}), **self.env_kwargs}  # fmt: skip

    @property
    def validation_source(self) -> str:
        """The validation tasks' generator: the training source when it is a generator name,
        else (a task file) the tier's."""
        return self.source if self.source in GENERATORS else get_tier(self.tier).source or "mixed"

    def ppo_hyperparameters(self) -> dict:
        return {**HYPERPARAMETERS, **self.hyperparameters}

    def eval_every(self) -> int:
        """Total steps between validation passes: ``eval_freq``, else ``timesteps / 20`` and at
        least :data:`EVAL_FREQ_FLOOR`."""
        return self.eval_freq or max(self.timesteps // 20, EVAL_FREQ_FLOOR)

    def policy(self) -> tuple[Any, dict]:
        """The policy (a class, or SB3's name ``MultiInputPolicy``) and its keywords that a new
        run of this config builds (``--architecture`` and its width in ``--hyperparameters``)."""
        hp = self.ppo_hyperparameters()
        if self.architecture == "mlp":
            return "MultiInputPolicy", {"net_arch": hp["net_arch"]}
        from modquad_gym.geometry.module import palette
        from modquad_gym.policy.inference import type_features
        from modquad_gym.policy.network import CandidatePolicy

        types = type_features(palette(get_tier(self.tier).modules or "t45"))
        return CandidatePolicy, {"hidden": hp["hidden"], "types": types}

    def command(self) -> str:
        """The ``python train.py`` command line that runs this config (what ``config.json``
        records): the tier, the seed, the run folder and every field the caller asked for
        (:meth:`asked`; what the tier's recipe fills is left to it)."""
        parts, asked = ["train.py"], self.asked()
        for f in fields(self):
            value = getattr(self, f.name)
            if f.name not in ("tier", "seed", "out", *asked):
                continue
            flag = "--" + f.name.replace("_", "-")
            if f.type == "bool":
                parts.append(f"--no-{f.name}")
            else:
                parts += [flag, json.dumps(value) if isinstance(value, dict) else str(value)]
        return shlex.join(parts)


def _same(value: Any, default: Any) -> bool:
    if isinstance(value, Path) and isinstance(default, Path):
        return value.resolve() == default.resolve()
    return value == default
