"""Every test file passes alone: one that asks the oracle for a cross-check method
(``benchmarks.reference_oracle``: ``hrep``, ``quickhull``, ``certified``, ``cvxpy``) registers
them itself, rather than relying on another test file imported before it."""

from __future__ import annotations

import ast
from pathlib import Path

TESTS = Path(__file__).resolve().parent
ONLY_REFERENCE = {"hrep", "quickhull"}
"""Names no product method or field has: a string of them anywhere asks for the method."""
ALSO_A_WORD = {"certified", "cvxpy"}
"""Names of a field or a package too: they count as ``method="..."`` only."""


def _asks(tree: ast.AST) -> bool:
    for node in ast.walk(tree):
        if isinstance(node, ast.Constant) and node.value in ONLY_REFERENCE:
            return True
        if (
            isinstance(node, ast.keyword)
            and node.arg == "method"
            and isinstance(node.value, ast.Constant)
            and node.value.value in ALSO_A_WORD
        ):
            return True
    return False


def _registers(tree: ast.AST) -> bool:
    return any(isinstance(node, ast.Call) and getattr(node.func, "id", None) == "register"
               for node in ast.walk(tree))  # fmt: skip


def test_a_file_that_asks_for_a_reference_method_registers_it():
    missing = []
    for path in sorted(TESTS.glob("test_*.py")):
        if path.name == Path(__file__).name:  # it names them to look for them
            continue
        tree = ast.parse(path.read_text())
        if _asks(tree) and not _registers(tree):
            missing.append(path.name)
    assert not missing
