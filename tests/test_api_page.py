"""The API page lists every public name, and the docs call only names that exist."""

from __future__ import annotations

import re
from pathlib import Path

import modquad_gym as mq

ROOT = Path(__file__).resolve().parents[1]
API = (ROOT / "docs" / "api.md").read_text()
ENTRIES = set(re.findall(r"^::: ([\w.]+)", API, re.M))
SUBPACKAGE_NAMES = (
    "modquad_gym.solvers.Evaluator",
    "modquad_gym.solvers.ExternalSolver",
    "modquad_gym.solvers.load_solver",
    "modquad_gym.tasks.make_generator",
    "modquad_gym.tasks.load_suite",
    "modquad_gym.dynamics.circle",
    "modquad_gym.envs.ModQuadAssemblyEnv",
    "modquad_gym.envs.wrappers.NearestValidAction",
    "modquad_gym.policy.DEFAULT_MODEL",
    "modquad_gym.policy.default_model",
    "modquad_gym.search.SEARCHES",
)


def test_every_name_of_the_package_is_on_the_api_page():
    missing = [name for name in mq.__all__ if f"modquad_gym.{name}" not in ENTRIES]
    assert not missing, f"docs/api.md lacks ::: modquad_gym.NAME for {missing}"
    for name in ("beam_search", "genetic_search", "make_solver", "Trajectory", "tolerates",
                 "fault_margin"):  # fmt: skip
        assert f"modquad_gym.{name}" in ENTRIES


def test_the_subpackage_names_users_call_are_on_the_api_page():
    assert set(SUBPACKAGE_NAMES) <= ENTRIES


def test_the_docs_call_only_names_the_package_has():
    """``mq.NAME`` in a page or the README names a public name or a subpackage (``mq.beam_search``
    was used before it was one)."""
    pages = [*(ROOT / "docs").rglob("*.md"), ROOT / "README.md"]
    for page in pages:
        for name in set(re.findall(r"\bmq\.([A-Za-z_]\w*)", page.read_text())):
            assert name in mq.__all__ or name == "__version__" or hasattr(mq, name), (page, name)
