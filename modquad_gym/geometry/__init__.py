"""Geometry, the bottom layer: module types and their rotor data (:mod:`.module`), grid cells
(:mod:`.cells`), mass properties (:mod:`.inertia`), structures and their configuration matrix
(:mod:`.structure`), and the enumeration of every structure of n modules (:mod:`.polyominoes`)."""

from modquad_gym.geometry.module import (
    DEFAULT_C_TAU,
    DEFAULT_HEIGHT,
    DEFAULT_MASS,
    DEFAULT_SIDE,
    GRAVITY,
    STOCK_TYPES,
    ModuleType,
    TModule,
    palette,
)
from modquad_gym.geometry.structure import Structure, structure_levels

__all__ = [
    "DEFAULT_C_TAU",
    "DEFAULT_HEIGHT",
    "DEFAULT_MASS",
    "DEFAULT_SIDE",
    "GRAVITY",
    "STOCK_TYPES",
    "ModuleType",
    "Structure",
    "TModule",
    "palette",
    "structure_levels",
]
