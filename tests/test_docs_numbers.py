"""Numbers the pages quote beside each other come from one run, and the typed ones say where
they come from: a table row quoting a run reads every column from it, the task-by-task
comparison is filled from the same CSV, the default methods of ``modquad score`` are the
code's, the reproduce command of a committed report is its own Made-by command and does not
overwrite it, and a five-seed single pass is labelled as one."""

from __future__ import annotations

import csv
import re
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "docs"))
import result_numbers  # noqa: E402


def _page(name: str) -> str:
    return " ".join((ROOT / name).read_text().split())


def _report_row(folder: str, method: str) -> dict[str, str]:
    """The summary row of ``results/FOLDER/benchmark.md`` for ``method``, by column."""
    lines = (ROOT / "results" / folder / "benchmark.md").read_text().splitlines()
    header = next(line for line in lines if line.startswith("| method | tasks |"))
    cells = [c.strip() for c in header.strip("|").split("|")]
    row = next(line for line in lines if line.startswith(f"| {method} | "))
    return dict(zip(cells, [c.strip() for c in row.strip("|").split("|")]))


def test_run_markers_quote_modules_seconds_and_oracle_calls_as_the_report_prints_them():
    for folder, method in (("tier_fault", "ppo"), ("tier_fault", "greedy"), ("tier_mixed", "ppo")):
        row = _report_row(folder, method)
        said = {m: result_numbers.number(f"run {folder} {method} {m}").split(" (")[0]
                for m in ("modules", "seconds", "oracle_calls")}  # fmt: skip
        assert abs(float(said["modules"]) - float(row["mean modules"])) < 0.006, (folder, method)
        assert said["seconds"] == row["seconds / task"], (folder, method)
        assert said["oracle_calls"].replace(",", "") == row["oracle calls / task"], (folder, method)


def test_the_fault_table_reads_every_column_of_a_row_from_one_run():
    """learned-designer.md's fault table: each trained cell is a marker of the same run and
    method (a typed cell beside a filled one kept an older run's numbers)."""
    text = (ROOT / "docs" / "learned-designer.md").read_text()
    table = text.split("| method | optimal, zero-shot |")[1].split("\n\n")[0]
    rows = [line for line in table.splitlines()[2:] if line.startswith("|")]
    assert len(rows) >= 5
    for line in rows:
        cells = [c.strip() for c in line.strip("|").split("|")]
        keys = [re.fullmatch(r"<!--n ([^>]+)-->.*<!--/n-->", c) for c in cells[2:]]
        assert all(keys), line
        runs = {tuple(k[1].split()[:3]) for k in keys}
        assert len(runs) == 1 and next(iter(runs))[:2] == ("run", "tier_fault"), line
        assert [k[1].split()[3] for k in keys] == ["optimal", "modules", "seconds"], line
    for method, rival in (("ppo", "greedy"), ("ppo-k8", "greedy"), ("ppo-guided", "beam")):
        assert f"<!--n pair tier_fault {method} {rival}-->" in text


def test_the_pair_marker_counts_the_tasks_from_the_csv():
    with open(ROOT / "results" / "tier_fault" / "benchmark.csv", newline="") as fh:
        rows = list(csv.DictReader(fh))
    by = {(r["method"], r["task"]): r for r in rows}
    tasks = [t for m, t in by if m == "ppo"]
    diff = [int(by["ppo", t]["n_modules"]) - int(by["greedy", t]["n_modules"]) for t in tasks
            if by["ppo", t]["success"] == "1" and by["greedy", t]["success"] == "1"]  # fmt: skip
    fewer, more = sum(d < 0 for d in diff), sum(d > 0 for d in diff)
    said = result_numbers.number("pair tier_fault ppo greedy")
    assert said.startswith(f"fewer modules than greedy on {fewer} tasks and more on {more} ")
    assert f"(one run, {len(diff)} held-out tasks both solve: {sum(diff) / len(diff):+.2f} " in said


def test_the_benchmarks_page_gives_score_s_default_methods_as_the_code_has_them():
    from modquad_gym.scoring.options import DEFAULT_METHODS, SEARCH_METHODS
    from modquad_gym.scoring.tiers import get_tier

    page = _page("docs/benchmarks.md")
    words = {8: "eight", 9: "nine", 10: "ten", 7: "seven"}
    assert f"the {words[len(SEARCH_METHODS)]} searches of" in page
    assert f"`{' '.join(SEARCH_METHODS)}`" in page
    extra = DEFAULT_METHODS[len(SEARCH_METHODS) :]
    assert DEFAULT_METHODS[: len(SEARCH_METHODS)] == SEARCH_METHODS
    assert f"on the current tier `DEFAULT_METHODS`, the searches and `{' '.join(extra)}`" in page
    assert f"`Tier.learned` (`{' '.join(get_tier('mixed').learned)}`" in page
    large = [m for m in get_tier("large").learned if m not in get_tier("mixed").learned]
    assert f"on the large tier also `{' '.join(large)}`" in page


def test_the_scale_reproduce_command_is_its_made_by_command_into_a_scratch_folder():
    report = (ROOT / "results" / "scale" / "report.md").read_text()
    made = re.search(r"Made by `(python -m benchmarks\.scale [^`]+)`", report)[1]
    for name in ("docs/results.md", "docs/benchmarks.md"):
        text = (ROOT / name).read_text().replace("\\\n", " ")
        commands = [" ".join(c.split()) for c in re.findall(r"^python -m benchmarks\.scale .*$",
                                                             text, re.M)]  # fmt: skip
        assert f"{made} --out /tmp/scale" in commands, name
        for command in commands:  # none rewrites the committed report by default
            assert "--force" not in command or "--out" in command, (name, command)


def test_the_five_seed_single_pass_is_labelled_where_it_is_quoted():
    """The mixed and fault tiers' five seeds were scored before `ppo` took its two more
    passes (their seeds.md say so): wherever a page quotes their `ppo`, it says single pass."""
    single = [t for t in ("current", "large", "mixed", "dynamic", "fault")
              if "rows are the single pass" in (ROOT / "results" / f"seeds_{t}" / "seeds.md")
              .read_text()]  # fmt: skip
    assert set(single) == {"mixed", "fault"}
    pages = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]
    for page in pages:
        text = page.read_text()
        for m in re.finditer(rf"<!--n seeds ({'|'.join(single)}) ppo \w+-->", text):
            before = " ".join(text[max(0, m.start() - 400) : m.start()].split())[-250:]
            assert re.search(r"single pass|one pass", before), (page.name, m[0], before)


def test_the_readme_gives_the_fuzz_tests_fixed_example_counts():
    fuzz = (ROOT / "tests" / "test_fuzz.py").read_text()
    counts = sorted({int(n) for n in re.findall(r"if DEEP else (\d+)", fuzz)})
    said = f"a fixed {counts[0]} to {counts[-1]} examples each" if len(counts) > 1 else (
        f"a fixed {counts[0]} examples each")  # fmt: skip
    assert said in _page("README.md")


def test_no_committed_scale_report_prints_empty_means():
    """A goal line with no task solved by both methods says so in words
    (``benchmarks.scale_report``); the committed reports were re-rendered where it mattered."""
    for report in sorted((ROOT / "results").rglob("report.md")):
        assert " vs  modules" not in report.read_text(), report.relative_to(ROOT)
