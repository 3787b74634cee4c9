"""modquad_gym: find the smallest modular multirotor (H-ModQuad) that can exert a task's wrenches.

Layers, bottom to top (a lower layer never imports a higher one):
``module``/``structure`` (geometry) -> ``oracle`` (is a wrench feasible?) -> ``dynamics`` (motions
and their structure-dependent wrenches) -> ``tasks``/``search``
-> ``envs`` (Gymnasium) -> ``agents`` (PPO, baselines) ; ``sim`` (MuJoCo) and ``viz`` on the side.
Importing this package stays light: torch, SB3 and MuJoCo load only where they are used.
"""

import modquad_gym.core.caches  # noqa: F401 - first: writable caches (numba, matplotlib)
from modquad_gym import envs  # noqa: F401 - registers ModQuadAssembly-v0 with Gymnasium
from modquad_gym.dynamics import DynamicTask, Payload, Trajectory, required_wrenches
from modquad_gym.geometry.module import DEFAULT_C_TAU, DEFAULT_SIDE, GRAVITY, ModuleType, TModule
from modquad_gym.geometry.structure import Structure, structure_levels
from modquad_gym.oracle import (
    METHODS,
    TOL,
    WrenchOracle,
    Zonotope,
    allocate,
    feasible,
    lambda_ratio,
    margin,
)
from modquad_gym.oracle.faults import FAULTS, fault_margin, tolerates
from modquad_gym.search import (
    SearchProblem,
    SearchResult,
    anytime_search,
    centrosymmetric_search,
    exhaustive_search,
    greedy_search,
    optimal_structures,
    random_search,
)
from modquad_gym.tasks import TaskRequirement

__version__ = "0.1.0"

__all__ = [
    "DEFAULT_C_TAU",
    "DEFAULT_SIDE",
    "GRAVITY",
    "DynamicTask",
    "Payload",
    "Trajectory",
    "required_wrenches",
    "METHODS",
    "TOL",
    "ModuleType",
    "SearchProblem",
    "SearchResult",
    "Structure",
    "TaskRequirement",
    "TModule",
    "WrenchOracle",
    "Zonotope",
    "allocate",
    "anytime_search",
    "centrosymmetric_search",
    "exhaustive_search",
    "greedy_search",
    "random_search",
    "feasible",
    "lambda_ratio",
    "margin",
    "FAULTS",
    "fault_margin",
    "tolerates",
    "optimal_structures",
    "structure_levels",
]
