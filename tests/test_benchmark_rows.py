"""The benchmarks' ``--rows`` re-renderings (scale, scale_seeds, prune, fallback): rows that no
run writes (impossible bounds, negative counts, unknown families or methods, NaN seconds,
duplicates, a method missing a task) are refused in one line naming the file, the row or the
task, exit 2; the goals judge only the methods that have rows."""

from __future__ import annotations

from pathlib import Path

import pytest

from benchmarks.common import run_script

SCALE = dict(band=16, family="planted", task="t1", method="greedy", planted=16, lower_bound=10,
             found=12, verified=True, gap_to_planted_pct=-25.0, gap_to_bound=2, seconds=1.5,
             peak_MB=10, note="")  # fmt: skip
"""A row of benchmarks.scale's rows.csv with consistent values (each case changes some)."""


def _scale_csv(path: Path, *rows: dict) -> Path:
    from benchmarks.scale import ROW_COLUMNS

    lines = [",".join(ROW_COLUMNS)]
    lines += [",".join(str({**SCALE, **r}[c]) for c in ROW_COLUMNS) for r in rows]
    path.write_text("\n".join(lines) + "\n")
    return path


def _refused(capsys, script: str, argv: list[str], *says: str) -> str:
    assert run_script(script, argv) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "Traceback" not in err, err
    for part in says:
        assert part in err, err
    return err


@pytest.mark.parametrize(
    "row",
    [
        dict(lower_bound=100, gap_to_bound=-88),  # a "certified" bound above a verified answer
        dict(band=-5),
        dict(band=200),
        dict(family="bogusfam"),
        dict(method="bogusmethod"),
        dict(peak_MB=-10),
        dict(lower_bound=-10, gap_to_bound=22),
        dict(planted=-16),
        dict(found="none", gap_to_planted_pct="", gap_to_bound=""),  # verified, no answer
        dict(gap_to_bound=5),  # not the answer's gap
        dict(gap_to_planted_pct=3.0),
    ],
)
def test_scale_refuses_rows_no_run_writes(row, tmp_path, capsys):
    path = _scale_csv(tmp_path / "rows.csv", row)
    out = tmp_path / "out"
    _refused(
        capsys, "scale", ["--rows", str(path), "--out", str(out)], "rows.csv: row 1: not a row"
    )
    assert not out.exists()


def test_scale_refuses_a_bound_above_a_verified_answer_across_rows_and_repeated_rows(
    tmp_path, capsys
):
    """One row's proved bound above another method's verified answer on the same task, and a
    (task, method) given twice in one file, are refused."""
    bound = dict(method="anytime", found="none", verified=False, lower_bound=14,
                 gap_to_planted_pct="", gap_to_bound="")  # fmt: skip
    path = _scale_csv(tmp_path / "a.csv", {}, bound)
    argv = ["--rows", str(path), "--out", str(tmp_path / "out")]
    _refused(capsys, "scale", argv, "task t1: greedy's verified 12 modules lie below the bound 14")
    path = _scale_csv(tmp_path / "b.csv", {}, {})
    argv = ["--rows", str(path), "--out", str(tmp_path / "out")]
    _refused(capsys, "scale", argv, "b.csv: task t1 has two greedy rows")


def test_scale_goals_judge_only_the_methods_with_rows(tmp_path):
    """Rows of greedy and ppo (the default --methods name nine): ppo is judged against greedy
    alone, and no line speaks of a method that did not run."""
    ppo = dict(method="ppo", found=11, gap_to_planted_pct=-31.2, gap_to_bound=1, seconds=0.5)
    path = _scale_csv(tmp_path / "rows.csv", {}, ppo)
    out = tmp_path / "out"
    assert run_script("scale", ["--rows", str(path), "--out", str(out)]) == 0
    text = (out / "report.md").read_text()
    goals = text.split("Goals:")[1].split("![gap vs size]")[0]
    assert "vs greedy: 11.0 vs 12.0 modules" in goals and "Beats 1/1 (greedy): met" in goals
    for absent in ("vs beam", "vs genetic", "vs centrosymmetric", "ppo-guided", "anytime"):
        assert absent not in goals, goals


SEEDS = "band,family,task,method,seed,found,seconds\n"


@pytest.fixture
def seed_rows(tmp_path):
    """A --rows file of benchmarks.scale_seeds from ``text`` (after its header)."""

    def write(text: str) -> Path:
        path = tmp_path / "seeds.csv"
        path.write_text(SEEDS + text)
        return path

    return write


@pytest.mark.parametrize(
    "text, says",
    [
        ("16,planted,t1,greedy,,12,nan\n", "row 1: not a row"),
        ("16,planted,t1,greedy,,12,1.0\n16,planted,t1,ppo,0,-3,2.0\n", "row 2: not a row"),
        ("16,planted,t1,greedy,,12,1.0\n16,planted,t1,ppo,0,11,-2.0\n", "row 2: not a row"),
        ("16,planted,t1,greedy,,12,1.0\n16,planted,t1,beam,,11,2.0\n", "row 2: not a row"),
        ("16,planted,t1,greedy,0,12,1.0\n", "row 1: not a row"),  # greedy has no seed
        ("16,bogus,t1,greedy,,12,1.0\n", "row 1: not a row"),
        ("32,planted,t1,greedy,,12,1.0\n", "row 1: band 32 is not among --bands 16"),
        ("16,planted,t1,ppo,0,11,2.0\n", "task t1 has a ppo seed 0 row and no greedy row"),
        ("16,planted,t1,greedy,,12,1.0\n16,planted,t1,greedy,,11,1.0\n", "two greedy rows"),
    ],
)
def test_scale_seeds_refuses_rows_no_run_writes(text, says, seed_rows, tmp_path, capsys):
    argv = ["--bands", "16", "--rows", str(seed_rows(text)), "--out", str(tmp_path / "out")]
    _refused(capsys, "scale_seeds", argv, "--rows", "seeds.csv", says)
    assert not (tmp_path / "out").exists()


def test_scale_seeds_re_renders_from_its_rows_alone(seed_rows, tmp_path):
    """No model folders needed: the seeds are the rows' (a task a seed did not run counts as
    missed, not as a crash)."""
    text = ("16,planted,t1,greedy,,12,1.0\n16,mixed,t2,greedy,,9,1.0\n"
            "16,planted,t1,ppo,0,11,0.5\n16,mixed,t2,ppo,0,9,0.5\n"
            "16,planted,t1,ppo,3,12,0.5\n")  # fmt: skip
    out = tmp_path / "out"
    argv = ["--bands", "16", "--rows", str(seed_rows(text)), "--runs", str(tmp_path / "none"),
            "--mixed-runs", str(tmp_path / "none"), "--out", str(out)]  # fmt: skip
    assert run_script("scale_seeds", argv) == 0
    report = (out / "report.md").read_text()
    assert "Seeds: 0, 3 (" in report
    assert "| 16 | 3 | 50 | 0 | 0.5 |" in report  # seed 3 did not run t2: missed


def test_prune_refuses_rows_that_lack_a_method_of_a_task(tmp_path, capsys):
    """benchmarks.scale rows of greedy alone, re-rendered for greedy, beam and ppo (each plain
    and pruned): the first missing one is named, where a KeyError used to end the run."""
    path = _scale_csv(tmp_path / "rows.csv", {})
    argv = ["--rows", str(path), "--bands", "16", "--out", str(tmp_path / "out")]
    _refused(capsys, "prune", argv, "rows.csv: task t1 has a greedy row and no greedy+prune row")
    assert not (tmp_path / "out").exists()


FALLBACK = "band,family,task,method,found,seconds,optimum\n"


@pytest.mark.parametrize(
    "text, says",
    [
        ("16,planted,t1,greedy,12,1.0,\n16,planted,t2,ppo-top8-f0,11,2.0,\n",
         "task t1 has a greedy row and no ppo-top8-f0 row"),
        ("16,planted,t1,greedy,12,1.0,\n16,planted,t1,ppo-top8-f0,11,2.0,\n"
         "16,planted,t1,greedy,5,1.0,\n", "task t1 has two greedy rows"),
        ("16,planted,t1,greedy,12,1.0,3\n16,planted,t1,ppo-top8-f0,2,2.0,3\n",
         "row 2: not a row"),  # a verified answer below the certified optimum
        ("16,planted,t1,greedy,12,inf,\n", "row 1: not a row"),
    ],
)  # fmt: skip
def test_fallback_refuses_duplicate_missing_and_impossible_rows(text, says, tmp_path, capsys):
    (tmp_path / "rows.csv").write_text(FALLBACK + text)
    argv = ["--rows", str(tmp_path / "rows.csv"), "--out", str(tmp_path / "out")]
    _refused(capsys, "fallback", argv, "--rows", "rows.csv", says)
    assert not (tmp_path / "out" / "report.md").exists()


def test_the_committed_rows_pass_the_checks():
    """Every committed rows.csv of these benchmarks reads back (the checks refuse only what no
    run writes)."""
    from benchmarks import fallback, scale
    from benchmarks.common import check_task_rows

    results = Path(__file__).resolve().parents[1] / "results"
    header = ",".join(scale.ROW_COLUMNS)
    paths = [p for p in results.rglob("rows.csv") if p.read_text().startswith(header + "\n")]
    assert len(paths) > 10
    for path in paths:
        scale.read_runs([path])
    for path in results.rglob("rows.csv"):
        if path.read_text().startswith(",".join(fallback.COLUMNS) + "\n"):
            rows = [r for r in fallback.read_rows(path) if r["family"] != "small"]
            check_task_rows(rows, {r["method"] for r in rows}, str(path))
