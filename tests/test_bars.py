"""The one progress-bar helper (:func:`modquad_gym.core.bars.progress_bar`) and its callers: a
bar on stderr only when asked (over items: more than one), removed when closed; the loops that
show one (fault flights, certificate levels, the engine's tasks, hover) use it, none its own."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

from modquad_gym.core.bars import progress_bar

ROOT = Path(__file__).resolve().parents[1]
CALLERS = (
    "sim/fault_flight.py",
    "search/certificates.py",
    "core/distributed.py",
    "sim/hover/run.py",
)


@pytest.mark.parametrize("show, items", [(False, [1, 2, 3]), (True, [1]), (True, [])])
def test_no_bar_unasked_or_over_one_item(capsys, show, items):
    assert progress_bar(show, "cases", "case", items=iter(items)) == items
    assert capsys.readouterr().err == ""


def test_no_bar_to_a_total_unasked(capsys):
    assert progress_bar(False, "level", " structures", total=5) is None
    assert capsys.readouterr().err == ""


def test_a_bar_on_stderr_named_and_counted_then_removed(capsys):
    seen = list(progress_bar(True, "cases", "case", items=iter([1, 2, 3]), mininterval=0))
    err = capsys.readouterr().err
    assert seen == [1, 2, 3] and "cases" in err and "3/3" in err and "case/s" in err
    assert not err.endswith("\n")  # leave=False: the line erased, not kept
    bar = progress_bar(True, "level", " structures", total=5)
    bar.update(5)
    bar.close()
    assert "level" in capsys.readouterr().err and not bar.leave


@pytest.mark.parametrize("path", CALLERS)
def test_the_callers_use_the_helper_not_tqdm(path):
    tree = ast.parse((ROOT / "modquad_gym" / path).read_text())
    imported = {n.module for n in ast.walk(tree) if isinstance(n, ast.ImportFrom)}
    assert "modquad_gym.core.bars" in imported and not {"tqdm", "tqdm.auto"} & imported
