"""The held-out scale suites (16-64 modules) and `python -m benchmarks.scale`."""

from __future__ import annotations

import os
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from benchmarks.scale_suites import (
    BANDS,
    FAMILIES,
    draw,
    load_scale_suite,
    search_budget,
    task_palette,
    task_seed,
    with_bounds,
)
from modquad_gym.geometry.module import STOCK_TYPES
from modquad_gym.geometry.structure import Structure
from modquad_gym.search import anytime_search, verified


def hidden_structure(task) -> Structure:
    """The structure a scale task was planted in."""
    m = task.meta
    if "hidden_cells" in m:  # the mixed family
        cells = [tuple(c) for c in m["hidden_cells"]]
        return Structure(cells, modules=[STOCK_TYPES[name] for name in m["hidden_modules"]])
    return Structure([tuple(c) for c in m["planted_cells"]])


@pytest.mark.parametrize("band", BANDS)
def test_shipped_suites_hold_their_planted_size_and_bounds(band):
    """Sizes and bounds of every task; the planted structure verified by the exact LP on every
    task up to 64 modules and on the first past it (an LP at 128 modules takes seconds)."""
    tasks = load_scale_suite(band)
    assert {t.meta["family"] for t in tasks} == set(FAMILIES)
    for i, task in enumerate(tasks):
        m = task.meta
        assert m["band"] == band == m["planted"] == hidden_structure(task).n_modules
        if band <= 64 or i == 0:  # the planted size is reachable
            assert verified(hidden_structure(task), task), task.name
        assert m["lift_bound"] <= m["lower_bound"] <= m["planted"]
        if m["best_known"] is not None:
            assert m["lower_bound"] <= m["best_known"] <= search_budget(band)


@pytest.mark.parametrize("band", (16, 64))
def test_shipped_suites_are_redrawn_from_their_seeds(band):
    """Recomputed wrenches match the shipped ones within a tolerance (CPUs differ in the last
    bits), and so do the kind, f_max and palette."""
    counts: dict = {}
    for task in load_scale_suite(band):
        family = task.meta["family"]
        i = counts.setdefault(family, 0)
        counts[family] += 1
        assert task.meta["seed"] == task_seed(family, band, i)
        again = draw(family, band, i)
        np.testing.assert_allclose(again.wrenches, task.wrenches, rtol=1e-12, atol=1e-12)
        assert (again.kind, again.f_max, again.meta["palette"]) == (
            task.kind,
            task.f_max,
            task.meta["palette"],
        )


def test_validation_draws_are_not_held_out_tasks():
    held = {task_seed(f, b, i) for f in FAMILIES for b in BANDS for i in range(100)}
    val = {task_seed(f, b, i, validation=True) for f in FAMILIES for b in BANDS for i in range(100)}
    assert not held & val
    with pytest.raises(ValueError, match="at most 100"):
        task_seed("planted", 16, 100)


def test_bounds_of_a_fresh_draw_never_exceed_its_planted_size():
    task = with_bounds(draw("torque", 16, 0, validation=True), time_limit=3.0)
    m = task.meta
    assert m["lift_bound"] <= m["lower_bound"] <= m["planted"]


def test_anytime_honours_its_time_limit_with_a_palette_at_scale():
    """Regression: with three types the exact levels past the tabulated level sizes were
    taken as fitting, and listing 3^15 type assignments ran for minutes past the limit."""
    task = draw("mixed", 24, 0, validation=True)
    t0 = time.perf_counter()
    r = anytime_search(task, n_max=64, time_limit=3.0, modules=task_palette(task))
    assert time.perf_counter() - t0 < 6.0
    assert r.structure is None or verified(r.structure, task)
    assert r.lower_bound <= task.meta["planted"]


def run_bench(*args, cwd):
    """``python -m benchmarks.scale ARGS`` in ``cwd`` (the repository on the path)."""
    root = str(Path(__file__).resolve().parents[1])
    return subprocess.run(
        [sys.executable, "-m", "benchmarks.scale", *args],
        capture_output=True,
        text=True,
        cwd=cwd,
        env={**os.environ, "PYTHONPATH": os.pathsep.join([root, os.environ.get("PYTHONPATH", "")])},
        timeout=600,
    )


@pytest.mark.slow
def test_bench_scale_writes_its_report_and_refuses_to_overwrite(tmp_path):
    out = tmp_path / "scale"
    args = ["--bands", "16", "--families", "planted", "torque", "--methods", "anytime",
            "greedy", "--time-limit", "2", "--out", str(out)]  # fmt: skip
    done = run_bench(*args, cwd=tmp_path)
    assert done.returncode == 0, done.stderr[-2000:]
    for name in ("report.md", "rows.csv", "summary.csv", "gap_vs_size.png"):
        assert (out / name).stat().st_size > 0
    report = (out / "report.md").read_text()
    assert "python -m benchmarks.scale --bands 16" in report and "Goals:" in report
    assert "never uses more modules than another method" in report
    rows = (out / "rows.csv").read_text().splitlines()
    assert len(rows) == 1 + 2 * 2  # header, 2 tasks x 2 methods
    again = run_bench(*args, cwd=tmp_path)
    assert again.returncode == 2 and "--force" in again.stderr
    # re-rendered in place from its own rows: --force must not clear them before they are read
    again = run_bench(*args, "--rows", str(out / "rows.csv"), "--force", cwd=tmp_path)
    assert again.returncode == 0, again.stderr[-2000:]
    assert len((out / "rows.csv").read_text().splitlines()) == len(rows)
    assert "re-rendered by" in (out / "report.md").read_text()


def test_bench_scale_refuses_bad_options_in_one_line(tmp_path):
    for bad in (["--methods", "nope"], ["--time-limit", "0"], ["--bands", "65"]):
        done = run_bench(*bad, "--out", str(tmp_path / "x"), cwd=tmp_path)
        assert done.returncode == 2, (bad, done.stderr)
        last = done.stderr.strip().splitlines()[-1]  # argparse prints its usage first
        assert "error" in last and bad[0] in last and "Traceback" not in done.stderr


def test_the_portfolio_goals_count_tasks_and_name_who_beat_it():
    from benchmarks.scale_report import portfolio_goal_lines

    def row(task, method, found, bound=10):
        return {"task": task, "method": method, "found": found, "lower_bound": bound}

    rows = [row("a", "anytime", 10), row("a", "beam", 12),  # certified, best
            row("b", "anytime", 20), row("b", "beam", 18), row("b", "greedy", 19),
            row("c", "anytime", "none"), row("c", "genetic", 30)]  # fmt: skip
    never_worse, gap = portfolio_goal_lines(rows)
    assert "1 of 3 tasks" in never_worse and "NOT met" in never_worse
    assert "b (beam 18 vs 20)" in never_worse and "c (genetic 30 vs none)" in never_worse
    assert "1 of 3 tasks, worst 100.0 % (c)" in gap and gap.endswith("NOT met")
    never_worse, gap = portfolio_goal_lines(rows[:2])
    assert never_worse.endswith("met") and "1 of 1 tasks" in never_worse and "0.0 %" in gap


def test_the_report_names_the_bands_run_and_says_when_no_task_was_both_solved():
    """One band run: the title and goal lines name it (not a range of bands the run did not
    have), and a rival with no task solved by both is said in words, not as empty means."""
    import argparse

    from benchmarks.scale_report import goal_lines, report, summary

    def row(task, method, found):
        solved = found != "none"
        return {"band": 64, "family": "planted", "task": task, "method": method, "planted": 64,
                "lower_bound": 58, "found": found, "verified": solved,
                "gap_to_planted_pct": round(100 * (found - 64) / 64, 1) if solved else "",
                "gap_to_bound": found - 58 if solved else "", "seconds": 2.0, "peak_MB": 100,
                "note": ""}  # fmt: skip

    rows = [row("a", "ppo", 58), row("a", "greedy", "none"), row("a", "beam", 61),
            row("b", "ppo", "none"), row("b", "greedy", 60), row("b", "beam", 60)]  # fmt: skip
    methods = ["greedy", "beam", "ppo"]
    (line,) = [g for g in goal_lines(rows, methods, 60) if g.startswith("- learned")]
    assert line.startswith("- learned `ppo` at 64 modules ")
    assert "vs greedy: no task both solved, so no modules to compare, solved 1 vs 1 of 2" in line
    assert "vs beam: 58.0 vs 61.0 modules on the 1 tasks both solved" in line
    assert " vs  modules" not in line
    args = argparse.Namespace(bands=[16, 32, 64], families=["planted"], per_family=1,
                              methods=methods, time_limit=60.0, workers=1, validation=False,
                              seed=0, model=None, rows=None, out="results/scale")  # fmt: skip
    page = report(rows, summary(rows), args)
    assert page.startswith("# Every method at 64 modules\n")  # the rows' band, not 16-64


def test_runs_merge_with_the_largest_bound_and_later_rows_first(tmp_path):
    from benchmarks.common import write_csv
    from benchmarks.scale import read_runs

    def row(task, method, found, bound, band=16):
        solved = found != "none"  # the gaps as benchmarks.scale writes them
        return {"band": band, "family": "planted", "task": task, "method": method, "planted": 16,
                "lower_bound": bound, "found": found, "verified": solved,
                "gap_to_planted_pct": round(100 * (found - 16) / 16, 1) if solved else "",
                "gap_to_bound": found - bound if solved else "", "seconds": 1.0,
                "peak_MB": 100, "note": ""}  # fmt: skip

    write_csv([row("a", "anytime", 14, 12), row("a", "ppo", 16, 12)], tmp_path / "one.csv")
    write_csv([row("a", "ppo", 15, 13), row("b", "ppo", "none", 20, 32)], tmp_path / "two.csv")
    rows = read_runs([tmp_path / "one.csv", tmp_path / "two.csv"])
    by = {(r["task"], r["method"]): r for r in rows}
    assert len(rows) == 3 and by["a", "ppo"]["found"] == 15  # the later run's row
    assert by["a", "anytime"]["lower_bound"] == 13 and by["a", "anytime"]["gap_to_bound"] == 1
    assert by["b", "ppo"]["gap_to_bound"] == "" and [r["band"] for r in rows] == [16, 16, 32]


def test_scale_seeds_summary_compares_each_seed_with_greedy():
    """benchmarks.scale_seeds: per seed, the share of greedy's solved tasks ppo solves, the
    modules above greedy's on tasks both solve, and the time ratio; then over the seeds."""
    from benchmarks.scale_seeds import band_summary, per_seed_table

    def row(task, method, seed, found, seconds):
        return {"band": 16, "family": "planted", "task": task, "method": method, "seed": seed,
                "found": found, "seconds": seconds}  # fmt: skip

    greedy = [("a", 10, 1.0), ("b", 12, 1.0), ("c", None, 1.0)]
    seed0 = [("a", 10, 0.5), ("b", 14, 0.5), ("c", 9, 1.0)]
    seed1 = [("a", 11, 1.0), ("b", None, 1.0), ("c", None, 1.0)]
    rows = [row(t, "greedy", "", n, s) for t, n, s in greedy]
    rows += [row(t, "ppo", "0", n, s) for t, n, s in seed0]
    rows += [row(t, "ppo", "1", n, s) for t, n, s in seed1]
    s = band_summary(rows, 16)
    assert (s["tasks"], s["greedy_solved"], s["seeds"], s["ppo_every_seed_all"]) == (3, 2, 2, 1)
    # seed 0 solves both of greedy's (100 %), seed 1 one (50 %); +1 and +1 modules; 2/3, 1
    assert s["ppo_solves_greedys_pct"].startswith("75.0 [50.0, 100.0]")
    assert s["ppo_minus_greedy_modules"] == "+1.00 [+1.00, +1.00]"
    assert s["ppo_over_greedy_seconds"].startswith("0.83 [0.67, 1.00]")
    (one, two) = per_seed_table(rows, [16])  # the report's per-seed lines, the same scores
    assert (one["seed"], one["ppo_solves_greedys_pct"], one["ppo_minus_greedy_modules"]) == (
        "0",
        100.0,
        1.0,
    )
    assert (two["ppo_solves_greedys_pct"], two["ppo_over_greedy_seconds"]) == (50.0, 1.0)
    assert one["ppo_over_greedy_seconds"] == 0.67


def test_scale_seeds_refuses_foreign_rows_in_one_line(tmp_path, capsys):
    """--rows of another report, or a row with a word for a number: exit 2, one line naming the
    file, the row or the missing column; nothing is written."""
    from benchmarks.common import run_script

    runs = tmp_path / "runs" / "seed-0"
    runs.mkdir(parents=True)
    (runs / "model.zip").write_bytes(b"")
    header = "band,family,task,method,seed,found,seconds\n"
    foreign = "band,family,task,method,found\n16,planted,a,ppo,3\n"
    cases = {"foreign.csv": (foreign, "its header is not band,family,task,method,seed"),
             "bad.csv": (header + "16,planted,a,ppo,0,three,1.0\n", "row 1: not a row of"),
             "empty.csv": (header, "no rows")}  # fmt: skip
    for name, (text, message) in cases.items():
        (tmp_path / name).write_text(text)
        argv = ["--rows", str(tmp_path / name), "--runs", str(tmp_path / "runs"), "--mixed-runs",
                str(tmp_path / "runs"), "--out", str(tmp_path / "out")]  # fmt: skip
        assert run_script("scale_seeds", argv) == 2
        err = capsys.readouterr().err.strip()
        assert len(err.splitlines()) == 1 and message in err and name in err, err
    assert not (tmp_path / "out" / "report.md").exists()


def test_scale_models_compares_each_model_with_greedy_per_family_and_band():
    """benchmarks.scale_models: per model, family and band, greedy's solved tasks it solves and
    its modules minus greedy's on the tasks both solve, with a bootstrap interval."""
    from benchmarks.scale_models import summary, versus_greedy

    def row(task, family, method, found, seconds=1.0):
        return {"band": 16, "family": family, "task": task, "method": method, "found": found,
                "seconds": seconds}  # fmt: skip

    rows = [row("a", "torque", "greedy", 10), row("b", "torque", "greedy", 12),
            row("c", "planted", "greedy", None), row("a", "torque", "new", 9, 0.5),
            row("b", "torque", "new", None, 0.5), row("c", "planted", "new", 15, 0.5)]  # fmt: skip
    everything = versus_greedy(rows, "new")
    assert (everything["greedy_solved"], everything["solves_of_greedys"], everything["solved"]) == (
        2,
        1,
        2,
    )
    assert everything["minus_greedy_modules"] == -1.0  # one task both solve: no interval
    assert np.isnan(everything["low"]) and np.isnan(everything["high"])
    assert everything["fewer"] == 1 and everything["over_greedy_seconds"] == 0.5
    planted = versus_greedy(rows, "new", 16, "planted")  # greedy solved none: no difference
    assert planted["greedy_solved"] == 0 and np.isnan(planted["minus_greedy_modules"])
    table = summary(rows, ["new"], [16], ["planted", "torque"])
    assert [(r["band"], r["family"]) for r in table] == [("all", "all"), (16, "planted"),
                                                         (16, "torque")]  # fmt: skip


def test_scale_models_refuses_a_model_without_a_name_in_one_line(tmp_path, capsys):
    from benchmarks.common import run_script

    for argv, message in ((["--models", "model.zip"], "give NAME=ZIP"),
                          (["--models", "a=missing.zip"], "--models a=missing.zip")):  # fmt: skip
        assert run_script("scale_models", [*argv, "--out", str(tmp_path / "out")]) == 2
        err = capsys.readouterr().err.strip()
        assert len(err.splitlines()) == 1 and message in err, err
    from modquad_gym.policy import SCALE_MODEL

    foreign = tmp_path / "foreign.csv"
    foreign.write_text("band,family,task,method,found,seconds\n16,torque,a,greedy,three,1.0\n")
    argv = ["--models", f"m={SCALE_MODEL}", "--reuse", str(foreign)]
    assert run_script("scale_models", [*argv, "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "foreign.csv: row 1" in err, err
    assert not (tmp_path / "out").exists()


def test_prune_benchmark_compares_each_method_with_and_without_the_post_pass(tmp_path, capsys):
    """benchmarks.prune: what pruning removed per method, and ppo+prune against greedy and
    greedy+prune per family and band (verified answers only); bad options exit 2 in one line."""
    from benchmarks.common import run_script
    from benchmarks.prune import goal_lines, method_rows, versus_rows
    from benchmarks.scale import without_prune

    assert without_prune("ppo+prune") == ("ppo", True)
    assert without_prune("ppo-guided") == ("ppo-guided", False)

    def row(task, family, method, found, verified=True, seconds=1.0):
        return {"band": 16, "family": family, "task": task, "method": method, "found": found,
                "verified": verified, "seconds": seconds}  # fmt: skip

    rows = [row("a", "torque", "greedy", 14), row("a", "torque", "greedy+prune", 13),
            row("a", "torque", "ppo", 15, seconds=0.2), row("a", "torque", "ppo+prune", 13,
                                                            seconds=0.3),
            row("b", "planted", "greedy", 20), row("b", "planted", "greedy+prune", 20),
            row("b", "planted", "ppo", "none", False, 0.2),
            row("b", "planted", "ppo+prune", 21, False, 0.3)]  # fmt: skip
    greedy, ppo = method_rows(rows, ["greedy", "ppo"])
    assert (greedy["modules"], greedy["modules_pruned"], greedy["tasks_pruned"]) == (17, 16.5, 1)
    assert (ppo["answered"], ppo["answered_pruned"], ppo["tasks_pruned"]) == (1, 1, 1)
    assert ppo["seconds_ratio"] == 1.5
    against = versus_rows(rows, "ppo+prune", ["greedy", "greedy+prune"], [16],
                          ["torque", "planted"])  # fmt: skip
    total = {v["rival"]: v for v in against if v["band"] == "all"}
    assert (total["greedy"]["difference"], total["greedy"]["missed"]) == (-1.0, 1)
    assert (total["greedy+prune"]["difference"], total["greedy+prune"]["both"]) == (0.0, 1)
    (line,) = goal_lines(against)  # one plain rival: torque -1 module, planted's task missed
    assert line.startswith("- `ppo+prune` against greedy") and line.endswith("NOT met")
    assert "1 of 2: planted-16 (missed 1)" in line
    out = tmp_path / "out"
    for argv, message in (
        (["--methods", "anytime"], "argument --methods: invalid choice: 'anytime'"),
        (["--bands", "20"], "--bands 20: no held-out suite of that size"),
        (["--time-limit", "0"], "--time-limit: "),
    ):  # argparse's usage, then its one-line error; a ValueError: the line alone
        assert run_script("prune", [*argv, "--out", str(out)]) == 2
        err = capsys.readouterr().err.strip()
        assert message in err.splitlines()[-1], err
    assert not (out / "report.md").exists()


def test_prune_without_a_learned_method_reports_what_pruning_removed(tmp_path, capsys):
    """`--methods greedy` (no learned method to compare): the page says so and no versus.csv
    is written, where the run used to end in a traceback after all its solving."""
    from benchmarks.common import run_script

    earlier = Path(__file__).parents[1] / "results" / "prune" / "16-64" / "rows.csv"
    lines = earlier.read_text().splitlines()
    rows = tmp_path / "rows.csv"
    rows.write_text("\n".join([lines[0], *(x for x in lines if ",greedy" in x)]) + "\n")
    out = tmp_path / "out"
    argv = ["--rows", str(rows), "--methods", "greedy", "--bands", "16", "32", "64",
            "--per-family", "3", "--out", str(out)]  # fmt: skip
    assert run_script("prune", argv) == 0, capsys.readouterr().err
    assert "No comparison (no `versus.csv`)" in (out / "report.md").read_text()
    assert (out / "methods.csv").exists() and not (out / "versus.csv").exists()


def test_scale_models_and_scale_seeds_write_their_rows_in_their_columns(monkeypatch):
    """One row builder serves both benchmarks: each row has its benchmark's columns, in order
    (what --reuse and --rows read back), found only where verified."""
    from types import SimpleNamespace

    import benchmarks.scale_models as models
    import benchmarks.scale_seeds as seeds

    tasks = [SimpleNamespace(name=n, meta={"family": "torque"}) for n in ("a", "b")]
    results = [{"found": 14, "verified": True, "seconds": 1.23456},
               {"found": 9, "verified": False, "seconds": 0.5}]  # fmt: skip
    monkeypatch.setattr(models, "fresh", lambda *args: results)
    mine = models.solve((16, "new", tasks, "model.zip"), 30.0)
    assert [tuple(r) for r in mine] == [models.COLUMNS] * 2
    assert (mine[0]["method"], mine[0]["found"], mine[0]["seconds"]) == ("new", 14, 1.235)
    assert mine[1]["found"] is None
    theirs = seeds.solve((32, "ppo", "3", tasks, "model.zip"), 30.0)
    assert [tuple(r) for r in theirs] == [seeds.COLUMNS] * 2
    assert (theirs[0]["band"], theirs[0]["method"], theirs[0]["seed"]) == (32, "ppo", "3")
