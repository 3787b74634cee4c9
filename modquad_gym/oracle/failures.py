"""The kinds of failure a structure may have to survive, and the columns of A each one stops."""

from __future__ import annotations

import itertools
import numbers

import numpy as np

FAULTS = ("rotor", "module", "rotor2", "rotor+module")
"""The kinds of failure: one rotor stops, one module's rotors all stop, any two rotors stop
(``"rotor2"``: in one module or in two), or one module's rotors and one rotor of another module
(``"rotor+module"``: a module lost, then a rotor elsewhere; a single module: the module)."""


def check_fault(fault: object, *, optional: bool = False) -> str | None:
    """``fault`` when it names a kind of failure (or is None, with ``optional``: no failure),
    else a ValueError listing them (an array is no name: ``in`` would ask for its truth
    value)."""
    if optional and fault is None:
        return None
    if not isinstance(fault, str) or fault not in FAULTS:
        raise ValueError(f"fault must be one of {', '.join(map(repr, FAULTS))}, got {fault!r}")
    return str(fault)


def check_fault_margin(value: object, fault: object = "rotor") -> float:
    """``value`` as a float in [0, 1) (the worst margin required after a failure, in the units
    of :func:`~.faults.fault_margin`), else a one-line ValueError; a positive margin needs a
    ``fault``."""
    if isinstance(value, bool) or not isinstance(value, numbers.Real):  # "0.1", True: no margin
        raise ValueError(f"fault_margin must be a number in [0, 1), got {value!r}")
    mu = float(value)
    if not 0.0 <= mu < 1.0:
        raise ValueError(f"fault_margin must lie in [0, 1), got {value!r}")
    if mu > 0.0 and fault is None:
        raise ValueError(
            "fault_margin applies with a fault (rotor, module, rotor2 or rotor+module)"
        )
    return mu


def failure_sets(
    n_rotors: int, fault: str, rotors_per_module: int = 4, *, nested: bool = False
) -> list[np.ndarray]:
    """The column sets a failure removes from a (6, n_rotors) matrix whose columns are
    grouped by module (``rotors_per_module`` each, in cell order, as
    :meth:`~modquad_gym.geometry.structure.Structure.configuration_matrix` has them): each
    rotor, each module's rotors, each pair of rotors (``"rotor2"``, in the order of
    :func:`itertools.combinations`) or each module's rotors with each rotor of another module
    (``"rotor+module"``). With ``nested`` the combined kinds also list, first, the smaller
    failures they contain (each rotor; each module and each rotor): the sets a margin is
    required after, since failures come one at a time and the margin, measured about each
    failed zonotope's own centre, may be smaller after fewer failures. Feasibility is monotone
    (Z_{S+T} lies in Z_S), so without a margin the combined sets alone decide it."""
    fault = check_fault(fault)
    if fault == "rotor":
        return [np.array([k]) for k in range(n_rotors)]
    if fault == "rotor2":
        pairs = [np.array(pair) for pair in itertools.combinations(range(n_rotors), 2)]
        return (failure_sets(n_rotors, "rotor") if nested else []) + pairs
    if n_rotors % rotors_per_module:
        raise ValueError(
            f"A has {n_rotors} columns, not a multiple of {rotors_per_module} rotors per module"
        )
    return module_failures(np.arange(0, n_rotors + 1, rotors_per_module), fault, nested=nested)


def module_failures(starts: np.ndarray, fault: str, *, nested: bool = False) -> list[np.ndarray]:
    """The failures of kind ``"module"`` or ``"rotor+module"`` of a matrix whose module i owns
    columns starts[i]:starts[i + 1]: each module's columns, with each column of another module
    for ``"rotor+module"`` (a single module: its columns alone, nothing else is left to
    fail); ``nested`` (:func:`failure_sets`) lists each module and each rotor first."""
    modules = [np.arange(a, b) for a, b in zip(starts[:-1], starts[1:])]
    if fault == "module" or len(modules) == 1:
        return modules
    m = int(starts[-1])
    both = [np.append(M, k) for M in modules for k in range(m) if not M[0] <= k <= M[-1]]
    return (modules + [np.array([k]) for k in range(m)] + both) if nested else both
