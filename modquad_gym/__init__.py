"""modquad_gym: find the smallest modular multirotor (H-ModQuad) that can exert a task's wrenches.

Layers, bottom to top (a lower layer never imports a higher one):
``module``/``structure`` (geometry) -> ``oracle`` (is a wrench feasible?) -> ``dynamics`` (motions
and their structure-dependent wrenches) -> ``tasks``/``search``
-> ``envs`` (Gymnasium) -> ``agents`` (PPO, baselines) ; ``sim`` (MuJoCo) and ``viz`` on the side.

Importing this package is light: it registers the environments with Gymnasium (by entry-point
strings, no environment module imported; at once when Gymnasium is loaded, else right after it
is imported) and loads every public name below on first use (``lazy_loader``, SPEC 1), so
neither numpy, Gymnasium, numba, torch, Ray nor MuJoCo load until something needs them.
"""

from typing import TYPE_CHECKING

import lazy_loader

import modquad_gym.core.caches  # noqa: F401 - first: writable caches (numba, matplotlib)
from modquad_gym import envs  # noqa: F401 - registers ModQuadAssembly-v0 with Gymnasium

__version__ = "0.1.0"

_NAMES = {
    "dynamics": ["DynamicTask", "Payload", "Trajectory", "required_wrenches"],
    "geometry.module": ["DEFAULT_C_TAU", "DEFAULT_SIDE", "GRAVITY", "ModuleType", "TModule"],
    "geometry.structure": ["Structure", "structure_levels"],
    "oracle": [
        "METHODS", "TOL", "WrenchOracle", "Zonotope", "allocate", "feasible", "lambda_ratio",
        "margin",
    ],
    "oracle.faults": ["FAULTS", "fault_margin", "tolerates"],
    "search": [
        "SearchProblem", "SearchResult", "Status", "anytime_search", "beam_search",
        "centrosymmetric_search", "exhaustive_search", "genetic_search", "greedy_search",
        "optimal_structures", "random_search",
    ],
    "methods": ["REGISTRY", "register"],
    "solvers": ["make_solver"],
    "tasks": ["TaskRequirement"],
}  # fmt: skip
"""The public names, by the module that defines them (loaded on first use)."""

_SUBPACKAGES = [
    "core", "dynamics", "geometry", "methods", "oracle", "policy", "search", "sim", "tasks", "viz",
]  # fmt: skip

__getattr__, __dir__, _ = lazy_loader.attach(__name__, _SUBPACKAGES, _NAMES)

__all__ = [
    "DynamicTask",
    "Payload",
    "Trajectory",
    "required_wrenches",
    "DEFAULT_C_TAU",
    "DEFAULT_SIDE",
    "GRAVITY",
    "ModuleType",
    "TModule",
    "Structure",
    "structure_levels",
    "METHODS",
    "TOL",
    "WrenchOracle",
    "Zonotope",
    "allocate",
    "feasible",
    "lambda_ratio",
    "margin",
    "FAULTS",
    "fault_margin",
    "tolerates",
    "SearchProblem",
    "SearchResult",
    "Status",
    "anytime_search",
    "beam_search",
    "centrosymmetric_search",
    "exhaustive_search",
    "genetic_search",
    "greedy_search",
    "optimal_structures",
    "random_search",
    "REGISTRY",
    "register",
    "make_solver",
    "TaskRequirement",
]

if TYPE_CHECKING:  # for type checkers and the API docs: the same names, eagerly
    from modquad_gym.dynamics import DynamicTask, Payload, Trajectory, required_wrenches
    from modquad_gym.geometry.module import (
        DEFAULT_C_TAU,
        DEFAULT_SIDE,
        GRAVITY,
        ModuleType,
        TModule,
    )
    from modquad_gym.geometry.structure import Structure, structure_levels
    from modquad_gym.methods import REGISTRY, register
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
        Status,
        anytime_search,
        beam_search,
        centrosymmetric_search,
        exhaustive_search,
        genetic_search,
        greedy_search,
        optimal_structures,
        random_search,
    )
    from modquad_gym.solvers import make_solver
    from modquad_gym.tasks import TaskRequirement
