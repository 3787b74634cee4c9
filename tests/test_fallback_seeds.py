"""``python -m benchmarks.fallback_seeds``: each decoding's small-task optimal share over several
models' ``benchmarks.fallback`` runs, its gain over the first paired task by task; folders that
do not hold the same tasks and variants are refused in one line."""

from __future__ import annotations

import csv

import pytest

from benchmarks.common import run_script
from benchmarks.fallback import COLUMNS

TASKS = [f"small-0-{i}-planted" for i in range(6)]


def write_run(folder, found: dict[str, list]) -> None:
    """A benchmarks.fallback rows.csv of the small tasks (optimum 4): ``found`` per variant."""
    folder.mkdir()
    with open(folder / "rows.csv", "w", newline="") as f:
        writer = csv.DictWriter(f, COLUMNS)
        writer.writeheader()
        for method, answers in found.items():
            for task, n in zip(TASKS, answers):
                writer.writerow({"band": 7, "family": "small", "task": task, "method": method,
                                 "found": "" if n is None else n, "seconds": 0.5,
                                 "optimum": 4})  # fmt: skip


def test_the_gain_is_paired_and_pooled_over_the_models(tmp_path, capsys):
    write_run(tmp_path / "a", {"single": [4, 5, 4, 5, 4, None], "extra": [4, 4, 4, 5, 4, 4]})
    write_run(tmp_path / "b", {"single": [4, 4, 5, 5, 4, 4], "extra": [4, 4, 4, 4, 4, 4]})
    out = tmp_path / "out"
    assert run_script("fallback_seeds", [str(tmp_path / "a"), str(tmp_path / "b"),
                                         "--out", str(out)]) == 0  # fmt: skip
    rows = {r["variant"]: r for r in csv.DictReader(open(out / "report.csv"))}
    single, extra = rows["single"], rows["extra"]
    assert single["optimal_pct_per_model"] == "50 66.6667" and float(single["gain_pt"]) == 0
    assert extra["optimal_pct_per_model"] == "83.3333 100"
    assert float(extra["optimal_pct"]) == pytest.approx(100 * 11 / 12, abs=0.01)
    assert float(single["success_pct"]) == pytest.approx(100 * 11 / 12, abs=0.01)
    # per task, the gain averaged over the two models: 0, .5, .5, .5, 0, .5 -> mean 1/3
    assert float(extra["gain_pt"]) == pytest.approx(100 / 3, abs=0.01)
    assert 0 < float(extra["gain_low"]) <= float(extra["gain_pt"]) <= float(extra["gain_high"])
    assert "python -m benchmarks.fallback_seeds" in (out / "report.md").read_text()


def test_folders_of_other_tasks_or_variants_are_refused(tmp_path, capsys):
    write_run(tmp_path / "a", {"single": [4] * 6, "extra": [4] * 6})
    write_run(tmp_path / "b", {"single": [4] * 6})
    out = tmp_path / "out"
    code = run_script("fallback_seeds", [str(tmp_path / "a"), str(tmp_path / "b"),
                                         "--out", str(out)])  # fmt: skip
    err = capsys.readouterr().err.strip()
    assert code == 2 and "\n" not in err and "Traceback" not in err
    assert f"FOLDER {tmp_path / 'b'}: not the variants and tasks of the first folder" in err
    assert not (out / "report.md").exists()


def test_a_repeated_row_or_another_optimum_is_refused(tmp_path, capsys):
    """A task with two rows of one variant, or whose certified optimum differs between the
    folders (not the same task), is refused naming the file or folder; neither is pooled."""
    write_run(tmp_path / "a", {"single": [4] * 6, "extra": [4] * 6})
    twice = tmp_path / "twice"
    write_run(twice, {"single": [4] * 6, "extra": [4] * 6})
    with open(twice / "rows.csv", "a") as f:
        f.write(f"7,small,{TASKS[0]},single,5,0.5,4\n")
    other = tmp_path / "other"
    write_run(other, {"single": [4] * 6, "extra": [4] * 6})
    (other / "rows.csv").write_text((other / "rows.csv").read_text().replace(",0.5,4", ",0.5,3"))
    out = tmp_path / "out"
    for folder, words in (
        (twice, f"FOLDER {twice / 'rows.csv'}: task {TASKS[0]} has two single rows"),
        (other, f"FOLDER {other}: task {TASKS[0]}'s optimum is 3, not 4"),
    ):
        code = run_script("fallback_seeds", [str(tmp_path / "a"), str(folder), "--out", str(out)])
        err = capsys.readouterr().err.strip()
        assert code == 2 and "\n" not in err and words in err, err
    assert not (out / "report.md").exists()


def test_against_compares_each_variant_with_the_same_variant_of_another_recipe(tmp_path, capsys):
    write_run(tmp_path / "a", {"single": [4, 5, 4, 5, 4, None], "extra": [4, 4, 4, 5, 4, 4]})
    write_run(tmp_path / "b", {"single": [4, 4, 5, 5, 4, 4], "extra": [4, 4, 4, 4, 4, 4]})
    write_run(tmp_path / "a0", {"single": [5, 5, 4, 5, 4, 4], "extra": [4, 4, 4, 5, 4, 4]})
    write_run(tmp_path / "b0", {"single": [4, 4, 5, 5, 5, 4], "extra": [4, 4, 4, 4, 4, 5]})
    out = tmp_path / "out"
    args = [str(tmp_path / "a"), str(tmp_path / "b"), "--against", str(tmp_path / "a0"),
            str(tmp_path / "b0"), "--out", str(out)]  # fmt: skip
    assert run_script("fallback_seeds", args) == 0
    rows = {r["variant"]: r for r in csv.DictReader(open(out / "report.csv"))}
    single, extra = rows["single"], rows["extra"]
    assert single["against_pct_per_model"] == "50 50" and extra["against_pct_per_model"] == (
        "83.3333 83.3333"
    )
    # single, per task (a - a0 + b - b0) / 2: .5, 0, 0, 0, .5, -.5 -> mean 1/12
    assert float(single["gain_pt"]) == pytest.approx(100 / 12, abs=0.01)
    # extra: 0, 0, 0, 0, 0, .5 -> 1/12
    assert float(extra["gain_pt"]) == pytest.approx(100 / 12, abs=0.01)
    assert "--against" in (out / "report.md").read_text()


def test_against_refuses_a_folder_on_both_sides(tmp_path, capsys):
    for name in ("a", "b"):
        write_run(tmp_path / name, {"single": [4] * 6})
    out = tmp_path / "out"
    args = [str(tmp_path / "a"), str(tmp_path / "b"), "--against", str(tmp_path / "b" / "."),
            "--out", str(out)]  # fmt: skip
    code = run_script("fallback_seeds", args)
    err = capsys.readouterr().err.strip()
    assert code == 2 and "\n" not in err
    assert f"--against {tmp_path / 'b'}: also a FOLDER" in err
    assert not (out / "report.md").exists()
