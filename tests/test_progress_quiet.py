"""Progress on stderr and ``--quiet`` (review limits, findings 3 and 4): ``modquad optima``
shows the exhaustive search's bar per level for a task searched in its own process, the
level bar moves while a chunk is decided, ``show``, ``export`` and ``validate`` take solve's
``--quiet`` (one definition), and ``validate`` shows a bar over its hovers' simulated
seconds."""

from __future__ import annotations

import os

os.environ.setdefault("MUJOCO_GL", "egl")  # before mujoco is imported: headless rendering

import json  # noqa: E402

import pytest  # noqa: E402
from test_hardening import run_main  # noqa: E402

from modquad_gym.cli.quiet import QUIET_HELP  # noqa: E402
from modquad_gym.core.distributed import Engine  # noqa: E402
from modquad_gym.search import exhaustive, levels, optimal_level  # noqa: E402
from modquad_gym.search.levels import ChunkBar, level_size  # noqa: E402
from modquad_gym.tasks import generated_task  # noqa: E402

SEARCH_LINE = "anytime: "
"""The default search's progress line on stderr."""


class Bar:
    """A progress bar that records its updates (in place of tqdm's)."""

    def __init__(self, n: int | None = None) -> None:
        self.n, self.updates, self.closed = n, [], False

    def update(self, k) -> None:
        self.updates.append(k)

    def close(self) -> None:
        self.closed = True


@pytest.fixture
def bars(monkeypatch) -> list[Bar]:
    """The level bars the exhaustive search makes, recorded."""
    made: list[Bar] = []

    def level_progress(enabled: bool, n: int):
        if not enabled:
            return None
        made.append(Bar(n))
        return made[-1]

    monkeypatch.setattr(exhaustive, "level_progress", level_progress)
    return made


def flat(text: str) -> str:
    return " ".join(text.split())


# --- --quiet: one definition, in every command that searches ----------------------------------
@pytest.mark.parametrize("command", ["solve", "show", "export", "validate"])
def test_quiet_is_solves_option_in_every_searching_command(capsys, command):
    code, out, _ = run_main(capsys, command, "--help")
    assert code == 0
    solve_words = QUIET_HELP.format(also="").removesuffix(")")  # validate adds its hover
    assert "--quiet" in out and flat(solve_words) in flat(out), out


def test_optima_help_says_what_quiet_silences(capsys):
    code, out, _ = run_main(capsys, "optima", "--help")
    assert code == 0
    assert "also the exhaustive search's bar per level" in flat(out)


@pytest.mark.parametrize("command", ["show", "export"])
def test_quiet_silences_the_search_line(tmp_path, capsys, command):
    suffix = ".png" if command == "show" else ".json"
    argv = [command, "--task", "example:screwdriver", "--force"]
    code, _, err = run_main(capsys, *argv, "--out", str(tmp_path / f"a{suffix}"))
    assert code == 0 and SEARCH_LINE in err, err
    code, _, err = run_main(capsys, *argv, "--out", str(tmp_path / f"b{suffix}"), "--quiet")
    assert code == 0 and SEARCH_LINE not in err, err


def test_quiet_with_progress_option_is_refused_in_show(tmp_path, capsys):
    """``--quiet`` means what it means in solve: ``--option progress=true`` contradicts it."""
    argv = ["show", "--task", "example:screwdriver", "--out", str(tmp_path / "s.png"), "--quiet"]
    code, _, err = run_main(capsys, *argv, "--option", "progress=true")
    assert code == 2 and "contradicts --quiet" in err, err


# --- validate: the hovers' bar ----------------------------------------------------------------
@pytest.fixture
def one_wrench(tmp_path):
    task = tmp_path / "task.json"
    task.write_text(json.dumps({"wrenches": [[0.0, 0.0, 3.0, 0.0, 0.0, 0.0]]}))
    return task


def test_validate_shows_a_hover_bar_that_quiet_silences(tmp_path, capsys, one_wrench):
    argv = ["validate", "--task", str(one_wrench), "--known-load-only"]
    argv += ["--hover-seconds", "0.5", "--max-hover-wrenches", "1"]
    code, _, err = run_main(capsys, *argv, "--out", str(tmp_path / "a"))
    assert code == 0, err
    assert "hover: " in err and "simulated s" in err, err  # the bar
    assert SEARCH_LINE in err, err
    code, _, err = run_main(capsys, *argv, "--out", str(tmp_path / "b"), "--quiet")
    assert code == 0, err
    assert "hover: " not in err and SEARCH_LINE not in err, err
    assert err.startswith("validate: bench on 1 wrenches"), err  # the estimate stays


def test_run_hover_tells_each_segment_its_planned_seconds():
    from modquad_gym.geometry.structure import Structure
    from modquad_gym.sim.hover import HoverConfig, run_hover

    seen: list[float] = []
    W = [[0.0, 0.0, 3.0, 0.0, 0.0, 0.0], [0.1, 0.0, 3.0, 0.0, 0.0, 0.0]]
    config = HoverConfig(seconds_per_wrench=0.2, takeoff_seconds=0.3)
    run_hover(Structure([(0, 0), (1, 0)]), W, config, on_segment=seen.append)
    assert seen == pytest.approx([0.3, 0.2, 0.2])  # the take-off, then each wrench


def test_validate_python_door_progress(capsys):
    from modquad_gym.geometry.structure import Structure
    from modquad_gym.sim.validate import validate

    structure, task = Structure([(0, 0), (1, 0)]), [[0.0, 0.0, 3.0, 0.0, 0.0, 0.0]]
    options = dict(hover_seconds=0.2, unknown_load=False, render=False)
    with pytest.raises(ValueError, match="progress must be True or False"):
        validate(structure, task, progress="yes", **options)
    validate(structure, task, **options)
    assert "hover" not in capsys.readouterr().err  # off by default
    validate(structure, task, progress=True, **options)
    assert "simulated s" in capsys.readouterr().err


# --- the exhaustive search's bar, within a task -----------------------------------------------
def test_the_level_bar_moves_within_a_chunk(bars):
    """Level 6 (216 structures) is one chunk: its bar moved many times, up to the whole level,
    and the answer is the same without a bar."""
    task = generated_task("planted", 0, n_modules=6)
    shown = optimal_level(task, n_max=7, progress=True)
    assert [b.n for b in bars] == [6]
    assert len(bars[0].updates) > 1 and sum(bars[0].updates) == level_size(6)
    assert bars[0].closed
    plain = optimal_level(task, n_max=7)
    assert (plain.n_modules, plain.keys, plain.count) == (shown.n_modules, shown.keys, shown.count)
    assert (plain.evaluated, plain.oracle_calls) == (shown.evaluated, shown.oracle_calls)


def test_chunk_bar_counts_each_structure_once():
    bar = Bar()
    moves = ChunkBar(bar, 10)
    moves.seen(3)
    moves.start = 4  # a feasible structure at index 3: the next slice starts after it
    moves.seen(2)
    moves.seen(1)  # already counted
    moves.close()
    assert bar.updates == [3, 3, 4] and sum(bar.updates) == 10
    ChunkBar(None, 10).close()  # no bar: nothing to move


def test_optima_shows_the_level_bar_with_one_worker(tmp_path, capsys, monkeypatch):
    monkeypatch.setattr(levels, "BAR_DELAY", 0.0, raising=False)  # drawn at once
    task = tmp_path / "p.json"
    generated_task("planted", 0, n_modules=6).save(task)
    argv = ["optima", "--task", str(task), "--n-max", "7", "--workers", "1"]
    code, _, err = run_main(capsys, *argv, "--out", str(tmp_path / "a.jsonl"))
    assert code == 0 and "optima" in err and "level 6" in err, err
    code, _, err = run_main(capsys, *argv, "--out", str(tmp_path / "b.jsonl"), "--quiet")
    assert code == 0 and "level" not in err and "optima:" not in err, err


@pytest.mark.parametrize(
    ("workers", "ray", "n_tasks", "progress", "shown"),
    [
        (1, False, 2, True, True),
        (2, True, 1, True, True),
        (2, True, 2, True, False),
        (1, False, 2, False, False),
    ],
)
def test_optima_level_bars_only_for_a_search_in_this_process(
    tmp_path, monkeypatch, workers, ray, n_tasks, progress, shown
):
    """A task run by a Ray worker shows no bar of its own (its stderr is not this one's); the
    tasks' bar is Engine.map's, as before."""
    from modquad_gym.scoring.optima import build_dataset

    engine = Engine(workers)
    monkeypatch.setattr(engine, "use_ray", ray)
    monkeypatch.setattr(engine, "cluster_cpus", lambda: workers)  # no Ray started
    asked = {}

    def fake_map(fn, items, **options):
        asked.update(fn.keywords, bar=options["progress"])
        return []

    monkeypatch.setattr(engine, "map", fake_map)
    sources = [(f"t{i}", generated_task("planted", i, n_modules=2)) for i in range(n_tasks)]
    build_dataset(sources, tmp_path / "o.jsonl", 3, engine, progress=progress)
    assert asked["progress"] is shown and asked["bar"] is progress


def test_the_hover_bar_never_passes_its_total(monkeypatch):
    """Segments' seconds summed in floats may pass the total by round-off: the bar stops at
    it (past it by less than half a unit, tqdm warns "clamping frac to range [0, 1]")."""
    import tqdm.auto

    from modquad_gym.sim.hover import HoverConfig
    from modquad_gym.sim.hover.run import hover_bar

    bars = []

    class Bar:
        def __init__(self, total, **kwargs):
            self.total, self.n = total, 0.0
            bars.append(self)

        def update(self, k):
            self.n += k

        def close(self):
            pass

    monkeypatch.setattr(tqdm.auto, "tqdm", Bar)
    config = HoverConfig(seconds_per_wrench=0.1, takeoff_seconds=0.1)
    with hover_bar(True, config, [3]) as moved:
        for _ in range(4):  # the take-off and three segments, each a little long
            moved(0.1 * (1 + 1e-12))
    assert bars[0].n == pytest.approx(bars[0].total) and bars[0].n <= bars[0].total
