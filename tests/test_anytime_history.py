"""The default search's history and progress line (issue 35, item 1): how the proved bound and
the incumbent improved over time, in the result, in ``modquad solve --json`` and on stderr."""

import io
import json
import time

import numpy as np
import pytest

from modquad_gym.cli import main
from modquad_gym.search import anytime_search, exhaustive_search
from modquad_gym.search import progress as progress_module
from modquad_gym.search.problem import SearchProblem
from modquad_gym.search.progress import ProgressLine, describe
from modquad_gym.search.result import Improvement, SearchRun
from modquad_gym.tasks import TaskRequirement

SOURCES = {"bounds", "exact", "compact", "moves", "beam", "genetic"}


def check_history(r) -> None:
    """Monotone (time, bound up, incumbent down), each event a change, the last one the result."""
    h = r.history
    assert h and h[0].source == "bounds" and {e.source for e in h} <= SOURCES
    for a, b in zip(h, h[1:]):
        assert a.seconds <= b.seconds and a.lower_bound <= b.lower_bound
        assert b.n_modules is not None or a.n_modules is None
        if a.n_modules is not None:
            assert b.n_modules <= a.n_modules
        assert (a.lower_bound, a.n_modules) != (b.lower_bound, b.n_modules)
    assert h[-1].lower_bound == r.lower_bound and h[-1].n_modules == r.n_modules
    assert 0.0 <= h[-1].seconds <= r.seconds


def test_an_easy_task_has_a_short_certified_history():
    r = anytime_search([[0, 0, 3.0, 0, 0, 0]], n_max=6)
    check_history(r)
    assert r.certified and len(r.history) <= 3 and r.history[-1].source == "exact"
    events = r.to_dict()["history"]
    assert [sorted(e) for e in events] == [["lower_bound", "n_modules", "seconds", "source"]] * len(
        events
    )
    assert events[0]["n_modules"] is None and events[-1]["n_modules"] == r.n_modules


def test_local_moves_shrink_the_incumbent_step_by_step():
    from benchmarks.scale_suites import draw

    task = draw("planted", 24, 1, validation=True)  # a validation draw, not a held-out task
    r = anytime_search(task, n_max=32, time_limit=5)
    check_history(r)
    sources = [e.source for e in r.history]
    assert "compact" in sources and sources.count("moves") >= 1


def test_no_structure_proved_at_once_and_other_searches_keep_no_history():
    r = anytime_search([[0, 0, -1.0, 0, 0, 0]], n_max=10)
    check_history(r)
    assert r.structure is None and r.certified and len(r.history) == 1
    plain = exhaustive_search([[0, 0, 3.0, 0, 0, 0]], n_max=4)
    assert plain.history == () and "history" not in plain.to_dict()


def new_run() -> SearchRun:
    return SearchRun("anytime", SearchProblem.build([[0, 0, 3.0, 0, 0, 0]], n_max=4))


def test_an_event_only_when_something_improves():
    run = new_run()
    seen = []
    run.listener = seen.append
    run.improve("bounds", lower_bound=5)
    run.improve("exact", lower_bound=4)  # lower: no event
    run.improve("compact", n_modules=9)
    run.improve("moves", n_modules=9)  # the same: no event
    run.improve("exact", lower_bound=6, n_modules=8)
    assert [(e.lower_bound, e.n_modules, e.source) for e in run.history] == [
        (5, None, "bounds"), (5, 9, "compact"), (6, 8, "exact")]  # fmt: skip
    assert seen == run.history


def test_the_line_says_incumbent_bound_gap_and_time():
    assert describe("anytime", Improvement(1.0, 19, 23, "moves"), 4.21) == (
        "anytime: 23 modules found (moves), bound 19 (gap 17 %), 4.2 s"
    )
    assert "certified" in describe("anytime", Improvement(1.0, 7, 7, "exact"), 1.0)
    assert describe("anytime", Improvement(0.0, 3, None, "bounds"), 0.0) == (
        "anytime: no structure yet, bound 3, 0.0 s"
    )


class Terminal(io.StringIO):
    def isatty(self):
        return True


def test_on_a_terminal_the_line_is_redrawn_in_place(monkeypatch):
    monkeypatch.setattr(progress_module, "REDRAW_SECONDS", 0.01)
    run = new_run()
    stream = Terminal()
    line = ProgressLine(run, stream)
    run.listener = line
    run.improve("bounds", lower_bound=3)
    run.improve("compact", n_modules=4)
    time.sleep(0.15)  # the clock moves between events
    line.close()
    out = stream.getvalue()
    assert out.count("\n") == 1 and out.endswith("\n") and out.count("\r") > 3
    assert "4 modules found (compact), bound 3 (gap 25 %)" in out.split("\r")[-1]
    clocks = {d.rstrip().rsplit(", ", 1)[-1] for d in out.split("\r") if "4 modules" in d}
    assert len(clocks) > 1  # tqdm's line redrawn by the ticker: the seconds move
    silent = Terminal()
    ProgressLine(new_run(), silent).close()  # no event: nothing drawn, not even a line end
    assert silent.getvalue() == ""


def test_in_a_log_a_burst_is_thinned_and_the_last_event_shown():
    run = new_run()
    stream = io.StringIO()
    line = ProgressLine(run, stream)
    run.listener = line
    run.improve("bounds", lower_bound=10)
    for n in range(40, 20, -1):  # local moves: twenty events at once
        run.improve("moves", n_modules=n)
    run.improve("exact", lower_bound=12)  # the bound rises; the incumbent is still the moves'
    line.close()
    lines = stream.getvalue().splitlines()
    assert 2 <= len(lines) <= 4 and lines[0].startswith("anytime: no structure yet, bound 10")
    assert lines[-1].startswith("anytime: 21 modules found (moves), bound 12 (gap 43 %)")


@pytest.fixture
def task_file(tmp_path):
    path = tmp_path / "t.json"
    TaskRequirement(np.array([[0, 0, 5.0, 0, 0, 0], [0.5, 0, 4.0, 0, 0, 0.1]]), "t").save(path)
    return str(path)


def test_cli_json_has_the_history_and_progress_goes_to_stderr(task_file, capsys):
    assert main(["solve", "--task", task_file, "--n-max", "6", "--time-limit", "5", "--json"]) == 0
    captured = capsys.readouterr()
    record = json.loads(captured.out)
    assert captured.err == ""  # --json: no progress
    history = record["history"]
    assert history and history[-1]["n_modules"] == record["n_modules"]
    assert history[-1]["lower_bound"] == record["lower_bound"]
    assert all(set(e) == {"seconds", "lower_bound", "n_modules", "source"} for e in history)

    assert main(["solve", "--task", task_file, "--n-max", "6", "--time-limit", "5"]) == 0
    err = capsys.readouterr().err
    assert "anytime: no structure yet, bound" in err
    assert f"anytime: {record['n_modules']} modules found (exact)" in err
    assert main(["solve", "--task", task_file, "--n-max", "6", "--quiet"]) == 0
    assert capsys.readouterr().err == ""
    assert main(["solve", "--task", task_file, "--n-max", "4", "--method", "exhaustive",
                 "--json"]) == 0  # fmt: skip
    assert "history" not in json.loads(capsys.readouterr().out)
