"""Task requirements: files, validation, generators, suites, make_generator."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from modquad_gym import Structure, feasible, margin, structure_levels
from modquad_gym.tasks import (
    FixedTasks,
    MixedTasks,
    PaperTasks,
    PlantedTasks,
    ScrewdriverTask,
    TaskFileError,
    TaskGenerator,
    TaskRequirement,
    load_suite,
    make_generator,
    planted_structure,
    random_cells,
    save_suite,
)


def _task(seed: int = 0, t: int = 5) -> TaskRequirement:
    rng = np.random.default_rng(seed)
    W = rng.normal(size=(t, 6))
    W[:, 2] = np.abs(W[:, 2]) + 1.0
    return TaskRequirement(W, name="demo", f_max=1.0)


def _optimum(task: TaskRequirement, n_max: int = 7) -> int | None:
    for n, level in enumerate(structure_levels(n_max), 1):
        for key in level:
            if feasible(Structure(key).configuration_matrix(), task.wrenches, task.f_max).all():
                return n
    return None


# --------------------------------------------------------------------------------------------
# the dataclass
# --------------------------------------------------------------------------------------------
def test_requirement_copies_and_freezes():
    W = np.ones((2, 6))
    task = TaskRequirement(W, name="x", f_max=2.0)
    W[0, 0] = 5.0
    assert task.wrenches[0, 0] == 1.0
    assert task.n_wrenches == 2 == len(task)
    assert task.wrenches.dtype == float
    with pytest.raises(ValueError):
        task.wrenches[0, 0] = 3.0


def test_requirement_equality_ignores_meta():
    a = TaskRequirement(np.ones((1, 6)), meta={"optimum": 3})
    b = TaskRequirement(np.ones((1, 6)))
    assert a == b and hash(a) == hash(b)
    assert a != TaskRequirement(np.ones((1, 6)) * 2)
    assert a != TaskRequirement(np.ones((1, 6)), f_max=2.0)


@pytest.mark.parametrize(
    "wrenches, f_max, words",
    [
        (np.ones((3, 5)), 1.0, ["shape", "(3, 5)"]),
        (np.ones(6), 1.0, ["shape", "(6,)"]),
        (np.zeros((0, 6)), 1.0, ["at least one wrench"]),
        ([[0, 0, 1, 0, 0, 0], [0, 0, np.nan, 0, 0, 0]], 1.0, ["row 2", "fz"]),
        ([[0, 0, 1, 0, 0, np.inf]], 1.0, ["row 1", "tz"]),
        (np.ones((1, 6)), 0.0, ["f_max"]),
        (np.ones((1, 6)), -1.0, ["f_max"]),
        (np.ones((1, 6)), math.inf, ["f_max"]),
    ],
)
def test_requirement_rejects(wrenches, f_max, words):
    with pytest.raises(ValueError) as info:
        TaskRequirement(wrenches, f_max=f_max)
    for word in words:
        assert word in str(info.value)


def test_dict_round_trip_keeps_meta_and_refuses_unknown_keys():
    task = _task()
    d = task.to_dict()
    assert set(d) == {"name", "f_max", "wrenches"}
    back = TaskRequirement.from_dict({**d, "meta": {"generator": "x", "optimum": 4}})
    assert back == task
    assert back.meta == {"generator": "x", "optimum": 4}
    assert TaskRequirement.from_dict({"wrenches": [[0, 0, 1, 0, 0, 0]]}).name == "task"
    with pytest.raises(ValueError, match="unknown key 'optimum'.*meta"):
        TaskRequirement.from_dict({**d, "optimum": 4})


# --------------------------------------------------------------------------------------------
# files
# --------------------------------------------------------------------------------------------
@pytest.mark.parametrize("suffix", [".json", ".csv", ".npy"])
def test_file_round_trip(tmp_path, suffix):
    task = _task(t=7)
    path = task.save(tmp_path / f"demo{suffix}")
    back = TaskRequirement.load(path)
    assert np.array_equal(back.wrenches, task.wrenches)  # exact floats
    assert back.f_max == task.f_max
    assert back.name == "demo"


def test_json_and_csv_keep_name_f_max_meta(tmp_path):
    task = TaskRequirement(np.ones((2, 6)), name="heavy", f_max=2.5, meta={"optimum": 3})
    js = TaskRequirement.load(task.save(tmp_path / "a.json"))
    assert js == task and js.meta == {"optimum": 3}
    cs = TaskRequirement.load(task.save(tmp_path / "b.csv"))
    assert cs == task


def test_npy_refuses_to_drop_f_max(tmp_path):
    with pytest.raises(ValueError, match="f_max"):
        TaskRequirement(np.ones((1, 6)), f_max=2.0).save(tmp_path / "a.npy")


def test_minimal_files(tmp_path):
    p = tmp_path / "only.json"
    p.write_text('{"wrenches": [[0, 0, 1, 0, 0, 0]]}')
    task = TaskRequirement.load(p)
    assert task.name == "only" and task.f_max == 1.0 and task.n_wrenches == 1
    c = tmp_path / "plain.csv"
    c.write_text("\n0,0,1,0,0,0\n\n0.1, 0.2, 2, 0, 0, 0.05\n\n")
    task = TaskRequirement.load(c)
    assert task.name == "plain" and task.wrenches.shape == (2, 6)
    assert task.wrenches[1, 5] == 0.05


BAD_FILES = [
    ("bad.json", '{"wrenches": [[0, 0, 1, 0, 0, 0]', ["not valid JSON", "line 1", "column"]),
    ("nokey.json", '{"forces": [[0, 0, 1, 0, 0, 0]]}', ["wrenches"]),
    ("list.json", "[[0, 0, 1, 0, 0, 0]]", ["wrenches"]),
    ("cols.json", '{"wrenches": [[0, 0, 1, 0, 0, 0], [0, 0, 1, 0, 0]]}', ["row 2", "6 columns"]),
    ("cell.json", '{"wrenches": [[0,0,1,0,0,0],[0,0,1,0,0,0],[0,"a",1,0,0,0]]}', ["row 3", "fy"]),
    ("bool.json", '{"wrenches": [[0, 0, true, 0, 0, 0]]}', ["row 1", "fz"]),
    ("nan.json", '{"wrenches": [[0, 0, 1, 0, 0, 0], [NaN, 0, 1, 0, 0, 0]]}', ["row 2", "finite"]),
    ("inf.json", '{"wrenches": [[0, 0, Infinity, 0, 0, 0]]}', ["row 1", "finite"]),
    ("empty.json", "", ["empty"]),
    ("zero.json", '{"wrenches": []}', ["empty"]),
    ("fmax.json", '{"wrenches": [[0, 0, 1, 0, 0, 0]], "f_max": 0}', ["f_max"]),
    ("fmaxneg.json", '{"wrenches": [[0, 0, 1, 0, 0, 0]], "f_max": -2}', ["f_max"]),
    ("name.json", '{"wrenches": [[0, 0, 1, 0, 0, 0]], "name": 3}', ["name"]),
    ("suite.json", '{"tasks": []}', ["wrenches", "load_suite"]),
    ("cols.csv", "fx,fy,fz,tx,ty,tz\n0,0,1,0,0,0\n0,0,1,0,0\n", ["row 2", "line 3", "6 columns"]),
    ("cell.csv", "0,0,1,0,0,0\n0,0,1,0,x,0\n", ["row 2", "ty", "'x'"]),
    ("nan.csv", "0,0,1,0,0,0\n\n0,0,nan,0,0,0\n", ["row 2", "line 3", "finite"]),
    ("inf.csv", "0,0,inf,0,0,0\n", ["row 1", "finite"]),
    ("empty.csv", "", ["no wrenches"]),
    ("header.csv", "fx,fy,fz,tx,ty,tz\n\n", ["no wrenches"]),
    ("late_header.csv", "0,0,1,0,0,0\nfx,fy,fz,tx,ty,tz\n", ["row 2", "fx"]),
    ("fmax.csv", "# f_max: 0\n0,0,1,0,0,0\n", ["f_max"]),
    ("unknown.txt", "0,0,1,0,0,0\n", ["unknown task file type", ".txt"]),
]


@pytest.mark.parametrize("filename, text, words", BAD_FILES, ids=[b[0] for b in BAD_FILES])
def test_bad_text_files(tmp_path, filename, text, words):
    path = tmp_path / filename
    path.write_text(text)
    with pytest.raises(TaskFileError) as info:
        TaskRequirement.load(path)
    message = str(info.value)
    assert str(path) in message
    for word in words:
        assert word in message, message


@pytest.mark.parametrize(
    "array", [np.ones((3, 5)), np.ones(6), np.zeros((0, 6)), np.ones((2, 6, 1))]
)
def test_bad_npy_shape(tmp_path, array):
    path = tmp_path / "w.npy"
    np.save(path, array)
    with pytest.raises(TaskFileError) as info:
        TaskRequirement.load(path)
    assert str(path) in str(info.value) and str(array.shape) in str(info.value)


def test_bad_npy_contents(tmp_path):
    path = tmp_path / "nan.npy"
    arr = np.ones((3, 6))
    arr[1, 2] = np.nan
    np.save(path, arr)
    with pytest.raises(TaskFileError, match="row 2"):
        TaskRequirement.load(path)
    text = tmp_path / "text.npy"
    text.write_text("not an array")
    with pytest.raises(TaskFileError, match="text.npy"):
        TaskRequirement.load(text)


def test_missing_file_names_path(tmp_path):
    path = tmp_path / "nowhere.json"
    with pytest.raises(FileNotFoundError) as info:
        TaskRequirement.load(path)
    assert str(path) in str(info.value)


def test_task_file_error_is_value_error():
    assert issubclass(TaskFileError, ValueError)


# --------------------------------------------------------------------------------------------
# suites
# --------------------------------------------------------------------------------------------
def test_suite_round_trip(tmp_path):
    tasks = [_task(0), TaskRequirement(np.ones((1, 6)), name="b", f_max=2.0, meta={"optimum": 2})]
    path = save_suite(tasks, tmp_path / "s.json", name="mine")
    assert json.loads(path.read_text())["name"] == "mine"
    back = load_suite(path)
    assert back == tasks
    assert back[1].meta == {"optimum": 2}


def test_bad_suite_names_task(tmp_path):
    path = tmp_path / "s.json"
    path.write_text('{"tasks": [{"wrenches": [[0,0,1,0,0,0]]}, {"wrenches": [[0,0,1,0,0]]}]}')
    with pytest.raises(TaskFileError) as info:
        load_suite(path)
    assert str(path) in str(info.value) and "task 2" in str(info.value)
    assert "row 1" in str(info.value)
    path.write_text('{"wrenches": [[0,0,1,0,0,0]]}')
    with pytest.raises(TaskFileError, match="tasks"):
        load_suite(path)
    with pytest.raises(ValueError):
        save_suite([], tmp_path / "e.json")


# --------------------------------------------------------------------------------------------
# generators
# --------------------------------------------------------------------------------------------
GENERATORS = [
    PaperTasks(),
    PaperTasks(n_wrenches=(3, 9), fz_reading="shift"),
    PlantedTasks(),
    PlantedTasks(n_modules=1, n_wrenches=4),
    ScrewdriverTask(),
    MixedTasks((PaperTasks(n_wrenches=5), PlantedTasks()), weights=(1.0, 3.0)),
]


@pytest.mark.parametrize("gen", GENERATORS, ids=lambda g: type(g).__name__)
def test_generators_deterministic_and_well_formed(gen):
    assert isinstance(gen, TaskGenerator) and isinstance(gen.name, str)
    for seed in range(4):
        a = gen(np.random.default_rng(seed))
        b = gen(np.random.default_rng(seed))
        assert isinstance(a, TaskRequirement)
        assert a == b and a.meta == b.meta
        assert a.wrenches.ndim == 2 and a.wrenches.shape[1] == 6 and a.n_wrenches >= 1
        assert np.all(np.isfinite(a.wrenches))
        assert np.all(a.wrenches[:, 2] > 0)


def test_generators_vary_with_seed():
    for gen in (PaperTasks(), PlantedTasks()):
        tasks = {gen(np.random.default_rng(s)) for s in range(5)}
        assert len(tasks) == 5


def test_paper_readings():
    rng = np.random.default_rng(3)
    W = PaperTasks(n_wrenches=400)(rng).wrenches
    assert W.shape == (400, 6)
    assert W[:, 2].min() >= 3.0 and W[:, 2].max() <= 3.0 + 12.0 * 0.5
    assert np.abs(W[:, [0, 1, 3, 4, 5]]).max() <= 0.5
    lit = PaperTasks(n_wrenches=400, fz_gain=30.0, fz_offset=0.0, fz_reading="literal")
    Wl = lit(np.random.default_rng(3)).wrenches
    assert (Wl[:, 2] < 0).any() and (Wl[:, 2] > 0).any()
    sh = PaperTasks(n_wrenches=400, fz_gain=30.0, fz_offset=0.0, fz_reading="shift")
    Ws = sh(np.random.default_rng(3)).wrenches
    assert Ws[:, 2].min() >= 0 and Ws[:, 2].max() <= 30.0 and Ws[:, 2].max() > 15.0
    t = {PaperTasks(n_wrenches=(2, 4))(np.random.default_rng(s)).n_wrenches for s in range(30)}
    assert t == {2, 3, 4}


def test_paper_defaults_satisfy_the_force_cone_and_literal_does_not():
    """For a T-module (eta = pi/4) |f_x|, |f_y| <= f_z / sqrt(2) is necessary for any structure
    (see PaperTasks): the defaults respect it, the paper's literal numbers break it."""
    for seed in range(10):
        W = PaperTasks()(np.random.default_rng(seed)).wrenches
        assert np.all(np.abs(W[:, :2]).max(axis=1) <= W[:, 2] / math.sqrt(2))
    broken = 0
    for seed in range(10):
        W = PaperTasks(fz_gain=30.0, fz_offset=0.0)(np.random.default_rng(seed)).wrenches
        broken += bool(np.any(np.abs(W[:, :2]).max(axis=1) > W[:, 2] / math.sqrt(2)))
    assert broken >= 7
    # and the cone really is necessary: a wrench outside it is infeasible for a big structure
    s = Structure([(i, j) for i in range(3) for j in range(2)])
    assert not feasible(s.configuration_matrix(), [[0.5, 0.0, 0.6, 0.0, 0.0, 0.0]])[0]


def test_paper_defaults_have_small_optimum():
    for seed in range(3):
        n = _optimum(PaperTasks()(np.random.default_rng(seed)))
        assert n is not None and 1 <= n <= 7


def test_paper_rejects_bad_parameters():
    for kwargs in (
        {"fz_reading": "square"},
        {"scale": 0.0},
        {"fz_gain": -1.0},
        {"fz_offset": -1.0},
        {"n_wrenches": 0},
        {"n_wrenches": (5, 2)},
        {"f_max": 0.0},
    ):
        with pytest.raises(ValueError):
            PaperTasks(**kwargs)


def test_random_cells_connected_and_seeded():
    for seed in range(10):
        cells = random_cells(np.random.default_rng(seed), 6)
        assert cells[0] == (0, 0) and len(set(cells)) == 6
        Structure(cells)  # raises if not connected
        assert cells == random_cells(np.random.default_rng(seed), 6)
    with pytest.raises(ValueError):
        random_cells(np.random.default_rng(0), 0)


def test_planted_tasks_feasible_for_hidden_structure():
    gen = PlantedTasks(n_modules=(1, 5), n_wrenches=(5, 30))
    sizes = set()
    for seed in range(12):
        task = gen(np.random.default_rng(seed))
        cells = [tuple(c) for c in task.meta["planted_cells"]]
        s = planted_structure(task)
        assert s is not None and list(s.cells) == cells
        assert task.meta["generator"] == "planted"
        assert task.meta["optimum_upper_bound"] == s.n_modules
        assert task.name == "planted"  # neutral: the hidden cells stay in meta only
        A = s.configuration_matrix()
        assert feasible(A, task.wrenches).all()
        assert margin(A, task.wrenches).min() >= 2 * gen.slack - 1e-6
        assert 5 <= task.n_wrenches <= 30
        sizes.add(s.n_modules)
    assert sizes <= {1, 2, 3, 4, 5} and len(sizes) >= 3


def test_planted_boundary_wrenches_reach_the_boundary():
    gen = PlantedTasks(n_modules=3, n_wrenches=40, boundary_fraction=1.0, p_extreme=1.0)
    task = gen(np.random.default_rng(0))
    m = margin(planted_structure(task).configuration_matrix(), task.wrenches)
    assert np.allclose(m, 2 * gen.slack, atol=1e-6)  # every rotor at slack or 1 - slack
    inner = PlantedTasks(n_modules=3, n_wrenches=40, boundary_fraction=0.0)(
        np.random.default_rng(0)
    )
    assert planted_structure(PaperTasks()(np.random.default_rng(0))) is None
    assert inner.meta["n_boundary"] == 0 and task.meta["n_boundary"] == 40


def test_screwdriver_optimum_is_small():
    task = ScrewdriverTask()(np.random.default_rng(0))
    assert task.n_wrenches == 2
    assert task.wrenches[1, 5] == ScrewdriverTask().torque
    n = _optimum(task, n_max=6)
    assert n is not None and 2 <= n <= 6
    with pytest.raises(ValueError):
        ScrewdriverTask(lift=-1.0)


def test_mixed_tasks_uses_every_generator_and_checks_weights():
    gen = MixedTasks((ScrewdriverTask(), PlantedTasks(n_wrenches=3)))
    kinds = {gen(np.random.default_rng(s)).meta["generator"] for s in range(20)}
    assert kinds == {"screwdriver", "planted"}
    only = MixedTasks((ScrewdriverTask(), PlantedTasks()), weights=(0.0, 1.0))
    assert {only(np.random.default_rng(s)).meta["generator"] for s in range(10)} == {"planted"}
    with pytest.raises(ValueError):
        MixedTasks(())
    with pytest.raises(ValueError):
        MixedTasks((ScrewdriverTask(),), weights=(1.0, 2.0))
    with pytest.raises(ValueError):
        MixedTasks((ScrewdriverTask(),), weights=(-1.0,))
    with pytest.raises(ValueError):
        MixedTasks(("paper",))


# --------------------------------------------------------------------------------------------
# make_generator
# --------------------------------------------------------------------------------------------
def test_make_generator_names():
    assert isinstance(make_generator("paper"), PaperTasks)
    assert isinstance(make_generator("planted"), PlantedTasks)
    assert isinstance(make_generator("screwdriver"), ScrewdriverTask)
    mixed = make_generator("mixed")
    assert isinstance(mixed, MixedTasks) and len(mixed.generators) == 2
    gen = PlantedTasks(n_modules=2)
    assert make_generator(gen) is gen


def test_make_generator_files_tasks_and_lists(tmp_path):
    task = _task()
    path = task.save(tmp_path / "t.json")
    for spec in (path, str(path)):
        gen = make_generator(spec)
        assert isinstance(gen, FixedTasks)
        assert gen(np.random.default_rng(0)) == task
    suite = save_suite([task, _task(1)], tmp_path / "suite.json")
    assert len(make_generator(suite).tasks) == 2
    assert make_generator(task)(np.random.default_rng(5)) == task
    pooled = make_generator([task, _task(1), path])
    assert isinstance(pooled, FixedTasks) and len(pooled.tasks) == 3
    drawn = {pooled(np.random.default_rng(s)) for s in range(30)}
    assert drawn == {task, _task(1)}
    mixed = make_generator(["screwdriver", task])
    assert isinstance(mixed, MixedTasks)


@pytest.mark.parametrize("spec", ["papers", "no/such/file.json", 42, [], None])
def test_make_generator_unknown(spec):
    with pytest.raises(ValueError) as info:
        make_generator(spec)
    if isinstance(spec, str):
        assert spec in str(info.value)


def test_make_generator_bad_file(tmp_path):
    path = tmp_path / "bad.csv"
    path.write_text("0,0,1\n")
    with pytest.raises(TaskFileError, match="row 1"):
        make_generator(path)


def test_pickle_keeps_tasks_and_generators():
    import pickle

    task = TaskRequirement(np.ones((2, 6)), name="p", meta={"optimum": 1})
    back = pickle.loads(pickle.dumps(task))
    assert back == task and back.meta == task.meta
    assert not back.wrenches.flags.writeable
    gen = make_generator("mixed")
    again = pickle.loads(pickle.dumps(gen))
    assert again(np.random.default_rng(7)) == gen(np.random.default_rng(7))


@given(seed=st.integers(0, 2**32 - 1), n=st.integers(1, 130))
@settings(max_examples=40, deadline=None)
def test_random_cells_grow_as_the_plain_rule_does(seed, n):
    """The grown structure keeps its frontier as it grows: the same draws, cell for cell, as
    choosing among ``free_neighbours`` of all the cells at each step (seeded tasks and suites
    depend on it)."""
    from modquad_gym.geometry.structure import free_neighbours
    from modquad_gym.tasks.generators import random_cells

    rng = np.random.default_rng(seed)
    plain = [(0, 0)]
    while len(plain) < n:
        free = free_neighbours(plain)
        plain.append(free[int(rng.integers(len(free)))])
    assert random_cells(np.random.default_rng(seed), n) == plain


def test_named_sources_plant_within_n_max_and_fit_ones_are_left_as_they_are():
    from modquad_gym.tasks import PlantedMixedTasks
    from modquad_gym.tasks.specs import sizes_within

    scale = make_generator("planted-16-64", n_max=20)
    assert scale.n_modules == (16, 20) and scale.name == "planted-16-64"
    assert make_generator("planted-16-64", n_max=7).n_modules == (7, 7)
    mixed = make_generator(["mixed", "planted-mixed-external"], n_max=2)
    inner = [g for m in mixed.generators for g in getattr(m, "generators", (m,))]
    counts = [g.n_modules for g in inner if hasattr(g, "n_modules")]
    assert counts == [(2, 2), (2, 2)]
    rng = np.random.default_rng(0)
    assert all(mixed(rng).meta.get("optimum_upper_bound", 2) <= 2 for _ in range(8))
    # sizes that fit: the very same generator (the same draws), named or not
    for gen in (PlantedTasks(), MixedTasks((PlantedTasks(), PaperTasks())), PlantedMixedTasks()):
        assert sizes_within(gen, 7) is gen
    assert make_generator("planted", n_max=7) == make_generator("planted")
    assert sizes_within(PlantedTasks(n_modules=9), 7).n_modules == (7, 7)
