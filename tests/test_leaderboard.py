"""The leaderboard (benchmarks/leaderboard*.py): generated from the committed data files, every
method on every tier, the committed pages up to date, and an outside agent added by one
command."""

from __future__ import annotations

import csv
import math
import re
from pathlib import Path

import numpy as np
import pytest

from benchmarks import leaderboard
from benchmarks.leaderboard_entries import BUDGET, RESCORED, TIERS, tier_entries
from benchmarks.leaderboard_page import page, scale_section

ROOT = Path(__file__).resolve().parents[1]
RESULTS = ROOT / "results"
NUMBER = re.compile(r"-?\d+(?:\.\d+)?")


@pytest.fixture(scope="module")
def entries():
    return [e for t in TIERS for e in tier_entries(t)]


def _same_text(a: str, b: str) -> None:
    """Equal up to the last printed digit of each number (floating point differs between
    CPUs in the last bits: docs/DESIGN)."""
    assert NUMBER.sub("#", a) == NUMBER.sub("#", b)
    for x, y in zip(NUMBER.findall(a), NUMBER.findall(b)):
        places = len(x.partition(".")[2])
        assert abs(float(x) - float(y)) <= 1.01 * 10**-places, (x, y)


def test_every_method_is_on_every_tier(entries):
    from modquad_gym.scoring.tiers import get_tier, honours_fault
    from modquad_gym.search import SEARCHES

    for name in TIERS:
        tier = get_tier(name)
        methods = {e.method: e for e in entries if e.tier == name}
        assert set(SEARCHES) | set(tier.learned) <= set(methods), name
        for m in tier.learned:  # five training seeds on every tier
            assert methods[m].kind == "learned" and methods[m].seeds == 5
            assert methods[m].optimal[1] <= methods[m].optimal[0] <= methods[m].optimal[2]
        assert methods["exhaustive"].optimal == (1.0, 1.0, 1.0)  # the optimum is its answer
        for e in methods.values():
            assert bool(e.status) == bool(tier.fault and not honours_fault(e.method)), e
            if e.kind == "search" and not e.status:  # one run: within the budget is optimal
                assert e.budget[0] <= e.optimal[0] and e.tasks == e.full


def test_the_fault_tier_scores_what_honours_the_failure_and_lists_the_rest(entries):
    fault = {e.method: e for e in entries if e.tier == "fault"}
    assert fault["milp"].status.startswith("refused")
    assert {m for m, e in fault.items() if not e.status} == {
        "exhaustive", "centrosymmetric", "greedy", "random", "anytime", "beam", "genetic",
        "ppo", "ppo-k8", "ppo-guided",
    }  # fmt: skip
    for m in ("ppo", "ppo-k8", "ppo-guided"):  # five seeds trained with the failure
        assert fault[m].kind == "learned" and fault[m].seeds == 5
        assert fault[m].source.endswith("seeds_fault/seeds.csv")
    assert fault["ppo"].success[0] >= 0.99  # one seed's single pass misses one task of 60
    assert fault["ppo-k8"].success[0] == fault["ppo-guided"].success[0] == 1.0


def test_each_tiers_prose_counts_the_training_runs_its_rows_average(entries):
    """The sentence above a tier's table says how many training runs its learned rows average,
    read from those rows: the fault tier's rows are five seeds, so its prose says five."""
    from benchmarks.leaderboard_entries import Entry
    from benchmarks.leaderboard_page import tier_section
    from modquad_gym.scoring.tiers import get_tier

    for t in TIERS:
        mine = [e for e in entries if e.tier == t]
        prose = tier_section(t, mine, "")[2]
        if get_tier(t).fault or get_tier(t).model_tier:
            assert {e.seeds for e in mine if e.kind == "learned"} == {5}
            assert "five training seeds" in prose and "one training run" not in prose, t
    one = [Entry(tier="fault", method="ppo", kind="learned", tasks=60, seeds=1, full=60)]
    assert "(the tier's recipe, one training run)" in tier_section("fault", one, "")[2]


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
    assert entry.oracle_calls[0] == pytest.approx(np.mean([int(r["oracle_calls"]) for r in rows]))
    within = [r["optimal"] == "1" and float(r["seconds"]) <= BUDGET for r in rows]
    assert entry.budget[0] == pytest.approx(np.mean(within))


def _table(text: str, tier: str) -> dict[str, dict[str, str]]:
    """The cells of one tier's table on the page, by method (bold and kind marks stripped)."""
    section = text.split(f"## Tier `{tier}`", 1)[1].split("\n## ", 1)[0]
    lines = [line for line in section.splitlines() if line.startswith("| ")]
    head = [c.strip() for c in lines[0].strip("|").split("|")]
    out = {}
    for line in lines[1:]:
        cells = [c.strip() for c in line.strip("|").split("|")]
        out[cells[1].split(" (")[0].strip("*")] = dict(zip(head, cells))
    return out


@pytest.mark.parametrize("tier", ["current", "mixed", "fault"])
def test_the_page_cells_are_the_reports(tier):
    """Each search's cells on the committed page, recomputed here from the tier report's rows
    (or the rescored searches' file) without the leaderboard's code."""
    from modquad_gym.scoring.tiers import get_tier

    n_max = get_tier(tier).n_max
    table = _table((RESULTS / "leaderboard.md").read_text(), tier)
    files = []
    for name in (f"tier_{tier}/benchmark.csv", RESCORED):  # the report's rows first
        with open(RESULTS / name, newline="") as fh:
            files.append([r for r in csv.DictReader(fh) if r["suite"] in get_tier(tier).suites])
    ranks = []
    for method, cells in table.items():
        mine = next(([r for r in rows if r["method"] == method] for rows in files
                     if any(r["method"] == method for r in rows)), [])  # fmt: skip
        mine = [r for r in mine if r["optimum"] and int(r["optimum"]) <= n_max]
        if cells["rank"] == "-" or cells["method"].endswith("seeds)"):
            continue
        within = np.mean([r["optimal"] == "1" and float(r["seconds"]) <= 1.0 for r in mine])
        assert cells[f"optimal within {BUDGET:g} s"] == f"{100 * within:.1f} %", method
        assert cells["tasks"] == str(len(mine))
        calls = np.mean([int(r["oracle_calls"]) for r in mine])
        assert cells["oracle calls / task"] == f"{calls:,.0f}", method
        seconds = np.mean([float(r["seconds"]) for r in mine])
        assert float(cells["seconds / task"]) == pytest.approx(seconds, abs=6e-4), method
        ranks.append((int(cells["rank"]), -within))
    assert [w for _, w in sorted(ranks)] == sorted(w for _, w in ranks)  # ranked at the budget


def test_the_committed_pages_are_what_the_command_makes(entries):
    results = (RESULTS / "leaderboard.md").read_text()
    docs = (ROOT / "docs" / "leaderboard.md").read_text()
    for text in (results, docs):
        assert "Made by `python -m benchmarks.leaderboard`" in "\n".join(text.splitlines()[:3])
    tiers = list(TIERS)
    _same_text(page(entries, tiers, "leaderboard.png", ""), results)
    _same_text(page(entries, tiers, "results/leaderboard.png", "results/"), docs)
    with open(RESULTS / "leaderboard.csv", newline="") as fh:
        committed = list(csv.DictReader(fh))
    fresh = [e.as_csv() for e in entries]
    assert [(r["tier"], r["method"], r["status"]) for r in committed] == [
        (r["tier"], r["method"], r["status"]) for r in fresh
    ]
    for old, new in zip(committed, fresh):
        for key in ("success", "optimal", "budget", "evaluated", "oracle_calls", "seconds",
                    "optimal_low", "optimal_high"):  # fmt: skip
            if old[key] or new[key]:
                assert float(old[key]) == pytest.approx(float(new[key]), rel=1e-5)
    for name in ("leaderboard.png", "leaderboard_anytime.png"):
        assert (RESULTS / name).is_file()


AGENT = '''
class Line:
    """Straight lines of growing length; fails on purpose on the large tier."""

    name = "line"

    def __init__(self, n_max=7, seed=0):
        self.n_max = n_max
        self.seed = seed

    def solve(self, task, evaluator):
        if self.n_max == 12:
            raise RuntimeError("no lines beyond 7 modules")
        for n in range(1, self.n_max + 1):
            if evaluator.evaluate([(i, 0) for i in range(n)]):
                return [(i, 0) for i in range(n)]
        return None
'''


def test_an_outside_agent_joins_with_one_command(tmp_path, monkeypatch, capsys):
    """Its own name, its seeds with an interval, its task count marked partial, a failing tier
    reported beside the others, the fault tier scored; its submission merged."""
    (tmp_path / "board_agent_for_tests.py").write_text(AGENT)
    monkeypatch.syspath_prepend(str(tmp_path))
    out = tmp_path / "board"
    argv = ["--solver", "board_agent_for_tests:Line", "--tiers", "current", "large", "fault",
            "--limit", "1", "--seeds", "0", "1", "--out", str(out), "--no-progress"]  # fmt: skip
    assert leaderboard.main(argv) == 0
    text = (out / "leaderboard.md").read_text()
    current = _table(text, "current")
    assert current["line"]["tasks"] == "2 of 100 (partial)"
    assert "2 seeds" in current["line"]["method"] and "| ppo-guided (5 seeds) |" in text
    assert _table(text, "large")["line"]["optimal within 1 s"].startswith(
        "failed: ValueError: solver 'line' failed"
    )
    fault = _table(text, "fault")["line"]  # scored: the evaluator decides survival
    assert fault["tasks"] == "1 of 60 (partial)" and fault["rank"] != "-"
    with open(out / "submission.csv", newline="") as fh:
        records = list(csv.DictReader(fh))
    assert {r["seed"] for r in records if r["tier"] == "current"} == {"0", "1"}
    assert not (ROOT / "docs" / "leaderboard.md").read_text().count("(outside")
    # merged: the submission in a submissions folder joins the committed board
    (tmp_path / "subs").mkdir()
    (out / "submission.csv").rename(tmp_path / "subs" / "line.csv")
    (merged,) = [e for e in tier_entries("current", submissions=tmp_path / "subs")
                 if e.kind == "outside"]  # fmt: skip
    assert (merged.method, merged.tasks, merged.full, merged.seeds) == ("line", 2, 100, 2)
    with pytest.raises(SystemExit) as exit_:
        leaderboard.main(["--solver", "board_agent_for_tests:Line"])  # the committed page stays
    assert exit_.value.code == 2 and "--solver needs --out" in capsys.readouterr().err
    with pytest.raises(SystemExit) as exit_:  # its files are not replaced without --force
        leaderboard.main([*argv[:-3], "--out", str(out)])
    assert exit_.value.code == 2 and "--force" in capsys.readouterr().err


@pytest.mark.parametrize(
    "argv, says",
    [
        (["--tiers", "current"], "--tiers needs --out: the committed leaderboard holds every tier"),
        (["--limit", "3"], "--limit goes with --solver"),
        (["--seeds", "7", "--out", "x"], "--seeds goes with --solver"),
        (
            ["--seeds", "1", "1", "--solver", "m:S", "--out", "x"],
            "argument --seeds: 1 is given twice",
        ),
    ],
)
def test_options_that_do_not_go_together_are_refused_before_work(argv, says, capsys):
    with pytest.raises(SystemExit) as exit_:
        leaderboard.main(argv)
    assert exit_.value.code == 2
    assert capsys.readouterr().err.strip().splitlines()[-1].endswith(f"error: {says}")


def test_the_scale_section_is_the_five_seed_scale_reports(tmp_path):
    lines = scale_section("results/")
    rows = [line for line in lines if line.startswith("| ") and not line.startswith("| band")]
    with open(RESULTS / "scale_seeds_exit" / "report.csv", newline="") as fh:
        after = {r["band"]: r for r in csv.DictReader(fh)}
    assert [row.split(" | ")[0].strip("| ") for row in rows] == list(after)
    for row in rows:  # each band's cells, before and after expert iteration, from the files
        band = row.split(" | ")[0].strip("| ")
        assert after[band]["ppo_solves_greedys_pct"] in row
        assert after[band]["ppo_minus_greedy_modules"] in row
    assert scale_section("results/", results=tmp_path) == []  # no reports: no section


def test_labels_sit_beside_their_points_without_overlapping():
    """The scatter's labels (leaderboard_figures._place_labels) on a crowded panel: each
    joined to its own point, none overlapping another or leaving the axes."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure
    from matplotlib.text import Text

    from benchmarks.leaderboard_figures import _place_labels

    fig = Figure(figsize=(6, 4))
    FigureCanvasAgg(fig)
    ax = fig.add_subplot()
    ax.set_xscale("log")
    points = [(0.02 * 1.1**i, 95 + (i % 3), f"method-{i}", "k") for i in range(6)]
    ax.plot([p[0] for p in points], [p[1] for p in points], "o")
    ax.set_xlim(1e-3, 1)
    ax.set_ylim(0, 105)
    fig.canvas.draw()
    _place_labels(ax, points)
    renderer = fig.canvas.get_renderer()
    labels = [a for a in ax.texts]
    assert sorted(a.get_text() for a in labels) == sorted(p[2] for p in points)
    boxes = []
    for a in labels:
        a.update_positions(renderer)
        boxes.append(Text.get_window_extent(a, renderer))
        assert a.xy == next((x, y) for x, y, t, _ in points if t == a.get_text())
    frame = ax.get_window_extent(renderer)
    for i, b in enumerate(boxes):
        assert frame.x0 <= b.x0 and b.x1 <= frame.x1 and frame.y0 <= b.y0 and b.y1 <= frame.y1
        assert not any(b.overlaps(c) for c in boxes[i + 1 :])


CLUSTER = [(0.00557, 100.0, "anytime"), (0.00771, 100.0, "exhaustive"),
           (0.010504, 96.55, "greedy"), (0.011084, 98.28, "beam"), (0.005364, 63.79, "random"),
           (0.004802, 22.41, "centrosymmetric"), (0.0323, 95.86, "ppo"),
           (0.0569, 100.0, "ppo-guided"), (0.0927, 99.31, "ppo-k8"), (0.1768, 100.0, "milp"),
           (0.1791, 100.0, "genetic")]  # fmt: skip
"""The dynamic tier's points (seconds, optimal %), whose greedy and beam lines crossed."""


def _crosses(a, b) -> bool:
    def side(p, q, r):
        return (q[0] - p[0]) * (r[1] - p[1]) - (q[1] - p[1]) * (r[0] - p[0])

    (p, q), (r, t) = a, b
    return side(p, q, r) * side(p, q, t) < 0 and side(r, t, p) * side(r, t, q) < 0


def _labelled(cluster: list) -> tuple:
    """A panel like the leaderboard's with ``cluster``'s points labelled as drawn: (its
    labels, the renderer)."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    from benchmarks.leaderboard_figures import _place_labels

    fig = Figure(figsize=(6.4, 4.4), layout="constrained")
    FigureCanvasAgg(fig)
    ax = fig.add_subplot()
    ax.set_xscale("log")
    ax.plot([p[0] for p in cluster], [p[1] for p in cluster], "o", ms=5)
    ax.set_xlim(0.0016, 0.54)
    ax.set_ylim(-5, 112)
    fig.canvas.draw()
    fig.set_layout_engine("none")
    _place_labels(ax, [(x, y, name, "k") for x, y, name in cluster])
    fig.canvas.draw()  # the lines as drawn, in display coordinates
    return ax.texts, fig.canvas.get_renderer()


def test_leader_lines_do_not_cross():
    """On a panel like the leaderboard's, points close together (two at 100 %, two just
    below, each labelled to a side), no two leader lines as drawn cross, and each label is
    still joined to its own point and overlaps no other."""
    from matplotlib.text import Text

    texts, renderer = _labelled(CLUSTER)
    lines = {a.get_text(): a.arrow_patch.get_path().vertices[[0, -1]] for a in texts}
    assert sorted(lines) == sorted(name for _, _, name in CLUSTER)
    names = sorted(lines)
    crossing = [(a, b) for i, a in enumerate(names) for b in names[i + 1 :]
                if _crosses(lines[a], lines[b])]  # fmt: skip
    assert not crossing, crossing
    boxes = [Text.get_window_extent(a, renderer) for a in texts]
    for a in texts:
        assert a.xy == next((x, y) for x, y, name in CLUSTER if name == a.get_text())
    assert not any(b.overlaps(c) for i, b in enumerate(boxes) for c in boxes[i + 1 :])


PAIR = [(0.0143, 88.2, "ppo"), (0.020, 97.0, "ppo-k8")]
"""The current tier's ``ppo`` and ``ppo-k8``: each label sat nearer the other's point."""


@pytest.mark.parametrize("nearer", [True, False])
def test_each_label_lies_nearer_its_own_point(monkeypatch, nearer):
    """Where a place free of clashes lies nearer the label's own point, it is taken (without
    the rule, ``ppo``'s label lands nearer ``ppo-k8``'s point)."""
    from matplotlib.text import Text

    from benchmarks import leaderboard_figures

    if not nearer:
        monkeypatch.setattr(leaderboard_figures, "NEARER", 0)
    texts, renderer = _labelled(PAIR)
    dots = {a.get_text(): a.axes.transData.transform(a.xy) for a in texts}
    own = []
    for a in texts:
        box = Text.get_window_extent(a, renderer)
        centre = ((box.x0 + box.x1) / 2, (box.y0 + box.y1) / 2)
        mine = math.dist(centre, dots[a.get_text()])
        own.append(all(math.dist(centre, d) >= mine for n, d in dots.items() if n != a.get_text()))
    assert all(own) == nearer


def test_the_docs_name_every_committed_mixed_row_file_without_the_type_index():
    """Every committed per-task file whose mixed-tier cells are `x,y` (no type index, so not
    verifiable again on the palette) is named where docs/benchmarks.md says they predate it."""
    from modquad_gym.scoring.tiers import get_tier

    suites = set(get_tier("mixed").suites)
    old = set()
    for path in sorted(RESULTS.rglob("*.csv")):
        with open(path, newline="") as fh:
            reader = csv.DictReader(fh)
            if {"suite", "cells"} <= set(reader.fieldnames or ()):
                cells = [c for r in reader if r["suite"] in suites and r["cells"]
                         for c in r["cells"].split(";")]  # fmt: skip
                if any(c.count(",") == 1 for c in cells):
                    old.add(path.relative_to(ROOT).as_posix())
    text = " ".join((ROOT / "docs" / "benchmarks.md").read_text().split())
    said = text.split("committed per-task rows predate the index", 1)[1].split(". ", 1)[0]
    assert old and all(f"`{p}`" in said for p in old), (old, said)
