"""Agents that design modular multirotors: the learned PPO agent and the searches behind one
:class:`~modquad_gym.agents.solvers.Solver` interface, plus the benchmark that compares them.

Importing this package does not import torch; :mod:`modquad_gym.agents.ppo` does, when a PPO
solver is made.
"""

from .solvers import DEFAULT_MODEL, METHODS, SearchSolver, Solver, make_solver

__all__ = ["DEFAULT_MODEL", "METHODS", "SearchSolver", "Solver", "make_solver"]
