"""The task commands (``modquad task``, ``export``, ``bench``) and their Python doors answer
alike: the same input is refused by both with one line naming what is wrong, a generator
refuses at construction what the command line refuses, and no door replaces a file unasked."""

from __future__ import annotations

import json
import re

import pytest
from test_edges_cli import assert_one_line_error, run_main
from test_hardening import assert_rejected

import modquad_gym as mq
from modquad_gym import dynamics as dy
from modquad_gym.dynamics.random_motions import MotionTasks
from modquad_gym.geometry.cells import MAX_MODULES
from modquad_gym.sim import export as ex
from modquad_gym.tasks import (
    MAX_WRENCHES,
    FixedTasks,
    MixedTasks,
    PaperTasks,
    PlantedMixedTasks,
    PlantedTasks,
    ScrewdriverTask,
    load_task,
    save_suite,
)

PAIR = mq.Structure([(0, 0), (1, 0)])


# ------------------------------------------------ save_structure refuses what export refuses
@pytest.mark.parametrize(
    "name, fmt, takes", [("b.xml", "json", ("mjcf", "urdf")), ("c.json", "urdf", ("json",))]
)
def test_save_structure_refuses_a_format_against_the_suffix(tmp_path, capsys, name, fmt, takes):
    """Both doors refuse the pair and offer every format the suffix takes (.xml: MJCF and
    URDF, both XML)."""
    path = tmp_path / name
    with pytest.raises(ValueError, match=rf"^fmt='{fmt}': path .*{name} ends in ") as info:
        ex.save_structure(PAIR, path, fmt)
    assert all(f"fmt={f!r}" in str(info.value) for f in takes), str(info.value)
    code, _, err = run_main(capsys, "export", "--cells", "[[0,0],[1,0]]", "--out", str(path),
                            "--format", fmt)  # fmt: skip
    assert_one_line_error(code, err, f"--format {fmt}", name, *(f"--format {f}" for f in takes))
    assert not path.exists()


def test_save_structure_takes_urdf_in_xml_and_says_a_suffix_naming_no_format(tmp_path):
    assert "<robot" in ex.save_structure(PAIR, tmp_path / "r.xml", "urdf").read_text()
    with pytest.raises(ValueError, match=r"^path .*r\.txt: its suffix names no format.* fmt "):
        ex.save_structure(PAIR, tmp_path / "r.txt")
    with pytest.raises(ValueError, match=r"^fmt must be one of mjcf, urdf, json, got 'yaml'"):
        ex.save_structure(PAIR, tmp_path / "r.json", "yaml")


@pytest.mark.parametrize("f_max", [1e13, 1e-310])
def test_save_structure_refuses_the_f_max_export_refuses(tmp_path, capsys, f_max):
    path = tmp_path / "x.json"
    with pytest.raises(ValueError, match=r"^f_max = .* is outside 1e-300\.\.1e12 "):
        ex.save_structure(PAIR, path, f_max=f_max)
    with pytest.raises(ValueError, match=r"^f_max = .* is outside"):
        ex.thrust_to_weight(PAIR, f_max)
    code, _, err = run_main(capsys, "export", "--cells", "[[0,0]]", "--out", str(path),
                            "--f-max", repr(f_max))  # fmt: skip
    assert_rejected(code, err, "--f-max", "outside 1e-300..1e12")
    assert not path.exists()


# ------------------------------------------------------------ a CSV comment key with a space
@pytest.mark.parametrize(
    "comment, field",
    [("# f max: 2", "f_max"), ("# F Max: 2", "f_max"), ("# f max = 2", "f_max"),
     ("# na me: x", "name")],
)  # fmt: skip
def test_a_csv_comment_key_with_a_space_is_a_near_miss(tmp_path, comment, field):
    path = tmp_path / "cm.csv"
    path.write_text(f"{comment}\n0,0,3,0,0,0\n")
    with pytest.raises(ValueError, match=rf"^{path}: line 1: comment .*{field}"):
        load_task(path)


@pytest.mark.parametrize(
    "comment", ["# measured on the bench: yes", "# my name: Bob", "# x = 3", "# kind : external"]
)
def test_free_text_with_spaced_words_stays_free_text(tmp_path, comment):
    path = tmp_path / "ft.csv"
    path.write_text(f"{comment}\n0,0,3,0,0,0\n")
    task = load_task(path)
    assert task.f_max == 1.0 and task.name == "ft"
    assert task.kind == ("external" if "kind" in comment else "total")


# ------------------------------------------------------- errors name the option that caused them
@pytest.mark.parametrize(
    "kind, option, value, lengths",
    [
        ("circle", "--radius", "1e6", "--radius, --speed, --laps"),
        ("hover", "--duration", "1e9", "--duration"),
        ("push", "--speed", "1e-12", "--distance, --speed"),
        ("line", "--max-acceleration", "1e-9", "--distance, --max-acceleration"),
    ],
)
def test_a_long_motion_names_the_typed_option_that_made_it_long(
    tmp_path, capsys, kind, option, value, lengths
):
    out = tmp_path / "r.json"
    code, _, err = run_main(capsys, "task", "motion", "--kind", kind, option, value,
                            "--out", str(out))  # fmt: skip
    line = assert_one_line_error(code, err, f"{lengths}) or lower --rate", "100,000")
    assert line.startswith(f"modquad: error: {option} {float(value):g}: the motion lasts"), line
    assert not out.exists()


def test_a_long_motion_names_every_typed_cause(tmp_path, capsys):
    argv = ["task", "motion", "--kind", "circle", "--laps", "1e5", "--rate", "1000"]
    code, _, err = run_main(capsys, *argv, "--out", str(tmp_path / "c.json"))
    line = assert_one_line_error(code, err)
    assert line.startswith("modquad: error: --laps 100000, --rate 1000: the motion lasts"), line


@pytest.mark.parametrize(
    "argv, start, advice",
    [
        (["--kind", "line", "--max-acceleration", "1000"], "--max-acceleration 1000:",
         "slow the motion (--max-acceleration) or raise --f-max"),
        (["--kind", "circle", "--speed", "4.4", "--radius", "0.5", "--laps", "3"],
         "--speed 4.4, --radius 0.5:", "(--speed, --radius)"),
        (["--kind", "hover", "--f-max", "1"], "--f-max 1:", "raise --f-max"),
    ],
)  # fmt: skip
def test_an_unflyable_motion_names_the_typed_option_that_made_it(tmp_path, capsys, argv, start,
                                                                   advice):  # fmt: skip
    """A motion whose modules cannot carry their own weight blames what was typed (it blamed
    --f-max, at its default, for --max-acceleration 1000)."""
    out = tmp_path / "u.json"
    code, _, err = run_main(capsys, "task", "motion", *argv, "--out", str(out))
    line = assert_one_line_error(code, err, "cannot carry its own weight", advice)
    assert line.startswith(f"modquad: error: {start} a module of type t45"), line
    assert not out.exists()


def test_a_long_motion_in_python_names_its_length_parameters():
    with pytest.raises(ValueError, match=r"^radius, speed, laps, ramp, hold, rate: the motion"):
        dy.circle(radius=1e6)
    with pytest.raises(ValueError, match=r"^duration, rate: the motion lasts 1e\+09 s"):
        dy.hover(1e9)


def test_a_tiny_f_max_is_named_as_the_cause(tmp_path, capsys):
    out = tmp_path / "q.json"
    argv = ["task", "motion", "--kind", "hover", "--f-max", "1e-300", "--out", str(out)]
    code, _, err = run_main(capsys, *argv)
    assert_one_line_error(code, err, "--f-max: 1e-300 N is too small", "9.81 N")
    assert not out.exists()
    data = dy.hover(1.0, rate=20.0).to_dict()
    path = tmp_path / "fmax_tiny.json"
    path.write_text(json.dumps({**data, "f_max": 1e-300}))
    with pytest.raises(ValueError, match=rf"^{path}: f_max: 1e-300 N is too small"):
        load_task(path)
    code, _, err = run_main(capsys, "export", "--task", str(path), "--out", str(out))
    assert_one_line_error(code, err, str(path), "f_max: 1e-300 N is too small")


# ------------------------------------------------------- no option ignored or replaced unsaid
@pytest.mark.parametrize("name", [["screwdriver"], []])
def test_task_example_force_without_out_is_refused(tmp_path, capsys, monkeypatch, name):
    monkeypatch.chdir(tmp_path)
    code, out, err = run_main(capsys, "task", "example", *name, "--force")
    assert_one_line_error(code, err, "--force", "--out")
    assert out == "" and list(tmp_path.iterdir()) == []


def test_task_motion_refuses_an_empty_name_as_python_does(tmp_path, capsys):
    """A task's name is never empty (a file's task without one takes the file's name)."""
    out = tmp_path / "q12.json"
    code, _, err = run_main(capsys, "task", "motion", "--kind", "hover", "--name", "",
                            "--out", str(out))  # fmt: skip
    assert code == 2 and err.strip() == "modquad: error: --name must be a non-empty string, got ''"
    assert not out.exists()
    with pytest.raises(ValueError, match="^name must be a non-empty string"):
        dy.hover(name="")


def test_export_task_folder_says_it_takes_one_file(tmp_path, capsys):
    folder = tmp_path / "bad"
    folder.mkdir()
    (folder / "a.json").write_text('{"wrenches": [[0, 0, 3, 0, 0, 0]]}')
    out = tmp_path / "d.json"
    code, _, err = run_main(capsys, "export", "--task", str(folder), "--out", str(out))
    assert_one_line_error(code, err, f"--task {folder} is a folder", "one task file")
    assert not out.exists()


# ------------------------------------------------------------------------- help and usage
def test_task_help_names_the_help_of_every_action(capsys):
    code, out, _ = run_main(capsys, "task", "--help")
    assert code == 0 and "`modquad task ACTION --help`" in " ".join(out.split())


def test_bench_without_arguments_requires_only_agents(capsys):
    code, _, err = run_main(capsys, "bench")
    last = err.strip().splitlines()[-1]
    assert code == 2 and last.endswith("the following arguments are required: agents"), err


# ------------------------------------------------- the generators name a bad argument (types)
GENERATOR_ARGUMENTS = [
    (lambda: PaperTasks(scale="a"), "scale must be a real number, got 'a'"),
    (lambda: PaperTasks(n_wrenches=2.5), "n_wrenches must be an int or an inclusive"),
    (lambda: PaperTasks(n_wrenches=(2, "x")), "n_wrenches must be an integer, got 'x'"),
    (lambda: PaperTasks(name=5), "name must be a string, got 5"),
    (lambda: PlantedTasks(boundary_fraction="x"), "boundary_fraction must be a real number"),
    (lambda: PlantedTasks(slack=None), "slack must be a real number, got None"),
    (lambda: PlantedTasks(module="t45"), "module must be a ModuleType or None, got 't45'"),
    (lambda: ScrewdriverTask(push="a"), "push must be a real number, got 'a'"),
    (lambda: ScrewdriverTask(lift=None), "lift must be a real number, got None"),
    (lambda: PlantedMixedTasks(n_wrenches=2.5), "n_wrenches must be an integer, got 2.5"),
    (lambda: PlantedMixedTasks(modules="zz"), "modules: unknown module type 'zz'"),
    (lambda: MixedTasks((ScrewdriverTask(),), name=3), "name must be a string, got 3"),
    (lambda: MotionTasks(name=None), "name must be a string, got None"),
]


@pytest.mark.parametrize("make, words", GENERATOR_ARGUMENTS)
def test_a_generator_names_a_bad_argument(make, words):
    with pytest.raises(ValueError, match=f"^{re.escape(words)}"):
        make()


@pytest.mark.parametrize(
    "generator",
    [PaperTasks(), PlantedTasks(), ScrewdriverTask(), PlantedMixedTasks(), MotionTasks(),
     FixedTasks((ScrewdriverTask().task(),)), MixedTasks((ScrewdriverTask(),))],
    ids=lambda g: type(g).__name__,
)  # fmt: skip
@pytest.mark.parametrize("rng", [None, 3])
def test_a_generator_call_names_rng(generator, rng):
    with pytest.raises(ValueError, match=rf"^rng must be a numpy.random.Generator .*got {rng}"):
        generator(rng)


# ---------------------------------------- the generators refuse the sizes the command line does
@pytest.mark.parametrize(
    "make, words",
    [
        (lambda: PlantedTasks(n_modules=MAX_MODULES + 1), f"n_modules must be <= {MAX_MODULES}"),
        (lambda: PlantedTasks(n_modules=(2, 10**6)), f"n_modules must be <= {MAX_MODULES}"),
        (lambda: PlantedMixedTasks(n_modules=200), f"n_modules must be <= {MAX_MODULES}"),
        (lambda: PaperTasks(n_wrenches=10**9), f"n_wrenches must be <= {MAX_WRENCHES}"),
        (lambda: PlantedTasks(n_wrenches=(1, 10**7)), f"n_wrenches must be <= {MAX_WRENCHES}"),
        (lambda: PlantedMixedTasks(n_wrenches=10**7), f"n_wrenches must be <= {MAX_WRENCHES}"),
        (lambda: PaperTasks(fz_gain=1e308, fz_offset=1e308), "scale, fz_gain, fz_offset: "),
        (lambda: ScrewdriverTask(torque=1e200), "push, torque, lift, align, press: "),
        (lambda: PaperTasks(f_max=1e-300), "f_max = 1e-300 is too small for wrenches up to 9"),
        (lambda: ScrewdriverTask(f_max=1e13), "f_max = 1e+13 is outside 1e-300..1e12"),
        (lambda: PlantedTasks(f_max=1e13), "f_max = 1e+13 is outside 1e-300..1e12"),
        (lambda: PlantedTasks(f_max=1e300), "f_max = 1e+300 is outside 1e-300..1e12"),
    ],
)
def test_a_generator_refuses_at_construction_what_the_searches_refuse(make, words):
    with pytest.raises(ValueError, match=f"^{re.escape(words)}"):
        make()


def test_the_module_limit_is_the_searches_and_the_commands(capsys, tmp_path):
    from modquad_gym.search.problem import MAX_MODULES as SEARCHES

    assert MAX_MODULES == SEARCHES
    argv = ["task", "generate", "--kind", "planted", "--n-modules", str(MAX_MODULES + 1)]
    code, _, err = run_main(capsys, *argv, "--out", str(tmp_path / "p.json"))
    assert code == 2 and f"must be in 1..{MAX_MODULES}, got {MAX_MODULES + 1}" in err, err


@pytest.mark.parametrize("kind", ["paper", "screwdriver"])
def test_task_generate_names_a_tiny_f_max_as_too_small(tmp_path, capsys, kind):
    out = tmp_path / "g.json"
    argv = ["task", "generate", "--kind", kind, "--f-max", "1e-300", "--out", str(out)]
    code, _, err = run_main(capsys, *argv)
    assert_one_line_error(code, err, "--f-max 1e-300 is too small for wrenches up to")
    assert not out.exists()


# ------------------------------------------------------------ no save replaces a file unasked
SAVERS = {
    "TaskRequirement.save": lambda path, **kw: ScrewdriverTask().task().save(path, **kw),
    "DynamicTask.save": lambda path, **kw: dy.hover(1.0, rate=20.0).save(path, **kw),
    "save_structure": lambda path, **kw: ex.save_structure(PAIR, path, **kw),
    "save_suite": lambda path, **kw: save_suite([ScrewdriverTask().task()], path, **kw),
}


@pytest.mark.parametrize("save", SAVERS.values(), ids=SAVERS.keys())
def test_a_save_replaces_an_existing_file_only_with_force(tmp_path, save):
    path = tmp_path / "keep.json"
    path.write_text("precious\n")
    with pytest.raises(ValueError, match=r"^path: .*keep\.json exists \(use force=True"):
        save(path)
    assert path.read_text() == "precious\n"
    with pytest.raises(ValueError, match="^force must be True or False, got 'yes'"):
        save(path, force="yes")
    assert save(path, force=True) == path and path.read_text() != "precious\n"


@pytest.mark.parametrize("save", SAVERS.values(), ids=SAVERS.keys())
@pytest.mark.parametrize("bad", [None, 5])
def test_a_save_names_a_path_that_is_not_one(save, bad):
    with pytest.raises(ValueError, match=rf"^path must be a file path .*got {bad}"):
        save(bad)


@pytest.mark.parametrize("save", SAVERS.values(), ids=SAVERS.keys())
def test_a_save_into_a_folder_names_it(tmp_path, save):
    folder = tmp_path / "d.json"
    folder.mkdir()
    with pytest.raises(ValueError, match=r"^path: .*d\.json is a folder, expected a file name"):
        save(folder, force=True)


@pytest.mark.parametrize("module", ["suites", "tiers"])
def test_the_suite_writers_refuse_an_existing_suite_before_any_search(
    tmp_path, monkeypatch, capsys, module
):
    from modquad_gym.core.interrupts import run_command
    from modquad_gym.scoring import suites, tiers

    def no_search(*args, **kwargs):
        raise AssertionError("the certified searches ran before the output was checked")

    monkeypatch.setattr(suites, "build_suite", no_search)
    monkeypatch.setattr(tiers, "build_tier_suite", no_search)
    monkeypatch.setattr(tiers, "SUITES_DIR", tmp_path)
    main, argv, name = {
        "suites": (suites.main, ["--out", str(tmp_path)], "heldout_paper.json"),
        "tiers": (tiers.main, ["large"], f"{tiers.TIERS['large'].suites[0]}.json"),
    }[module]
    (tmp_path / name).write_text("precious\n")
    prog = f"python -m modquad_gym.scoring.{module}"
    assert run_command(main, prog, argv) == 2
    err = capsys.readouterr().err.strip()
    assert re.fullmatch(rf"{re.escape(prog)}: error: .*{re.escape(name)}.*--force.*", err), err
    assert (tmp_path / name).read_text() == "precious\n"
