"""``modquad score`` and its neighbours refuse, in one line and before any work, what they used to
take silently or end in a traceback: an empty output path, an outside agent that fails to import,
to be made or calls ``sys.exit``, a suite whose ``meta.optimum`` is not a module count or is
below the proved bound, and options that no scored method uses (review 3: 2, 4, 6, 10, 18, 19,
20, 21)."""

from __future__ import annotations

import json
import sys

import pytest

from modquad_gym.cli import main

TASK = {"name": "tiny", "f_max": 1.0, "wrenches": [[0, 0, 3, 0, 0, 0], [0.1, 0, 3.5, 0, 0, 0.1]]}
"""A task two modules do (one cannot: the exact bounds prove it)."""


def _suite(tmp_path, optimum=2, name="suite"):
    path = tmp_path / f"{name}.json"
    path.write_text(json.dumps({"name": name, "tasks": [{**TASK, "meta": {"optimum": optimum}}]}))
    return path


def _no_work(*args, **kwargs):
    raise AssertionError("the work started")


@pytest.fixture()
def score(tmp_path, capsys, monkeypatch):
    """``modquad score --suite SUITE ... --out OUT`` with the benchmark itself replaced: (exit
    code, the error line); nothing may be scored."""
    monkeypatch.setattr("modquad_gym.scoring.agents.run_benchmark", _no_work)
    suite = _suite(tmp_path)

    def run(*argv: str, suite=suite):
        code = main(["score", "--suite", str(suite), "--no-progress", *argv,
                     "--out", str(tmp_path / "rep")])  # fmt: skip
        err = capsys.readouterr().err.strip()
        assert code == 2 and err.count("\n") == 0, err
        assert not (tmp_path / "rep").exists()
        return err

    return run


# --- an empty path is not the working folder ----------------------------------------------------


@pytest.mark.parametrize(
    "argv, option",
    [
        (["score", "--methods", "greedy", "--out", ""], "--out"),
        (["score", "--methods", "ppo", "--model", ""], "--model"),
        (["score", "--methods", "ppo", "--train-dir", ""], "--train-dir"),
        (["score", "--suite", ""], "--suite"),
        (["validate", "--task", "example:screwdriver", "--out", ""], "--out"),
    ],
)
def test_an_empty_path_is_refused_while_parsing(tmp_path, capsys, monkeypatch, argv, option):
    monkeypatch.chdir(tmp_path)
    with pytest.raises(SystemExit) as exc:
        main(argv)
    assert exc.value.code == 2
    assert f"argument {option}: an empty path" in capsys.readouterr().err
    assert not any(tmp_path.iterdir())  # nothing written into the working folder


def test_an_empty_path_is_refused_by_the_python_doors_and_train(tmp_path, capsys, monkeypatch):
    from agents.cli import parse_args
    from modquad_gym.core.outputs import OutputError, check_output_dir, check_output_file
    from modquad_gym.scoring.options import score_options
    from modquad_gym.solvers import make_solver

    monkeypatch.chdir(tmp_path)
    for check in (check_output_dir, check_output_file):
        with pytest.raises(OutputError, match="--out: an empty path"):
            check("", what="--out")
    with pytest.raises(ValueError, match="--out: an empty path"):
        score_options(out="")
    with pytest.raises(ValueError, match="^model: an empty path"):  # the Python door's name
        make_solver("ppo", model="")
    code = main(["solve", "--task", "example:screwdriver", "--method", "ppo", "--model", ""])
    assert code == 2 and "--model: an empty path" in capsys.readouterr().err
    for option in ("--out", "--resume", "--report-dir"):
        with pytest.raises(SystemExit):
            parse_args([option, ""])
        assert f"argument {option}: an empty path" in capsys.readouterr().err
    assert not any(tmp_path.iterdir())


# --- an outside agent's own failure is one line naming it --------------------------------------

AGENTS = {
    "mq_agent_raises": "class Agent:\n    def __init__(self, n_max):\n        raise "
    "RuntimeError('boom in __init__')\n",
    "mq_agent_import": "raise RuntimeError('boom at import')\n",
    "mq_agent_syntax": "def f(:\n",
    "mq_agent_needs": "class Agent:\n    def __init__(self, n_max, bogus):\n        pass\n"
    "    def solve(self, task):\n        return None\n",
    "mq_agent_exits_import": "import sys\nsys.exit(4)\n",
}
WORDS = {
    "mq_agent_raises": "making Agent(n_max) failed: RuntimeError: boom in __init__",
    "mq_agent_import": "importing mq_agent_import failed: RuntimeError: boom at import",
    "mq_agent_syntax": "importing mq_agent_syntax failed: SyntaxError",
    "mq_agent_needs": "making Agent(n_max) failed: TypeError",
    "mq_agent_exits_import": "importing mq_agent_exits_import failed: SystemExit: 4",
}


@pytest.mark.parametrize("module", sorted(AGENTS))
def test_an_agent_that_fails_to_load_is_one_line(tmp_path, monkeypatch, score, module):
    (tmp_path / f"{module}.py").write_text(AGENTS[module])
    monkeypatch.syspath_prepend(str(tmp_path))
    monkeypatch.delitem(sys.modules, module, raising=False)
    err = score("--methods", "greedy", "--solver", f"{module}:Agent")
    assert f"--solver '{module}:Agent': {WORDS[module]}" in err


def test_an_agent_that_calls_sys_exit_while_solving_is_one_line(tmp_path, capsys, monkeypatch):
    (tmp_path / "mq_agent_quits.py").write_text("import sys\ndef quits(task):\n    sys.exit(3)\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    argv = ["score", "--suite", str(_suite(tmp_path)), "--methods", "greedy", "--solver",
            "mq_agent_quits:quits", "--no-progress", "--out", str(tmp_path / "rep")]  # fmt: skip
    assert main(argv) == 2
    err = capsys.readouterr().err.strip()
    assert err == "modquad: error: solver 'quits' failed on task 'tiny': SystemExit: 3"


def test_a_solver_without_a_colon_is_told_how_to_write_it(score):
    assert "--solver 'mq_agents': write it as package.module:Name" in score(
        "--methods", "greedy", "--solver", "mq_agents"
    )


# --- a suite's optimum is checked before any work -----------------------------------------------


@pytest.mark.parametrize(
    "optimum, words",
    [
        ("x", "meta.optimum = 'x' is not a module count"),
        (True, "meta.optimum = True is not a module count"),
        (0, "meta.optimum = 0 is not a module count"),
        (2.0, "meta.optimum = 2.0 is not a module count"),
        (1, "meta.optimum = 1 is below the proved lower bound"),
    ],
)
def test_a_suite_optimum_that_is_not_a_module_count_is_refused(tmp_path, score, optimum, words):
    bad = _suite(tmp_path, optimum, "bad")
    assert f"{bad}: task 1 ('tiny'): {words}" in score("--methods", "greedy", suite=bad)


def test_the_shipped_suites_pass_the_optimum_check():
    from modquad_gym.geometry.module import palette
    from modquad_gym.scoring.suites import check_optima
    from modquad_gym.scoring.tiers import TIERS

    for tier in TIERS.values():
        types = palette(tier.modules) if tier.modules else None
        for name, tasks in tier.load_suites().items():
            check_optima(tasks, name, types, tier.fault)


# --- options no scored method uses ------------------------------------------------------------


@pytest.mark.parametrize(
    "argv, words",
    [
        (["--methods", "greedy", "--seed", "5"], "--seed 5: no method scored takes a seed"),
        (["--methods", "greedy", "--model", "{suite}"], "--model {suite}: not used: no learned"),
        (["--methods", "greedy", "--train-dir", "{tmp}"], "--train-dir {tmp}: not used: no"),
        (["--methods", "ppo", "--train-dir", "{tmp}/no"], "--train-dir {tmp}/no: does not exist"),
        (["--methods", "ppo", "--train-dir", "{suite}"], "--train-dir {suite}: not a folder"),
        (["--methods", "ppo", "--train-dir", "{tmp}"], "--train-dir {tmp}: no config.json or"),
        (
            ["--methods", "greedy", "--samples", "3"],
            "--samples 3: replaces the ppo-kN of "
            "--methods, and --methods has none; add ppo-k3 to --methods",
        ),
        (["--methods", "ppo", "--model", "{tmp}"], "--model {tmp}: a folder"),
        (["--methods", "ppo", "--train-dir", "{run}"], "{run}/config.json: not a model's config"),
    ],
)
def test_options_no_scored_method_uses_are_refused(tmp_path, score, argv, words):
    """Options no scored method uses, and a --train-dir whose config.json is not one, are
    refused before the work (such a config.json was found only when the report was written)."""
    (tmp_path / "run").mkdir()
    (tmp_path / "run" / "config.json").write_text("{not json")
    fill = {
        "tmp": str(tmp_path),
        "suite": str(tmp_path / "suite.json"),
        "run": str(tmp_path / "run"),
    }
    assert words.format(**fill) in score(*(a.format(**fill) for a in argv))


def test_the_python_door_refuses_the_same_options(tmp_path, monkeypatch):
    from modquad_gym.scoring.agents import chosen_methods, score
    from modquad_gym.scoring.options import score_options
    from modquad_gym.scoring.tiers import get_tier

    monkeypatch.setattr("modquad_gym.scoring.agents.run_benchmark", _no_work)
    suite = [_suite(tmp_path)]
    for given, words in (({"seed": 5}, "--seed 5"), ({"samples": 0}, "--samples 0"),
                         ({"model": suite[0]}, "--model")):  # fmt: skip
        with pytest.raises(ValueError, match=words):
            score(score_options(suite=suite, methods=["greedy"], out=tmp_path / "r", **given), "x")
    current = get_tier("current")
    assert chosen_methods(score_options(methods=["random"], seed=5), current) == ["random"]
    args = score_options(methods=["ppo-k2", "ppo-k8", "greedy"], samples=3)
    assert chosen_methods(args, current) == ["greedy", "ppo-k3"]


# --- the help says what the code does; no Ray where none is needed ------------------------------


def test_validate_help_names_the_methods_that_cannot_fly_a_fault(capsys):
    from modquad_gym.cli.common import NO_FAULT
    from modquad_gym.methods import REGISTRY

    assert NO_FAULT == "milp" == ", ".join(n for n, m in REGISTRY.items() if not m.fault)
    with pytest.raises(SystemExit):
        main(["validate", "--help"])
    text = " ".join(capsys.readouterr().out.split())
    assert f"Every method but {NO_FAULT} takes it" in text and "Not with the learned" not in text


def test_an_unreachable_ray_address_does_not_block_work_without_ray(tmp_path, capsys, monkeypatch):
    from modquad_gym.core.distributed import Engine

    task = tmp_path / "tiny.json"
    task.write_text(json.dumps(TASK))
    monkeypatch.setenv("RAY_ADDRESS", "127.0.0.1:1")
    solve = ["solve", "--task", str(task), "--n-max", "3", "--quiet"]
    assert main([*solve, "--method", "greedy"]) == 0
    # a method that spreads its work over Ray is still refused at once, as is an explicit address
    assert main([*solve, "--method", "exhaustive"]) == 2
    assert "nothing answers there" in capsys.readouterr().err
    argv = ["solve", "--task", str(task), "--task", str(task.with_name("other.json")),
            "--method", "greedy", "--ray-address", "127.0.0.1:1"]  # fmt: skip
    task.with_name("other.json").write_text(json.dumps(TASK))
    assert main([*argv, "--workers", "2"]) == 2  # two tasks: the workers would share them
    assert "nothing answers there" in capsys.readouterr().err
    engine = Engine(2, check_address=False)  # unchecked until Ray is first needed
    if engine.use_ray:
        with pytest.raises(ValueError, match="nothing answers there"):
            engine.map(abs, [1, -2])
