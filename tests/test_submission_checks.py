"""A leaderboard submission ranks only as one row per (seed, suite, task), the same tasks in every
seed, in a file with the columns the leaderboard reads and known tiers, under a name no committed
method has; its self-reported time is marked so on the page. The forged files are made from the
committed tier report's rows (as an outside submitter could)."""

from __future__ import annotations

import csv
import re
from pathlib import Path

import pytest

from benchmarks import leaderboard
from benchmarks.leaderboard_entries import tier_entries

ROOT = Path(__file__).resolve().parents[1]
REPORT = ROOT / "results" / "tier_current" / "benchmark.csv"
NAME = "outside-agent"


def _report(method: str) -> list[dict]:
    with open(REPORT, newline="") as fh:
        return [r for r in csv.DictReader(fh) if r["method"] == method]


def _as(rows: list[dict], seed: int, **changes) -> list[dict]:
    """The report's rows as an outside agent's submission rows of one seed."""
    return [dict(r, tier="current", seed=str(seed), method=NAME, status="", **changes)
            for r in rows]  # fmt: skip


def _write(path: Path, records: list[dict], keys=None) -> Path:
    from benchmarks.leaderboard_scoring import SUBMISSION_KEYS

    with open(path, "w", newline="") as fh:
        writer = csv.DictWriter(fh, keys or SUBMISSION_KEYS, extrasaction="ignore")
        writer.writeheader()
        writer.writerows(records)
    return path


def _entries(path: Path):
    from benchmarks.leaderboard_entries import submission_entries
    from modquad_gym.scoring.tiers import get_tier

    return submission_entries(path, get_tier("current"), 100)


def _variant(name: str) -> tuple[list[dict], str]:
    """The review's forged submissions (A, C, F) and what the refusal says."""
    best, greedy = _report("exhaustive"), _report("greedy")
    first = re.escape(f"seed '0', task {best[0]['task']!r} of suite {best[0]['suite']!r}")
    return {
        # A: one solved task repeated 100 times: read as 100 tasks, ranked first
        "A": (_as([best[0]] * 100, 0, seconds="0.001"),
              rf"row 2 \(line 3\) repeats row 1: {first}"),
        # C: each of two seeds holds 50 different tasks twice: read as 100 tasks, 2 seeds
        "C": (_as(best[:50] * 2, 0) + _as(best[50:] * 2, 1),
              rf"row 51 \(line 52\) repeats row 1: {first}"),
        # F: seed 1 only its 10 optimal tasks beside seed 0's honest 100: optimal 91 % for 82 %
        "F": (_as(best[:10], 1) + _as(greedy, 0),
              rf"seeds '1' and '0' of '{NAME}' on tier current cover different tasks "
              r"\(10 and 100;"),
    }[name]  # fmt: skip


@pytest.mark.parametrize("name", ["A", "C", "F"])
def test_a_padded_or_cherry_picked_submission_is_refused(name, tmp_path):
    records, says = _variant(name)
    path = _write(tmp_path / f"{name}.csv", records)
    with pytest.raises(ValueError, match=f"^{re.escape(str(path))}: {says}"):
        _entries(path)


def test_a_partial_submission_counts_its_distinct_tasks_in_every_seed(tmp_path):
    best = _report("exhaustive")
    path = _write(tmp_path / "partial.csv", _as(best[:10], 1) + _as(best[:10], 0))
    (entry,) = _entries(path)
    assert (entry.tasks, entry.full, entry.seeds, entry.optimal[0]) == (10, 100, 2, 1.0)


def test_the_task_count_is_of_tasks_not_rows():
    from benchmarks.leaderboard_entries import over_runs, record_row
    from modquad_gym.scoring.tiers import get_tier

    rows = [record_row(r) for r in _report("greedy")[:3]]
    entry = over_runs(get_tier("current"), "greedy", "outside", {"0": rows * 4}, "", 100)
    assert entry.tasks == 3


def _malformed(name: str, tmp_path: Path) -> tuple[Path, str]:
    """A submission file that is not one, and what its refusal says after the file's name."""
    rows = _as(_report("exhaustive")[:3], 0)
    path = tmp_path / f"{name}.csv"
    if name == "no status":
        from benchmarks.leaderboard_scoring import SUBMISSION_KEYS

        _write(path, rows, [k for k in SUBMISSION_KEYS if k != "status"])
        return path, "not a submission file: no column status$"
    if name == "hello":
        path.write_text("hello\n")
        return path, "not a submission file: no column tier, seed, method, status, suite"
    _write(path, rows[:1] + [dict(rows[1], tier="Current")] + rows[2:])
    return path, r"row 2 \(line 3\): tier 'Current' is not a benchmark tier"


@pytest.mark.parametrize("name", ["no status", "hello", "misspelt tier"])
def test_a_malformed_submission_is_one_line_exit_2_on_the_command_line(
    name, tmp_path, monkeypatch, capsys
):
    from benchmarks.common import run_main

    folder = tmp_path / "submissions"
    folder.mkdir()
    path, says = _malformed(name, folder)
    monkeypatch.setattr(leaderboard, "tier_entries",
                        lambda t, results, rescored=None: tier_entries(
                            t, results, submissions=folder, rescored=rescored))  # fmt: skip
    argv = ["--tiers", "current", "--out", str(tmp_path / "board"), "--no-progress"]
    assert run_main(leaderboard.main, "leaderboard", argv) == 2
    (line,) = capsys.readouterr().err.strip().splitlines()
    assert re.match(f"python -m benchmarks.leaderboard: error: {re.escape(str(path))}: {says}",
                    line), line  # fmt: skip
    assert not (tmp_path / "board" / "leaderboard.md").exists()


@pytest.mark.parametrize(
    "name, says",
    [
        ("Exhaustive", "is a committed method's \\(read as 'exhaustive'\\)"),
        ("exhaustive ", "is a committed method's \\(read as 'exhaustive'\\)"),
        ("ｇｒｅｅｄｙ", "is a committed method's \\(read as 'greedy'\\)"),  # fullwidth: NFKC
        ("ppo-guided (5 seeds)", "is a committed method's \\(read as 'ppo-guided'\\)"),
        ("Beam(2)", "is a committed method's \\(read as 'beam'\\)"),
        ("anytime\u200b", "holds an invisible character U\\+200B"),
        ("my\u2060agent", "holds an invisible character U\\+2060"),
        (" ", "is empty"),
    ],
)
def test_a_name_that_imitates_a_committed_one_is_refused(name, says):
    from benchmarks.leaderboard_checks import refuse_taken

    with pytest.raises(ValueError, match=f"^sub.csv: the agent's name {re.escape(repr(name))} "
                       f"{says}"):  # fmt: skip
        refuse_taken(name, "sub.csv")


def test_a_name_of_its_own_passes():
    from benchmarks.leaderboard_checks import refuse_taken

    for name in ("my-agent", "my agent (v2)", "Ångström-net", "greedy-plus"):
        refuse_taken(name, "sub.csv")


def test_an_outside_agents_time_is_marked_self_reported(tmp_path):
    """Its share within the budget and its seconds marked §, the note under its tables; the
    committed rows unmarked; the page says what the rebuild cannot check."""
    from test_leaderboard import _table

    from benchmarks.leaderboard_page import page

    folder = tmp_path / "submissions"
    folder.mkdir()
    _write(folder / "fast.csv", _as(_report("exhaustive")[:10], 0, seconds="0.0001"))
    text = page(tier_entries("current", submissions=folder), ["current"], "x.png", "")
    table = _table(text, "current")
    mine = table.pop(NAME)
    assert mine["optimal within 1 s"] == "100.0 % §" and mine["seconds / task"] == "0.000 §"
    assert mine["tasks"] == "10 of 100 (partial)"
    assert not any("§" in cell for row in table.values() for cell in row.values())
    section = text.split("## Tier `current`", 1)[1].split("\n## ", 1)[0]
    assert "§ Self-reported: an outside agent's seconds per task" in section
    assert "not measured again here" in section
    committed = (ROOT / "docs" / "leaderboard.md").read_text()
    assert "they are not measured again" in committed and "identical seeds" in committed


@pytest.mark.parametrize(
    "column, value, says",
    [
        ("cells", "{digits}", r"cells '.*': expected an integer, got '\u0660'"),
        ("cells", "0,0,0", "cells '0,0,0': each cell is x,y$"),
        ("cells", "0_0,0", "cells '0_0,0': expected an integer, got '0_0'"),
        ("evaluated", "\u0661\u0662", r"evaluated '\u0661\u0662' is not a count"),
        ("seconds", "1_0", "seconds '1_0' is not seconds"),
        ("seconds", "nan", "seconds 'nan' is not seconds"),
    ],
)
def test_a_submitted_number_follows_the_one_number_rule(column, value, says, tmp_path):
    rows = _as(_report("exhaustive")[:3], 0)
    if value == "{digits}":  # the first cell's x in another script's digits
        value = "\u0660" + rows[0]["cells"][1:] if rows[0]["cells"][0] == "0" else None
        assert value is not None, rows[0]["cells"]
    path = _write(tmp_path / "digits.csv", [dict(rows[0], **{column: value})] + rows[1:])
    with pytest.raises(ValueError, match=rf"^{re.escape(str(path))}: row 1 \(line 2\): {says}"):
        _entries(path)
