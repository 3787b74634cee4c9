"""One door: the Python API and the ``modquad`` command line give the same answers and refuse the
same inputs in the same words (each door spelling the option its own way)."""

from __future__ import annotations

import re

import pytest
from test_hardening import assert_one_line_error, assert_rejected, run_main

import modquad_gym as mq
from modquad_gym.tasks import load_task

PAPER = "example:paper_seed0"


# ------------------------------------------------------------------ seed=None is the default
@pytest.mark.parametrize(
    "method, options",
    [
        ("random", {"restarts": 4}),
        ("beam", {}),
        ("genetic", {"generations": 20}),
    ],
)
def test_seed_none_is_seed_zero_in_every_door(method, options):
    """seed=None drew fresh entropy in the search functions and meant seed 0 in make_solver."""
    task = load_task(PAPER)
    search = getattr(mq, f"{method}_search")
    answers = [search(task, seed=None, time_limit=20, **options) for _ in range(2)]
    answers.append(mq.make_solver(method, seed=None, time_limit=20, **options).solve(task))
    answers.append(search(task, seed=0, time_limit=20, **options))
    got = {(r.structure.cells, r.evaluated) for r in answers}
    assert len(got) == 1, got


def test_seed_none_of_the_anytime_search_is_seed_zero():
    task = load_task("example:screwdriver")
    a = mq.anytime_search(task, seed=None, time_limit=20)
    b = mq.make_solver("anytime", seed=None, time_limit=20).solve(task)
    assert a.structure.cells == b.structure.cells and a.certified and b.certified


@pytest.mark.parametrize("door", ["search", "make_solver"])
def test_restarts_none_is_refused_naming_it(door):
    """It was `TypeError: 'NoneType' object cannot be interpreted as an integer`."""
    task = load_task(PAPER)
    with pytest.raises(ValueError, match=r"^restarts must be an integer, got None$"):
        if door == "search":
            mq.random_search(task, restarts=None)
        else:
            mq.make_solver("random", restarts=None).solve(task)


# ------------------------------------------------------------------------- chunk's upper bound
def _chunk_calls(task):
    return {
        "anytime": lambda chunk: mq.anytime_search(task, chunk=chunk, time_limit=5),
        "exhaustive": lambda chunk: mq.make_solver("exhaustive", chunk=chunk),
        "optima": lambda chunk: mq.optimal_structures(task, chunk=chunk),
    }


@pytest.mark.parametrize("door", ["anytime", "exhaustive", "optima"])
def test_a_chunk_beyond_its_bound_is_refused_naming_it(door):
    """chunk=10**12 was a MemoryError naming neither the option nor its value."""
    from modquad_gym.search.options import MAX_CHUNK

    call = _chunk_calls(load_task("example:screwdriver"))[door]
    with pytest.raises(ValueError, match=rf"^chunk must be <= {MAX_CHUNK}, got {10**12}$"):
        call(10**12)


def test_a_chunk_the_memory_cannot_hold_is_refused(monkeypatch):
    from modquad_gym.search.options import CHUNK_BYTES

    monkeypatch.setattr("modquad_gym.core.resources.available_memory", lambda: 2**20)
    call = _chunk_calls(load_task("example:screwdriver"))["anytime"]
    assert 2**16 * CHUNK_BYTES > 2**20
    with pytest.raises(ValueError, match=r"^chunk=65536 needs about .* of memory"):
        call(2**16)


def test_the_command_line_refuses_a_chunk_beyond_its_bound(capsys):
    argv = ["solve", "--task", "example:screwdriver", "--method", "anytime", "--json"]
    code, _, err = run_main(capsys, *argv, "--option", f"chunk={10**12}")
    assert_one_line_error(code, err, f"--option chunk={10**12}: chunk must be <= ")


# --------------------------------------------------- errors name the option as the door spells it
@pytest.mark.parametrize("method, n_max, most", [("exhaustive", 17, 16), ("anytime", 129, 128)])
def test_an_n_max_beyond_reach_is_refused_when_the_solver_is_made(capsys, method, n_max, most):
    """Python made the solver and failed in solve; the CLI said n_max=17 (Python's spelling)."""
    with pytest.raises(ValueError, match=rf"^n_max={n_max} is beyond what the {method} method"):
        mq.make_solver(method, n_max=n_max)
    argv = ["solve", "--task", "example:screwdriver", "--method", method, "--n-max", str(n_max)]
    code, _, err = run_main(capsys, *argv)
    assert_one_line_error(code, err, f"--n-max {n_max}: method '{method}'", f"at most {most}")


@pytest.mark.parametrize(
    "given, said, words",
    [
        (["elite=30"], "elite=30", "elite must be <= 23 (population 24 - 1), got 30"),
        (["tournament=100"], "tournament=100", "tournament must be <= 24 (population 24)"),
        (["population=2"], "population=2", "elite must be <= 1 (population 2 - 1), got 2"),
        (["population=10", "elite=12"], "elite=12", "elite must be <= 9"),
    ],
)
def test_genetic_options_checked_together_name_the_option(capsys, given, said, words):
    """They said 'elite must be <= 23, got 30' without the --option prefix, at solve time."""
    options = [word for text in given for word in ("--option", text)]
    argv = ["solve", "--task", "example:screwdriver", "--method", "genetic", *options]
    code, _, err = run_main(capsys, *argv)
    assert_one_line_error(code, err, f"--option {said}: {words}")
    python = dict(text.split("=") for text in given)
    with pytest.raises(ValueError, match=re.escape(words)):
        mq.make_solver("genetic", **{k: int(v) for k, v in python.items()})


@pytest.mark.parametrize(
    "argv, shown, hidden",
    [
        (["--method", "exhaustive", "--time-limit", "5"], "--time-limit 5:", ["5.0", "engine"]),
        (["--method", "exhaustive", "--option", "foo=1"], "--option chunk=", ["engine", "start"]),
        (["--method", "greedy", "--seed", "3"], "--time-limit", ["start"]),
    ],
)
def test_a_refused_option_lists_what_the_command_line_can_spell(capsys, argv, shown, hidden):
    code, _, err = run_main(capsys, "solve", "--task", "example:screwdriver", *argv)
    assert_one_line_error(code, err, shown)
    for word in hidden:
        assert word not in err, err


# ------------------------------------------------- task generate: the generators Python names
@pytest.mark.parametrize(
    "kind, spec, seeded",
    [
        ("paper", "paper", True),
        ("paper", "paper-external", True),
        ("planted", "planted-external", True),
        ("screwdriver", "screwdriver-external", False),
    ],
)
def test_task_generate_writes_the_named_generators_task(tmp_path, capsys, kind, spec, seeded):
    """The CLI gave external tasks f_max 2 N and the paper defaults (80 wrenches), the Python
    classes f_max 1 N, and make_generator('paper-external') 40 wrenches: three answers."""
    import numpy as np

    from modquad_gym.tasks import generated_task, make_generator

    task_kind = "external" if spec.endswith("external") else "total"
    out = tmp_path / "cli.json"
    argv = ["task", "generate", "--kind", kind, "--task-kind", task_kind, "--out", str(out)]
    assert run_main(capsys, *argv, *(["--seed", "3"] if seeded else []))[0] == 0
    python = generated_task(kind, 3, task_kind)
    python.save(tmp_path / "python.json")
    assert out.read_bytes() == (tmp_path / "python.json").read_bytes()
    drawn = make_generator(spec)(np.random.default_rng(3))
    np.testing.assert_array_equal(load_task(out).wrenches, drawn.wrenches)
    assert (python.f_max, python.kind, python.meta) == (drawn.f_max, drawn.kind, drawn.meta)
    assert python.f_max == (2.0 if task_kind == "external" else 1.0)


# ------------------------------------------------------------ suites on the command line
def test_optima_reads_an_example_suite_as_score_does(tmp_path, capsys):
    """`optima --suite example:suite_small` said "no suite 'example:suite_small'"."""
    import json

    from modquad_gym.tasks import load_suite

    out = tmp_path / "o.jsonl"
    argv = ["optima", "--suite", "example:suite_small", "--out", str(out), "--workers", "1"]
    code, _, err = run_main(capsys, *argv, "--quiet")
    assert code == 0, err
    records = [json.loads(line) for line in out.read_text().splitlines()]
    tasks = load_suite("example:suite_small")
    assert [r["name"] for r in records] == [t.name for t in tasks]
    for record, task in zip(records, tasks):
        n, keys = mq.optimal_structures(task, n_max=7)
        assert record["optimum"] == n and record["structures"] == [list(map(list, k)) for k in keys]


def test_optima_with_modules_gives_optimal_structures_typed_answer(tmp_path, capsys):
    import json

    from modquad_gym.geometry.module import palette

    out = tmp_path / "o.jsonl"
    argv = ["optima", "--task", "example:screwdriver", "--out", str(out), "--workers", "1"]
    code, _, err = run_main(capsys, *argv, "--quiet", "--modules", "t45,flat")
    assert code == 0, err
    (record,) = [json.loads(line) for line in out.read_text().splitlines()]
    n, keys = mq.optimal_structures(load_task("example:screwdriver"), modules=palette("t45,flat"))
    python = sorted(([list(c) for c, _ in k], [m.name for _, m in k]) for k in keys)
    assert record["palette"] == ["t45", "flat"] and record["optimum"] == n
    assert sorted(zip(record["structures"], record["modules"])) == python
    code, _, err = run_main(capsys, *argv, "--quiet")  # one dataset, one palette
    assert_one_line_error(code, err, "--out", "another palette")


def test_solving_a_suite_file_points_to_the_commands_that_read_suites(capsys):
    code, _, err = run_main(capsys, "solve", "--task", "example:suite_small")
    assert_one_line_error(code, err, "modquad score --suite", "modquad optima --suite")


# --------------------------------------------------------------- validate: one set of checks
def _line():
    return mq.Structure([(0, 0), (0, 1), (1, 0)]), [[0.0, 0.0, 2.0, 0.0, 0.0, 0.0]]


@pytest.mark.parametrize(
    "options, words, cli_words",
    [
        ({"hover_seconds": 61}, "hover_seconds must be <= 60, got 61",
         "--hover-seconds must be <= 60, got 61"),
        ({"hover_seconds": 0}, "hover_seconds must be >= 0.05, got 0",
         "--hover-seconds must be >= 0.05, got 0"),
        ({"hover_seconds": 2, "load_ramp_seconds": 5},
         "load_ramp_seconds must be <= hover_seconds (2), got 5",
         "--load-ramp-seconds must be <= --hover-seconds (2), got 5"),
        ({"max_hover_wrenches": 0}, "max_hover_wrenches must be >= 1, got 0",
         "--max-hover-wrenches"),  # argparse's own words
    ],
)  # fmt: skip
def test_validate_refuses_what_the_command_line_refuses(tmp_path, capsys, options, words,
                                                       cli_words):  # fmt: skip
    """Python ran hover_seconds=61, shortened a ramp of 5 s quietly, and named hover_seconds=0
    seconds_per_wrench."""
    pytest.importorskip("mujoco")
    from modquad_gym.sim.validate import validate

    structure, wrenches = _line()
    with pytest.raises(ValueError, match="^" + re.escape(words) + "$"):
        validate(structure, wrenches, render=False, **options)
    argv = ["validate", "--task", "example:screwdriver", "--out", str(tmp_path / "v")]
    flags = [x for k, v in options.items() for x in ("--" + k.replace("_", "-"), str(v))]
    code, _, err = run_main(capsys, *argv, *flags)
    assert_rejected(code, err, cli_words)
    assert not (tmp_path / "v").exists()


def test_validate_hovers_under_as_many_wrenches_in_both_doors():
    """Python hovered under every wrench by default, the command line under 20."""
    import inspect

    from modquad_gym.cli import build_parser
    from modquad_gym.sim.validate import validate

    parser = build_parser(["validate"])
    args = parser.parse_args(["validate", "--task", "t.json"])
    python = inspect.signature(validate).parameters["max_hover_wrenches"].default
    assert python == args.max_hover_wrenches == 20


# ------------------------------------------------------------------------------------- help
def test_seed_help_names_the_methods_that_take_it():
    from modquad_gym.cli import build_parser
    from modquad_gym.methods import REGISTRY

    parser = build_parser(["solve"])
    solve = parser._subparsers._group_actions[0].choices["solve"]
    (seed,) = [a for a in solve._actions if a.dest == "seed"]
    takes = [n for n, m in REGISTRY.items() if "seed" in m.options.names()]
    assert {"random", "anytime", "beam", "genetic"} <= set(takes)
    for name in takes:
        assert name in seed.help, (name, seed.help)
    assert "refused for the other methods" in seed.help


def test_quiet_with_progress_is_a_contradiction(capsys):
    """--option progress=true printed progress despite --quiet."""
    argv = ["solve", "--task", "example:screwdriver", "--method", "anytime", "--quiet"]
    code, _, err = run_main(capsys, *argv, "--option", "progress=true")
    assert_one_line_error(code, err, "--option progress=true: contradicts --quiet")


@pytest.mark.parametrize("method", ["greedy", "anytime"])
def test_export_and_show_design_for_a_fault_as_python_does(tmp_path, capsys, method):
    """show and export searched 'as modquad solve' but had no --fault."""
    pytest.importorskip("matplotlib")
    from modquad_gym.sim.export import save_structure

    task = load_task("example:screwdriver")
    python = mq.make_solver(method, fault="rotor", fault_margin=0.05, time_limit=20).solve(task)
    assert python.structure is not None and python.fault == "rotor"
    save_structure(python.structure, tmp_path / "python.json", f_max=task.f_max)
    search = ["--task", "example:screwdriver", "--method", method, "--fault", "rotor",
              "--fault-margin", "0.05", "--time-limit", "20"]  # fmt: skip
    code, out, err = run_main(capsys, "export", *search, "--out", str(tmp_path / "cli.json"))
    assert code == 0, err
    assert (tmp_path / "cli.json").read_bytes() == (tmp_path / "python.json").read_bytes()
    code, out, err = run_main(capsys, "show", *search, "--out", str(tmp_path / "s.png"))
    assert code == 0, err
    assert f"cells {list(python.structure.cells)}" in out and "survives any rotor failure" in out
    assert "green where the intact structure exerts a wrench" in out  # what the picture shows


@pytest.mark.parametrize("command", ["export", "show"])
def test_export_and_show_refuse_a_fault_as_solve_does(tmp_path, capsys, command):
    out = tmp_path / ("x.json" if command == "export" else "x.png")
    argv = [command, "--task", "example:screwdriver", "--method", "milp", "--fault", "rotor"]
    code, _, err = run_main(capsys, *argv, "--out", str(out))
    assert_one_line_error(code, err, "method 'milp' cannot honour fault='rotor'")
    argv = [command, "--cells", "[[0,0]]", "--fault", "rotor", "--out", str(out)]
    code, _, err = run_main(capsys, *argv)
    assert_one_line_error(code, err, "--fault rotor", "--cells")
    assert not out.exists()
