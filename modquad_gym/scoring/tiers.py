"""Benchmark tiers: an environment id, its held-out suites with certified optima, its budget.

* ``current``: ``ModQuadAssembly-v0`` (one module type, n_max 7), the planted and paper-like
  held-out suites (:mod:`.suites`);
* ``large``: ``ModQuadAssemblyLarge-v0`` (one type, n_max 12), tasks planted in 6-12 modules,
  where the certified search costs seconds per task;
* ``mixed``: ``ModQuadAssemblyMixed-v1`` with the palette t45, t45m, flat (n_max 7) on
  self-weight (``external``) tasks planted in mixed structures of 3-6 modules: the rotors also
  lift the structure;
* ``dynamic``: ``ModQuadAssemblyDynamic-v0`` (one type, n_max 7) on random dynamic tasks
  (:class:`~modquad_gym.dynamics.random_motions.MotionTasks`: motions, off-centre payloads,
  pushes through a tool), each structure judged on its own mass and inertia; its model is the
  default recipe trained on that source;
* ``fault``: ``ModQuadAssemblyFaultTolerant-v0`` (one type, n_max 10, ``fault="rotor"``) on the
  default (``mixed``) task source: an answer counts only when it still exerts every task wrench
  after any single rotor failure; the optimum is the smallest such structure. Only the methods
  that honour ``fault=`` are scored (:func:`honours_fault`: milp refuses it); its model is
  trained with the failure (``python train.py --tier fault``: the expert's optima, the
  learner's labels, the environment and the validation optima all survive it).

Suites are package data (``modquad_gym/data/suites``); ``python -m modquad_gym.scoring.tiers
large`` (or ``mixed``, ``dynamic``, ``fault``) rewrites a tier's suite from its fixed seeds, each
task with its certified optimum from :func:`~modquad_gym.search.exhaustive_search` (about 20 s
for the fault tier's 60 tasks on 2 cores).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

from modquad_gym.core.options import OneLineParser
from modquad_gym.core.outputs import check_output_file
from modquad_gym.dynamics import DynamicTask
from modquad_gym.geometry.module import palette
from modquad_gym.policy.models import shipped_model
from modquad_gym.scoring.suites import (
    SUITES_DIR,
    draw_task,
    optimum_counts,
    validation_tasks,
    with_optimum,
)
from modquad_gym.tasks import TaskRequirement, load_suite, make_generator, save_suite


@dataclass(frozen=True)
class Tier:
    """One benchmark tier (see the module docstring)."""

    name: str
    env_id: str
    n_max: int
    suites: tuple[str, ...]
    env_kwargs: dict = field(default_factory=dict)
    modules: str | None = None
    source: str = ""
    seed0: int = 0
    n_tasks: int = 0
    recipe: dict = field(default_factory=dict)
    """Training settings that differ from the recipe's defaults on this tier
    (:class:`agents.config.TrainConfig` fields)."""
    learned: tuple[str, ...] = ("ppo", "ppo-k8", "ppo-guided")
    """The learned methods its reports score (benchmark method names; settings of the guided
    search chosen on validation tasks, ``modquad score --validation``)."""
    model_tier: str = ""
    """The tier whose shipped model this tier uses ("": its own): a size-free model trained on
    one tier acts on another."""
    fault: str | None = None
    """The single failure every answer must survive (``"rotor"``, ``"module"``), or None."""
    goals: dict = field(default_factory=dict)
    """The tier's goals on its held-out suites: {method: {metric: least share, or a search's
    name: at least its share}} for the metrics ``success`` and ``optimal``, and ``configs``: a
    share of the exhaustive search's
    configurations per task, or the search to evaluate fewer than (without it: fewer than every
    search but random and milp, whose count is its answers only)."""

    def load_suites(
        self, limit: int | None = None
    ) -> dict[str, list[TaskRequirement | DynamicTask]]:
        """The tier's held-out suites by name (first ``limit`` tasks of each)."""
        return {s: load_suite(SUITES_DIR / f"{s}.json")[:limit] for s in self.suites}

    @property
    def model(self) -> Path:
        """The tier's shipped PPO model: ``data/models/ppo_default`` on the current tier (and
        on the tiers whose ``model_tier`` is ``current``), ``data/models/ppo_<name>`` on the
        others."""
        return shipped_model(self.model_tier or self.name)

    @property
    def results(self) -> str:
        """The folder of the tier's committed benchmark report."""
        return "results" if self.name == "current" else f"results/tier_{self.name}"

    def search_kwargs(self) -> dict:
        """Keywords that make a search of :mod:`modquad_gym.search` solve this tier."""
        return {
            **({"modules": palette(self.modules)} if self.modules else {}),
            **({"fault": self.fault} if self.fault else {}),
        }


TIERS = {
    "current": Tier("current", "ModQuadAssembly-v0", 7, ("heldout_paper", "heldout_planted"),
                    goals={"ppo": {"success": 0.98, "optimal": 0.90,
                                   "configs": "centrosymmetric"}}),
    "large": Tier("large", "ModQuadAssemblyLarge-v0", 12, ("large_planted",),
                  source="planted-large", seed0=3_000_000, n_tasks=40,
                  recipe={"expert": "one", "demo_tasks": 800, "timesteps": 30_000},
                  model_tier="current",
                  learned=("ppo", "ppo-k8", "ppo-guided", "ppo-guided-b256-w8"),
                  goals={**{m: {"optimal": 0.95, "configs": 0.05}
                            for m in ("ppo-guided", "ppo-guided-b256-w8")},
                         "ppo": {"optimal": "greedy"}}),
    "mixed": Tier("mixed", "ModQuadAssemblyMixed-v1", 7, ("mixed_external",),
                  env_kwargs={"tasks": "planted-mixed-external"}, modules="t45,t45m,flat",
                  source="planted-mixed-external", seed0=4_000_000, n_tasks=40,
                  recipe={"expert": "one", "demo_tasks": 3000},
                  goals={m: {"success": 0.98, "optimal": 0.80} for m in ("ppo", "ppo-guided")}),
    "dynamic": Tier("dynamic", "ModQuadAssemblyDynamic-v0", 7, ("dynamic_motions",),
                    source="motions", seed0=7_000_000, n_tasks=60,
                    goals={"ppo-guided": {"success": 0.98, "optimal": 0.95},
                           "ppo": {"optimal": "greedy"}}),
    "fault": Tier("fault", "ModQuadAssemblyFaultTolerant-v0", 10, ("fault_rotor",),
                  source="mixed", seed0=8_000_000, n_tasks=60, fault="rotor"),
}  # fmt: skip
"""The tiers by name."""


def get_tier(name: str) -> Tier:
    if name not in TIERS:
        raise ValueError(f"--tier: unknown tier {name!r}; choose one of {', '.join(TIERS)}")
    return TIERS[name]


def honours_fault(method: str) -> bool:
    """Can ``method`` (a solver name of :func:`~modquad_gym.solvers.make_solver`) guarantee that
    its answer survives a failure? The registered methods that take ``fault=`` can (every one
    but milp; the learned ones verify that each answer survives). An outside agent
    (``package.module:Name``) is handed the problem with its fault and an evaluator that
    decides survival, and every answer is verified to survive."""
    from modquad_gym.methods import method_of

    if ":" in method:
        return True
    try:
        return bool(method_of(method)[0].fault)
    except ValueError:
        return False


def build_tier_suite(tier: Tier, n: int | None = None, progress: bool = True) -> list:
    """The tier's held-out tasks (seeds ``seed0 + i``) with their certified optimum."""
    gen = make_generator(tier.source)
    seeds = range(tier.seed0, tier.seed0 + (n or tier.n_tasks))
    return certify(tier, [draw_task(gen, s, name=f"{tier.name}-{s}") for s in seeds], progress)


def validation_suite(tier: Tier, n: int = 40, progress: bool = True) -> list:
    """``n`` validation tasks of the tier's training task source with their certified optimum:
    the tasks training selects its model on (:func:`.suites.validation_tasks`, disjoint from
    training and held-out seeds), where decoders and recipes are tuned."""
    return certify(tier, validation_tasks(n, tier.source or "mixed"), progress)


def certify(tier: Tier, tasks: list, progress: bool = True) -> list:
    """The tasks with the tier's certified optimum in their meta (:func:`.suites.with_optimum`)."""
    from tqdm import tqdm

    modules = tier.search_kwargs().get("modules")
    desc = f"certified optima ({tier.name})"
    return [with_optimum(t, tier.n_max, modules, tier.fault)
            for t in tqdm(tasks, desc, disable=not progress)]  # fmt: skip


def main(argv: list[str] | None = None) -> int:
    p = OneLineParser(
        prog="python -m modquad_gym.scoring.tiers",
        description="Rewrite a tier's held-out suite (fixed seeds, certified optima).",
    )
    p.add_argument("tier", choices=[t for t in TIERS if TIERS[t].source])
    p.add_argument("--n", type=int, default=None, help="tasks (default: the tier's size)")
    p.add_argument("--force", action="store_true", help="replace the shipped suite file")
    args = p.parse_args(argv)
    tier = TIERS[args.tier]
    out = SUITES_DIR / f"{tier.suites[0]}.json"
    check_output_file(out, force=args.force, what="output")  # before the certified searches
    tasks = build_tier_suite(tier, args.n)
    path = save_suite(tasks, out, force=args.force)
    print(f"{path}: {len(tasks)} tasks, optimum counts {optimum_counts(tasks)}")
    return 0


if __name__ == "__main__":
    from modquad_gym.core.interrupts import run_command

    raise SystemExit(run_command(main, "python -m modquad_gym.scoring.tiers"))
