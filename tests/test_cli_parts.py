"""The command line's tables: every benchmark name leads to a module with ``main``, and every
``task generate --kind`` builds a task of the asked kind and f_max."""

from __future__ import annotations

import ast
import importlib.util

import numpy as np
import pytest

from modquad_gym.cli import build_parser
from modquad_gym.cli.bench import BENCHMARKS
from modquad_gym.cli.task import GENERATE


def _subparser(*names):
    parser = build_parser()
    for name in names:
        (action,) = [a for a in parser._actions if a.dest in ("command", "task_command")]
        parser = action.choices[name]
    return parser


@pytest.mark.parametrize("name", list(BENCHMARKS))
def test_every_benchmark_name_has_a_module_with_main(name):
    module, what = BENCHMARKS[name]
    spec = importlib.util.find_spec(module)
    assert spec is not None and spec.origin, module
    tree = ast.parse(open(spec.origin).read())
    assert any(isinstance(n, ast.FunctionDef) and n.name == "main" for n in tree.body), module
    (action,) = [a for a in _subparser("bench")._actions if a.dest == "what"]
    assert name in action.choices and f"{name}: {what}" in action.help


@pytest.mark.parametrize("kind", ["total", "external"])
def test_every_generate_kind_builds_its_task(kind):
    (action,) = [a for a in _subparser("task", "generate")._actions if a.dest == "kind"]
    assert tuple(action.choices) == tuple(GENERATE) == ("paper", "planted", "screwdriver")
    for name, cls in GENERATE.items():
        task = cls(f_max=1.5, kind=kind)(np.random.default_rng(0))
        assert (task.kind, task.f_max) == (kind, 1.5), name
