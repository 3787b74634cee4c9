"""Optional dependencies: import them where they are used, with an error that names the extra.

The core install (numpy, scipy, gymnasium, DAQP, numba, tqdm) answers feasibility and search
questions; training, simulation, pictures, the cvxpy reference and Ray are package extras.
"""

from __future__ import annotations

import importlib
import importlib.util
from types import ModuleType

EXTRA_OF = {
    "torch": "train",
    "stable_baselines3": "train",
    "sb3_contrib": "train",
    "tensorboard": "train",
    "mujoco": "sim",
    "matplotlib": "viz",
    "pygame": "viz",
    "moviepy": "viz",
    "plotly": "viz",
    "cvxpy": "test",
    "ray": "distributed",
}
"""Top-level module name -> the extra of ``pip install 'modquad_gym[extra]'`` that brings it."""


def missing_extra_message(module: str) -> str:
    """One line telling which extra installs ``module`` (a dotted name is fine)."""
    top = module.split(".")[0]
    extra = EXTRA_OF.get(top, "all")
    return f"{top} is not installed; install it with: pip install 'modquad_gym[{extra}]'"


def require(*modules: str) -> None:
    """An ImportError naming the extra to install for the first of ``modules`` that is not
    installed (found without importing it): a command checks before any work."""
    for module in modules:
        if importlib.util.find_spec(module.split(".")[0]) is None:
            raise ImportError(missing_extra_message(module))


def import_optional(module: str) -> ModuleType:
    """``importlib.import_module(module)``, or an ImportError naming the extra to install."""
    try:
        return importlib.import_module(module)
    except ModuleNotFoundError as err:
        if err.name and module.split(".")[0] != err.name.split(".")[0]:
            raise  # a dependency of the optional package itself is missing: say it as it is
        raise ImportError(missing_extra_message(module)) from err
