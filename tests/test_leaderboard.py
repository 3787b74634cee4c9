"""The leaderboard (benchmarks/leaderboard.py): generated from the committed data files, every
method on every tier, the committed pages up to date, and an outside agent added by one
command."""

from __future__ import annotations

import csv
import importlib.util
import re
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[1]
RESULTS = ROOT / "results"
NUMBER = re.compile(r"-?\d+(?:\.\d+)?")


@pytest.fixture(scope="module")
def board():
    path = ROOT / "benchmarks" / "leaderboard.py"
    spec = importlib.util.spec_from_file_location("benchmarks_leaderboard", path)
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module  # its dataclass looks its module up
    spec.loader.exec_module(module)
    yield module
    sys.modules.pop(spec.name, None)


@pytest.fixture(scope="module")
def entries(board):
    return [e for t in board.TIERS for e in board.tier_entries(t)]


def _same_text(a: str, b: str) -> None:
    """Equal up to the last printed digit of each number (floating point differs between
    CPUs in the last bits: docs/DESIGN)."""
    assert NUMBER.sub("#", a) == NUMBER.sub("#", b)
    for x, y in zip(NUMBER.findall(a), NUMBER.findall(b)):
        places = len(x.partition(".")[2])
        assert abs(float(x) - float(y)) <= 1.01 * 10**-places, (x, y)


def test_every_method_is_on_every_tier(board, entries):
    from modquad_gym.scoring.tiers import get_tier
    from modquad_gym.search import SEARCHES

    for name in board.TIERS:
        tier = get_tier(name)
        methods = {e.method: e for e in entries if e.tier == name}
        assert set(SEARCHES) | set(tier.learned) <= set(methods), name
        for m in tier.learned:
            assert methods[m].kind == "learned" and methods[m].seeds == 5
            assert methods[m].optimal[1] <= methods[m].optimal[0] <= methods[m].optimal[2]
        assert methods["exhaustive"].optimal == (1.0, 1.0, 1.0)  # the optimum is its answer


def test_learned_numbers_are_the_seed_reports_pooled_over_tasks(entries):
    """Recomputed here from seeds.csv: each seed's optimal share over the tier's 100 tasks."""
    with open(RESULTS / "seeds_current" / "seeds.csv", newline="") as fh:
        rows = [r for r in csv.DictReader(fh) if r["method"] == "ppo-guided"]
    per_seed = [
        sum(float(r["optimal"]) * int(r["tasks"]) for r in rows if r["seed"] == s) / 100
        for s in "01234"
    ]
    (entry,) = [e for e in entries if e.tier == "current" and e.method == "ppo-guided"]
    assert entry.optimal[0] == pytest.approx(np.mean(per_seed), abs=1e-12)


def test_search_numbers_are_the_tier_reports(entries):
    with open(RESULTS / "tier_large" / "benchmark.csv", newline="") as fh:
        rows = [r for r in csv.DictReader(fh) if r["method"] == "greedy"]
    (entry,) = [e for e in entries if e.tier == "large" and e.method == "greedy"]
    assert entry.optimal[0] == pytest.approx(np.mean([r["optimal"] == "1" for r in rows]))
    solved = [int(r["n_modules"]) for r in rows if r["success"] == "1"]
    assert entry.modules == pytest.approx(np.mean(solved))
    assert entry.evaluated[0] == pytest.approx(np.mean([int(r["evaluated"]) for r in rows]))


def test_the_committed_pages_are_what_the_command_makes(board, entries):
    results = (RESULTS / "leaderboard.md").read_text()
    docs = (ROOT / "docs" / "leaderboard.md").read_text()
    for text in (results, docs):
        assert "Made by `python -m benchmarks.leaderboard`" in "\n".join(text.splitlines()[:3])
    tiers = list(board.TIERS)
    _same_text(board.page(entries, tiers, "leaderboard.png", ""), results)
    _same_text(board.page(entries, tiers, "results/leaderboard.png", "results/"), docs)
    with open(RESULTS / "leaderboard.csv", newline="") as fh:
        committed = list(csv.DictReader(fh))
    fresh = [e.as_csv() for e in entries]
    assert [(r["tier"], r["method"]) for r in committed] == [
        (r["tier"], r["method"]) for r in fresh
    ]
    for old, new in zip(committed, fresh):
        for key in ("success", "optimal", "evaluated", "seconds", "optimal_low", "optimal_high"):
            assert float(old[key]) == pytest.approx(float(new[key]), rel=1e-5)
    assert (RESULTS / "leaderboard.png").is_file()


def test_an_outside_agent_joins_with_one_command(board, tmp_path, monkeypatch, capsys):
    (tmp_path / "board_agent_for_tests.py").write_text(textwrap.dedent('''
        class Line:
            name = "line"

            def __init__(self, n_max=7):
                self.n_max = n_max

            def solve(self, task, evaluator):
                for n in range(1, self.n_max + 1):
                    if evaluator.evaluate([(i, 0) for i in range(n)]):
                        return [(i, 0) for i in range(n)]
                return None
        '''))  # fmt: skip
    monkeypatch.syspath_prepend(str(tmp_path))
    out = tmp_path / "board"
    argv = ["--solver", "board_agent_for_tests:Line", "--tiers", "current", "--limit", "1",
            "--out", str(out), "--no-progress"]  # fmt: skip
    assert board.main(argv) == 0
    text = (out / "leaderboard.md").read_text()
    assert (
        "| **board_agent_for_tests:Line** (yours) |" in text and "| ppo-guided (5 seeds) |" in text
    )
    assert "scored now, first 1 tasks of each suite" in text
    assert not (ROOT / "docs" / "leaderboard.md").read_text().count("(yours)")
    with pytest.raises(SystemExit) as exit_:
        board.main(["--solver", "board_agent_for_tests:Line"])  # the committed page stays
    assert exit_.value.code == 2 and "--solver needs --out" in capsys.readouterr().err


def test_the_scale_section_is_the_five_seed_scale_reports(board, tmp_path):
    lines = board.scale_section("results/")
    rows = [line for line in lines if line.startswith("| ") and not line.startswith("| band")]
    with open(RESULTS / "scale_seeds_exit" / "report.csv", newline="") as fh:
        after = {r["band"]: r for r in csv.DictReader(fh)}
    assert [row.split(" | ")[0].strip("| ") for row in rows] == list(after)
    for row in rows:  # each band's cells, before and after expert iteration, from the files
        band = row.split(" | ")[0].strip("| ")
        assert after[band]["ppo_solves_greedys_pct"] in row
        assert after[band]["ppo_minus_greedy_modules"] in row
    assert board.scale_section("results/", results=tmp_path) == []  # no reports: no section
