"""modquad_gym: find the smallest modular multirotor (H-ModQuad) that can exert a task's wrenches.

Layers, bottom to top (a lower layer never imports a higher one):
``module``/``structure`` (geometry) -> ``oracle`` (is a wrench feasible?) -> ``tasks``/``search``
-> ``envs`` (Gymnasium) -> ``agents`` (PPO, baselines) ; ``sim`` (MuJoCo) and ``viz`` on the side.
Importing this package stays light: torch, SB3 and MuJoCo load only where they are used.
"""

from .module import DEFAULT_C_TAU, DEFAULT_SIDE, ModuleType, TModule
from .oracle import METHODS, TOL, WrenchOracle, Zonotope, allocate, feasible, lambda_ratio, margin
from .structure import Structure, structure_levels

__version__ = "0.1.0"

__all__ = [
    "DEFAULT_C_TAU",
    "DEFAULT_SIDE",
    "METHODS",
    "TOL",
    "ModuleType",
    "Structure",
    "TModule",
    "WrenchOracle",
    "Zonotope",
    "allocate",
    "feasible",
    "lambda_ratio",
    "margin",
    "structure_levels",
]
