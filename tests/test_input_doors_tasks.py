"""Input doors of the tasks, dynamics, oracle, module type, export writers and environment
(review 2 items 3-6 and 11-15, review 3 items 15 and 19): what a function cannot do is refused
in one line naming the argument (or the file, line and field), never done silently or
half-way."""

from __future__ import annotations

import json

import gymnasium as gym
import numpy as np
import pytest
from test_hardening import assert_one_line_error, run_main

import modquad_gym as mq
from modquad_gym import dynamics as dy
from modquad_gym.envs.assembly.viewer import AssemblyViewer
from modquad_gym.sim import export as ex
from modquad_gym.tasks import TaskFileError, TaskRequirement, load_suite, load_task, save_suite

T = TaskRequirement([[0, 0, 3, 0, 0, 0], [0.5, 0, 3, 0, 0, 0]])
PAIR = mq.Structure([(0, 0), (1, 0)])


# ------------------------------------------------- review 2, 3: a line too fast for its samples
@pytest.mark.parametrize("accel", [1e4, 1e6, 1e9])
def test_a_line_faster_than_its_samples_is_refused(accel):
    """``line(max_acceleration=1e6)`` made a task whose samples held no acceleration at all."""
    with pytest.raises(ValueError, match=r"^max_acceleration: .*4 sample intervals.*raise rate"):
        dy.line(max_acceleration=accel)


# --------------------------------------------------------- review 2, 4: near-miss CSV comments
@pytest.mark.parametrize(
    "comment, field",
    [
        ("# f_max = 2", "f_max"),
        ("#f_max=2", "f_max"),
        ("# f_max 2", "f_max"),
        ("# fmax = 2", "f_max"),
        ("# F_MAX=2", "f_max"),
        ("#  kind external", "kind"),
        ('# meta {"a": 1}', "meta"),
        ("# name = robot", "name"),
    ],
)
def test_a_comment_that_misses_the_colon_is_refused(tmp_path, comment, field):
    path = tmp_path / "c.csv"
    path.write_text(f"# note: bench\n{comment}\n0,0,3,0,0,0\n")
    with pytest.raises(TaskFileError) as info:
        TaskRequirement.load(path)
    message = str(info.value)
    assert message.startswith(f"{path}: line 2: comment ") and "\n" not in message
    assert f"does not set {field}: write '# {field}: VALUE'" in message


@pytest.mark.parametrize(
    "comment",
    ["# note: f_max = 2", "# Kind regards", "#", "# name.", "# name of the bench",
     "# kind of heavy", "# meta data below", "# f_max was measured"],
)  # fmt: skip
def test_free_text_comments_are_still_free(tmp_path, comment):
    path = tmp_path / "c.csv"
    path.write_text(f"{comment}\n# f_max: 2\n0,0,3,0,0,0\n")
    assert TaskRequirement.load(path).f_max == 2.0


def test_a_near_miss_comment_is_one_line_at_the_command_line(tmp_path, capsys):
    path = tmp_path / "c.csv"
    path.write_text("# f_max = 2\n0,0,3,0,0,0\n")
    code, _, err = run_main(capsys, "solve", "--task", str(path), "--method", "greedy",
                            "--n-max", "3", "--quiet")  # fmt: skip
    assert_one_line_error(code, err, str(path), "line 1", "'# f_max: VALUE'")


# ------------------------------------------------------------- review 2, 5: allocate one wrench
@pytest.mark.parametrize(
    "w, words",
    [
        ([[0, 0, 100, 0, 0, 0], [0, 0, 1, 0, 0, 0]], "got shape (2, 6)"),
        (np.zeros((0, 6)), "got shape (0, 6)"),
        ([0, 0, 1, 0, 0, np.nan], "w: wrench row 1 is not finite"),
        ("abcdef", "w: wrenches must hold real numbers"),
    ],
)
def test_allocate_takes_one_wrench(w, words):
    A = PAIR.configuration_matrix()
    with pytest.raises(ValueError) as info:
        mq.allocate(A, w)
    assert words in str(info.value)
    u, gamma = mq.allocate(A, [[0, 0, 1, 0, 0, 0]])
    assert u.shape == (8,) and gamma == mq.allocate(A, [0, 0, 1, 0, 0, 0])[1]


# -------------------------------------------------------- review 2, 6 and 15: the oracle's cache
def test_a_key_reused_for_a_matrix_of_another_shape_is_refused():
    A = PAIR.configuration_matrix()
    B = mq.Structure([(0, 0), (0, 1), (1, 0), (1, 1)]).configuration_matrix()
    w = [[0, 0, 10, 0, 0, 0]]
    oracle = mq.WrenchOracle()
    oracle.feasible(A, w, key="k")
    for call in (oracle.feasible, oracle.margin):
        with pytest.raises(ValueError, match=r"^key 'k': A has shape \(6, 16\).*\(6, 8\)"):
            call(B, w, key="k")
    with pytest.raises(ValueError, match="^key 'k'"):
        oracle.gamma_zonotope(B, "k")
    assert oracle.feasible(B, w, key="k2") == mq.feasible(B, w)  # a new key: its own answer
    assert oracle.feasible(A, w, key="k") == mq.feasible(A, w)


@pytest.mark.parametrize(
    "size, words",
    [("x", "must be an integer, got 'x'"), (2.7, "must be an integer, got 2.7"),
     (True, "must be an integer, got True"), (-1, "must be >= 0, got -1")],
)  # fmt: skip
def test_cache_size_is_checked_not_converted(size, words):
    with pytest.raises(ValueError, match=f"^cache_size {words}"):
        mq.WrenchOracle(cache_size=size)
    assert mq.WrenchOracle(cache_size=np.int64(3)).cache_size == 3


# ----------------------------------------------------------- review 2, 11: a module type's fields
@pytest.mark.parametrize(
    "kw, words",
    [
        ({"c_tau": float("nan")}, "c_tau must be finite"),
        ({"c_tau": float("inf")}, "c_tau must be finite"),
        ({"c_tau": "0.01"}, "c_tau must be a real number"),
        ({"c_tau": -0.01}, "c_tau must be >= 0"),
        ({"side": True}, "side must be a real number, got True"),
        ({"side": "0.4"}, "side must be a real number"),
        ({"height": True}, "height must be a real number, got True"),
        ({"name": 5}, "name must be a non-empty string, got 5"),
        ({"name": ""}, "name must be a non-empty string"),
        ({"mass": True}, "mass must be a real number, got True"),
    ],
)
def test_a_module_type_checks_its_fields(kw, words):
    with pytest.raises(ValueError, match=f"^{words}"):
        mq.ModuleType.from_tilts((0.5, -0.5, 0.5, -0.5), **kw)
    t = mq.ModuleType.from_tilts((0.5, -0.5, 0.5, -0.5), side=np.float64(0.5), height=0)
    assert type(t.side) is float and t.height == 0.0


# ------------------------------------------------------------- review 2, 12: the export writers
@pytest.mark.parametrize(
    "call, words",
    [
        (lambda: ex.urdf_text(None), "structure must be a modquad_gym.Structure, got NoneType"),
        (lambda: ex.structure_dict("abc"), "structure must be a modquad_gym.Structure, got str"),
        (lambda: ex.export_text([(0, 0)], "json"), "structure must be a modquad_gym.Structure"),
        (lambda: ex.thrust_to_weight(None), "structure must be a modquad_gym.Structure"),
        (lambda: ex.urdf_text(PAIR, name=5), "name must be None or a non-empty line"),
        (lambda: ex.urdf_text(PAIR, name="a\nb"), "name must be None or a non-empty line"),
    ],
)
def test_the_writers_check_what_they_write(call, words):
    with pytest.raises(ValueError, match=f"^{words}"):
        call()


def test_save_structure_takes_only_a_flag_for_force(tmp_path):
    out = tmp_path / "x.urdf"
    with pytest.raises(ValueError, match="^force must be True or False, got 'yes'"):
        ex.save_structure(PAIR, out, force="yes")
    with pytest.raises(ValueError, match="^path must be a file path"):
        ex.save_structure(PAIR, None)
    assert not out.exists()
    ex.save_structure(PAIR, out)
    assert "<robot" in out.read_text()


# -------------------------------------------------------------- review 2, 13: tasks and suites
@pytest.mark.parametrize(
    "meta, words",
    [
        ({"x": object()}, "meta['x'] is of type object, which JSON cannot hold"),
        ({"x": [1, float("nan")]}, "meta['x'][1] is nan: JSON has no NaN"),
        ({"x": {"y": np.array([1.0, np.inf])}}, "meta['x']['y'][1] is inf"),
    ],
)
@pytest.mark.parametrize("suffix", [".json", ".csv"])
def test_meta_that_json_cannot_hold_is_refused_before_writing(tmp_path, meta, words, suffix):
    path = tmp_path / f"m{suffix}"
    task = TaskRequirement(T.wrenches, meta=meta)
    with pytest.raises(ValueError) as info:
        task.save(path)
    assert str(info.value).startswith(words)
    assert not path.exists()
    with pytest.raises(ValueError, match=r"^meta\['x'\]"):
        save_suite([task], tmp_path / "s.json")
    assert not (tmp_path / "s.json").exists()


def test_csv_header_is_checked_for_every_file(tmp_path):
    path = T.save(tmp_path / "m.json")
    for load in (TaskRequirement.load, load_task):
        with pytest.raises(ValueError, match="^csv_header must be one of auto, yes, no, got 'x'"):
            load(path, csv_header="x")
        with pytest.raises(ValueError, match="^csv_header='yes' says how a CSV file's first"):
            load(path, csv_header="yes")
        assert load(path, csv_header="auto") == T
    csv = T.save(tmp_path / "m.csv")
    assert TaskRequirement.load(csv, csv_header="yes") == T


def test_csv_header_with_a_folder_of_mixed_files_reads_each(tmp_path, capsys):
    """The command line passes --csv-header to the CSV files of a folder, not to the others."""
    T.save(tmp_path / "a.json")
    (tmp_path / "b.csv").write_text("fx,fy,fz,tx,ty,tz\n0,0,3,0,0,0\n")
    code, out, err = run_main(capsys, "solve", "--task", str(tmp_path), "--csv-header", "yes",
                              "--method", "greedy", "--n-max", "3", "--quiet")  # fmt: skip
    assert code == 0 and out.count("optimal") == 2, err


@pytest.mark.parametrize(
    "call, words",
    [
        (lambda p: save_suite(T, p / "s.json"), "tasks must be a list of tasks, got one task"),
        (lambda p: save_suite([T, 3], p / "s.json"), "tasks: task 2 is of type int"),
        (lambda p: save_suite([], p / "s.json"), "tasks must be a non-empty list"),
        (lambda p: save_suite(5, p / "s.json"), "tasks must be a non-empty list of tasks, got 5"),
        (lambda p: save_suite([T], p / "s.csv"), "path: a suite is a .json file"),
        (lambda p: save_suite([T], p / "s.json", name=5), "name must be a string or None, got 5"),
        (lambda p: save_suite([T], None), "path must be a file path"),
        (lambda p: T.save(None), "path must be a file path"),
        (lambda p: TaskRequirement.load(None), "path must be a file path"),
        (lambda p: load_task(None), "path must be a file path"),
        (lambda p: load_suite(None), "path must be a file path"),
    ],
)
def test_suite_and_task_arguments_are_named(tmp_path, call, words):
    with pytest.raises(ValueError) as info:
        call(tmp_path)
    assert str(info.value).startswith(words), info.value
    assert list(tmp_path.iterdir()) == []


def test_a_suite_reads_examples_and_refuses_a_name_not_a_string(tmp_path):
    assert len(load_suite("example:suite_small")) == len(
        json.loads(mq.tasks.example_path("suite_small").read_text())["tasks"]
    )
    path = tmp_path / "n.json"
    path.write_text(json.dumps({"name": 5, "tasks": [T.to_dict()]}))
    with pytest.raises(TaskFileError, match="the suite's name must be a string, got 5"):
        load_suite(path)
    with pytest.raises(TaskFileError, match="not a regular file"):
        load_suite(tmp_path)
    save_suite((T,), path.with_name("ok.json"), name="mine")
    assert load_suite(path.with_name("ok.json")) == [T]
    save_suite((t for t in [T, T]), path.with_name("two.json"))  # any iterable of tasks
    assert load_suite(path.with_name("two.json")) == [T, T]


# ------------------------------------------------------------------- review 2, 14: environment
@pytest.fixture(scope="module")
def env():
    e = gym.make("ModQuadAssembly-v0", n_max=3)
    yield e
    e.close()


@pytest.mark.parametrize("options", [5, "task", [("task", "example:screwdriver")]])
def test_reset_options_must_be_a_dict(env, options):
    with pytest.raises(ValueError, match="^options must be a dict or None"):
        env.reset(options=options)


def test_reset_takes_a_task_file_as_make_does(env, tmp_path):
    obs = env.reset(seed=0, options={"task": "example:screwdriver"})[0]
    made = gym.make("ModQuadAssembly-v0", n_max=3, task="example:screwdriver")
    np.testing.assert_array_equal(obs["task"], made.reset(seed=0)[0]["task"])
    assert env.unwrapped.task.name == made.unwrapped.task.name == "screwdriver"
    env.reset(options={"task": T.save(tmp_path / "t.json")})
    assert env.unwrapped.task == T  # the name saved in the file
    for spec, words in [
        ("paper", "options['task']='paper' names a family of random tasks"),
        ("example:suite_small", "options['task'] takes one task"),
        (str(tmp_path / "none.json"), "options['task']: unknown task spec"),
    ]:
        with pytest.raises(ValueError) as info:
            env.reset(options={"task": spec})
        assert str(info.value).startswith(words), info.value


@pytest.mark.parametrize(
    "kw, words",
    [
        ({"viewer": 5}, "viewer must be an AssemblyViewer or None, got 5"),
        ({"viewer": AssemblyViewer(1, 3)}, "viewer: its grid reaches 1 cells"),
        ({"viewer": AssemblyViewer(2, 3, (64, 64)), "render_size": (32, 32)},
         "render_size (32, 32) and the viewer's frames (64, 64) differ"),
    ],
)  # fmt: skip
def test_a_viewer_is_checked_at_make(kw, words):
    with pytest.raises(ValueError) as info:
        gym.make("ModQuadAssembly-v0", n_max=3, render_mode="rgb_array", **kw)
    assert str(info.value).startswith(words), info.value


# ---------------------------------------------------- review 3, 15 and 19: dynamic task files
RISING = {"t": [0, 0.5, 1.0], "position": [[0, 0, 0], [0, 0, 0.01], [0, 0, 0.02]]}
DYNAMIC = {"name": "dyn", "kind": "dynamic", "f_max": 2.0, "trajectory": RISING}


@pytest.mark.parametrize(
    "change, words",
    [
        ({"t": [False, True, 2]}, "trajectory.t: sample 1 is false, not a number"),
        ({"position": [[0, 0, 0], [0, True, 0], [0, 0, 0]]},
         "trajectory.position: sample 2 holds true, not a number"),
        ({"velocity": [[0, 0, 0], [0, 0, 0], [0, 0, False]]},
         "trajectory.velocity: sample 3 holds false"),
        ({"exerted": [[0] * 6, [0] * 6, [0, 0, True, 0, 0, 0]]},
         "exerted: sample 3 holds true, not a number"),
        ({"payload": {"mass": 0.1, "offset": [0, False, 0]}},
         "payload.offset: entry 2 is false, not a number"),
    ],
)  # fmt: skip
def test_dynamic_task_files_refuse_booleans(tmp_path, capsys, change, words):
    data = json.loads(json.dumps(DYNAMIC))
    traj = {k: v for k, v in change.items() if k in ("t", "position", "velocity")}
    data["trajectory"].update(traj)
    data.update({k: v for k, v in change.items() if k not in traj})
    path = tmp_path / "d.json"
    path.write_text(json.dumps(data))
    with pytest.raises(TaskFileError, match=f"^{path}: {words}".replace(".", r"\.")):
        load_task(path)
    code, _, err = run_main(capsys, "solve", "--task", str(path), "--method", "greedy",
                            "--n-max", "3", "--quiet")  # fmt: skip
    assert_one_line_error(code, err, f"{path}: {words}")


@pytest.mark.parametrize(
    "change, words",
    [
        ({"payload": {"mass": 1e6}}, "payload.mass: 1e+06 kg is more than"),
        ({"trajectory": {"t": [0, 1e-3, 2e-3, 3e-3],  # 1e6 m/s^2 up (4 samples of a parabola)
                         "position": [[0, 0, 0], [0, 0, 0.5], [0, 0, 2], [0, 0, 4.5]]}},
         "f_max: 2 N per rotor cannot fly"),
    ],
)  # fmt: skip
@pytest.mark.parametrize("command", ["solve", "validate", "show", "export"])
def test_a_dynamic_task_no_structure_lifts_names_its_file(tmp_path, capsys, change, words,
                                                          command):  # fmt: skip
    path = tmp_path / "d.json"
    path.write_text(json.dumps({**DYNAMIC, **change}))
    argv = [command, "--task", str(path)]
    if command == "export":
        argv += ["--out", str(tmp_path / "e.json")]
    code, _, err = run_main(capsys, *argv)
    assert_one_line_error(code, err, f"{path}: {words}")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["d.json"]
