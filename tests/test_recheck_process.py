"""The fresh process of ``modquad score``'s re-check, and ``--solver``'s refusal of file paths.

The re-check once ran in ``multiprocessing``'s ``spawn`` child, which imports the caller's
``__main__`` again: a user's script calling the scorer imported its agent there, and without an
``if __name__ == "__main__"`` guard it hung. A ``--solver`` file path ran the file, then failed
in words about relative imports.
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

from modquad_gym.core.caches import SOURCES
from modquad_gym.scoring import agents

AGENT = """
import os
with open(os.environ["AGENT_MARKS"], "a") as marks:
    marks.write(f"{os.getpid()}\\n")

class Agent:
    name = "line"
    def solve(self, task, evaluator):
        for n in range(1, 8):
            if evaluator.evaluate([(i, 0) for i in range(n)]):
                return [(i, 0) for i in range(n)]
        return None
"""


def test_a_script_without_a_main_guard_scores_and_its_agent_is_imported_once(tmp_path):
    """The scorer's main() at a script's top level finishes, the re-check checked the rows, and
    the agent's module ran in the scorer's process only."""
    (tmp_path / "myagent.py").write_text(AGENT)
    out = tmp_path / "scores"
    (tmp_path / "run.py").write_text(
        "from modquad_gym.scoring.agents import main\n"
        f"main(['--tier', 'current', '--solver', 'myagent:Agent', '--methods', 'greedy', "
        f"'--limit', '1', '--no-progress', '--out', {str(out)!r}])\n"
    )
    marks = tmp_path / "marks.txt"
    env = {**os.environ, "PYTHONPATH": str(Path(SOURCES).parent), "AGENT_MARKS": str(marks)}
    run = subprocess.run([sys.executable, "run.py"], cwd=tmp_path, env=env, capture_output=True,
                         text=True, timeout=180)  # fmt: skip
    assert run.returncode == 0, run.stderr[-2000:]
    assert "Re-verified in a fresh process" in (out / "benchmark.md").read_text()
    assert len(marks.read_text().split()) == 1  # the scorer's process; the re-check's not


@pytest.mark.parametrize("given", ["./fileagent.py:Agent", "fileagent.py:Agent",
                                   "/abs/fileagent.py:Agent", "sub/fileagent:Agent"])  # fmt: skip
def test_a_solver_file_path_is_refused_in_one_line_before_it_runs(given, tmp_path, monkeypatch,
                                                                   capsys):  # fmt: skip
    (tmp_path / "fileagent.py").write_text(AGENT)
    marks = tmp_path / "marks.txt"
    monkeypatch.setenv("AGENT_MARKS", str(marks))
    monkeypatch.chdir(tmp_path)
    argv = ["--tier", "current", "--solver", given, "--limit", "1", "--no-progress", "--out",
            str(tmp_path / "scores")]  # fmt: skip
    assert agents.script(argv) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err == [
        f"modquad score: error: --solver {given!r}: a file path is not accepted; give "
        "module:Name, the module importable from the current folder (myagent:Agent for "
        "./myagent.py)"
    ]
    assert not marks.exists() and "fileagent" not in sys.modules


def test_score_of_a_shipped_example_suite_is_re_checked(tmp_path, capsys):
    """``--suite example:NAME`` (review 23, F7): the fresh process reads the shipped file the
    scorer read, so the run finishes and its report counts the re-checked rows."""
    from modquad_gym.cli import main

    out = tmp_path / "scores"
    argv = ["score", "--suite", "example:suite_small", "--methods", "greedy", "--no-progress",
            "--out", str(out)]  # fmt: skip
    assert main(argv) == 0, capsys.readouterr().err
    text = (out / "benchmark.md").read_text()
    assert "Re-verified in a fresh process" in text and "example:suite_small" in text


def test_a_re_check_process_that_fails_is_reported_as_that_not_as_a_refusal(tmp_path, capsys):
    """A re-check that gives no verdicts (here: its suite file went away) is its own one-line
    error with the process's last error line, exit code 2; no answer was refused."""
    from modquad_gym.scoring.recheck import recheck, suite_sources
    from modquad_gym.scoring.tiers import get_tier
    from modquad_gym.tasks import load_suite

    suite = tmp_path / "mine.json"
    suite.write_bytes((Path(agents.__file__).parents[1] / "data" / "examples" /
                       "suite_small.json").read_bytes())  # fmt: skip
    rows = agents.run_benchmark({"mine": load_suite(suite)}, ["greedy"], 7, progress=False)
    sources = suite_sources([str(suite)], get_tier("current"), None)
    suite.unlink()
    with pytest.raises(ValueError) as refused:
        recheck(rows, 1, sources, 7, None, None)
    line = str(refused.value)
    assert line.startswith("the fresh process that re-checks the answers failed to run: "
                           "FileNotFoundError: suite file not found: "), line  # fmt: skip
    assert str(suite) in line and "refuses" not in line and "\n" not in line
