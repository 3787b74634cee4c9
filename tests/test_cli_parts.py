"""The command line's tables: every benchmark name leads to a script with ``main``, and every
``task generate --kind`` builds a task of the asked kind and f_max."""

from __future__ import annotations

import importlib.util

import pytest
from test_fuzz_outputs import MOVED

from benchmarks.common import scripts
from modquad_gym.cli import build_parser
from modquad_gym.tasks import GENERATE_KINDS, generated_task


def _subparser(*names):
    parser = build_parser()
    for name in names:
        (action,) = [a for a in parser._actions if a.dest in ("command", "task_command")]
        parser = action.choices[name]
    return parser


@pytest.fixture(scope="module")
def known_scripts() -> dict[str, str]:
    """:func:`scripts` once for the module: it parses every benchmark's source."""
    return scripts()


@pytest.mark.parametrize("name", list(MOVED))
def test_every_benchmark_is_a_script_with_main(name, known_scripts):
    """The measurement scripts left the package (issue 33): each is ``benchmarks.NAME`` with a
    ``main`` and a docstring saying what it measures."""
    assert name in known_scripts and known_scripts[name], name
    assert importlib.util.find_spec("modquad_gym.bench") is None  # no laboratory in the wheel
    (action,) = [a for a in _subparser("bench")._actions if a.dest == "what"]
    assert action.choices is None  # `modquad bench agents` alone is left, deprecated


@pytest.mark.parametrize("kind", ["total", "external"])
def test_every_generate_kind_builds_its_task(kind):
    (action,) = [a for a in _subparser("task", "generate")._actions if a.dest == "kind"]
    assert tuple(action.choices) == GENERATE_KINDS == ("paper", "planted", "screwdriver")
    for name in GENERATE_KINDS:
        task = generated_task(name, 0, kind, f_max=1.5)
        assert (task.kind, task.f_max) == (kind, 1.5), name
