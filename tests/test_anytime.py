"""The anytime search: the exhaustive search's answers wherever the latter finishes, verified
structures with proved bounds at scale, bad input refused before work; its local moves."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import modquad_gym as mq
from modquad_gym.cli import main
from modquad_gym.geometry.cells import is_connected, normalise
from modquad_gym.geometry.module import GRAVITY, palette
from modquad_gym.search import anytime_search, exhaustive_search
from modquad_gym.search.bounds import force_lower_bound
from modquad_gym.search.moves import compact_shapes, relocations, removable
from modquad_gym.search.problem import check_time_limit
from modquad_gym.tasks import PlantedTasks, TaskRequirement

T = palette("t45,t45m,flat")


def random_cells(n, rng):
    cells = [(0, 0)]
    while len(cells) < n:
        free = sorted({(x + dx, y + dy) for x, y in cells
                       for dx, dy in ((1, 0), (-1, 0), (0, 1), (0, -1))} - set(cells))  # fmt: skip
        cells.append(free[int(rng.integers(len(free)))])
    return cells


def small_task(seed):
    rng = np.random.default_rng(seed)
    s = mq.Structure(random_cells(int(rng.integers(1, 7)), rng))
    A = s.configuration_matrix()
    U = rng.integers(0, 2, (int(rng.integers(2, 10)), A.shape[1])).astype(float)
    W = (A @ U.T).T * rng.choice([1.0, 1.2])
    if rng.uniform() < 0.3:
        W[:, 3:] *= 2.0
    return W


@settings(max_examples=60, deadline=None)
@given(st.integers(0, 10**6))
def test_anytime_is_the_exhaustive_search_where_it_finishes(seed):
    W = small_task(seed)
    exact = exhaustive_search(W, n_max=6)
    r = anytime_search(W, n_max=6, time_limit=60)
    assert r.certified and r.n_modules == exact.n_modules
    assert r.lower_bound == exact.lower_bound
    if exact.structure is not None:
        assert r.structure.key == exact.structure.key


@pytest.mark.parametrize("seed", range(3))
@pytest.mark.parametrize("kind", ["total", "external"])
def test_typed_anytime_is_the_typed_exhaustive_search(seed, kind):
    rng = np.random.default_rng(seed)
    cells = random_cells(3, rng)
    types = [T[int(k)] for k in rng.integers(0, 3, 3)]
    s = mq.Structure(cells, modules=types)
    A = s.configuration_matrix()
    W = (A @ rng.integers(0, 2, (6, A.shape[1])).T).T
    if kind == "external":
        W[:, 2] -= s.mass * GRAVITY
    exact = exhaustive_search(W, n_max=4, modules=T, kind=kind)
    r = anytime_search(W, n_max=4, modules=T, kind=kind, time_limit=60)
    assert r.certified and r.to_dict()["cells"] == exact.to_dict()["cells"]
    assert r.to_dict()["modules"] == exact.to_dict()["modules"]


def test_beyond_the_exact_reach_a_verified_structure_and_its_bound():
    task = PlantedTasks(n_modules=24, n_wrenches=20)(np.random.default_rng(3))
    r = anytime_search(task, n_max=40, time_limit=20)
    assert r.structure is not None and mq.search.verified(r.structure, task)
    assert r.lower_bound >= force_lower_bound(task.wrenches, mq.TModule())
    assert r.lower_bound <= r.n_modules <= 24  # the planted structure is feasible
    assert r.certified == (r.n_modules == r.lower_bound)


def test_mixed_palette_at_scale():
    task = TaskRequirement([[0, 0, 30.0, 0, 0, 0.5], [0, 0, 25.0, 1.0, 0, 0]])
    r = anytime_search(task, n_max=30, modules=T, time_limit=10)
    assert r.structure is not None and mq.search.verified(r.structure, task)
    assert set(r.to_dict()["modules"]) <= {"t45", "t45m", "flat"}
    assert r.lower_bound <= r.n_modules


def test_bad_input_is_refused_before_work():
    W = [[0, 0, 3.0, 0, 0, 0]]
    for bad in (0, -1, 1e9, float("nan"), "soon"):
        with pytest.raises(ValueError, match="time_limit"):
            anytime_search(W, time_limit=bad)
    assert check_time_limit(86_400) == 86_400.0
    with pytest.raises(ValueError, match="at most 128 modules"):
        anytime_search(W, n_max=10**6)
    with pytest.raises(ValueError, match="at most 10,000"):
        anytime_search(np.tile(W, (100_000, 1)), n_max=64)
    impossible = anytime_search([[0, 0, -1.0, 0, 0, 0]], n_max=10**6)  # proved at once
    assert impossible.structure is None and impossible.certified


def test_cli_default_search_at_scale(tmp_path, capsys):
    path = tmp_path / "t.json"
    assert (
        main(["task", "generate", "--kind", "planted", "--n-modules", "20", "--out", str(path)])
        == 0
    )
    assert len(TaskRequirement.load(path).meta["planted_cells"]) == 20
    capsys.readouterr()
    assert (
        main(["solve", "--task", str(path), "--n-max", "64", "--time-limit", "10", "--json"]) == 0
    )
    record = __import__("json").loads(capsys.readouterr().out)
    assert record["method"] == "anytime" and record["feasible"]
    assert record["lower_bound"] <= record["n_modules"] <= 20
    assert record["certified"] == (record["lower_bound"] == record["n_modules"])
    for bad in (["--time-limit", "0"], ["--time-limit", "1e9"]):
        with pytest.raises(SystemExit) as exit_info:
            main(["solve", "--task", str(path), *bad])
        assert exit_info.value.code == 2
    assert "time-limit" in capsys.readouterr().err


# --------------------------------------------------------------------------- local moves
@pytest.mark.parametrize("n", [1, 2, 5, 16, 37, 64])
def test_compact_shapes_are_connected_and_distinct(n):
    shapes = compact_shapes(n)
    assert shapes and all(len(set(s)) == n and is_connected(s) for s in shapes)
    assert len({normalise(s) for s in shapes}) == len(shapes)


@settings(max_examples=80, deadline=None)
@given(st.integers(0, 10**6), st.integers(1, 14))
def test_removable_modules_are_exactly_the_non_cut_cells(seed, n):
    cells = random_cells(n, np.random.default_rng(seed))
    brute = [i for i in range(n) if n > 1 and is_connected(cells[:i] + cells[i + 1 :])]
    assert removable(cells) == brute
    for i, c in relocations(cells):
        moved = cells[:i] + [c] + cells[i + 1 :]
        assert is_connected(moved) and len(set(moved)) == n


def test_the_time_left_goes_to_the_fields_heuristics(monkeypatch):
    """The portfolio (issue 35): when the local moves stop early without meeting the bound, beam
    and genetic get the time left, and the smaller verified structure is the answer (here the
    exact levels and the moves are switched off: the compact-shape incumbent alone is far
    larger than beam's)."""
    import modquad_gym.search.anytime as anytime
    from benchmarks.scale_suites import draw
    from modquad_gym.search import beam_search

    task = draw("torque", 16, 0, validation=True)  # a validation draw, not a held-out task
    monkeypatch.setattr(anytime.ExactLevels, "fits", lambda self, n: False)
    monkeypatch.setattr(anytime.Incumbents, "improve", lambda self, lower: None)
    r = anytime_search(task, n_max=24, time_limit=6)
    beam = beam_search(task, n_max=24, time_limit=6)
    assert r.structure is not None and r.n_modules <= beam.n_modules
    assert r.history[-1].source in ("beam", "genetic", "greedy")  # who found it
    alone = anytime_search(task, n_max=24, time_limit=6, producers=())
    assert alone.n_modules > r.n_modules and r.evaluated > alone.evaluated


@pytest.mark.parametrize(
    "script, argv, says",
    [
        ("anytime", ["--tasks", "0"], "argument --tasks: must be in 1..100, got 0"),
        ("anytime", ["--sizes"], "argument --sizes: expected at least one argument"),
        ("anytime", ["--time-limit", "nan"], "argument --time-limit: expected a finite number"),
        ("scale_seeds", ["--time-limit", "0"], "argument --time-limit: must lie in (0, 86,400]"),
        ("certificates", ["--fault-tasks", "-1"], "argument --fault-tasks: must be in 0.."),
    ],
)
def test_benchmark_options_that_mean_no_work_are_refused_before_it(
    script, argv, says, tmp_path, capsys
):
    """An empty workload (it used to end in a traceback after the run) or a time limit that is
    not one: argparse's one line naming the option, exit 2, nothing written."""
    from benchmarks.common import run_script

    assert run_script(script, [*argv, "--out", str(tmp_path / "out")]) == 2
    assert says in capsys.readouterr().err.strip().splitlines()[-1]
    assert not (tmp_path / "out").exists()
