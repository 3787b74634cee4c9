"""The learned methods by each door (``make_solver``, the command line, the solver classes of
docs/api.md): the same model, options, checks and answers."""

from __future__ import annotations

import json

import numpy as np
import pytest

from modquad_gym.cli import build_parser, main
from modquad_gym.cli.solve import SolveSpec
from modquad_gym.geometry.module import palette
from modquad_gym.policy.models import SCALE_MODEL, shipped_model
from modquad_gym.search import verified
from modquad_gym.search.problem import DEFAULT_TIME_LIMIT, SearchProblem
from modquad_gym.solvers import make_solver
from modquad_gym.tasks import make_generator

pytest.importorskip("sb3_contrib")


def cells(result) -> list | None:
    return [list(c) for c in result.structure.cells] if result.structure is not None else None


def solve_json(capsys, task: str, *argv: str) -> dict:
    code = main(["solve", "--task", task, "--json", *argv])
    out = capsys.readouterr()
    assert code == 0, out.err
    return json.loads(out.out)


# --- finding 2: a one-type self-weight task ----------------------------------------------------


@pytest.fixture(scope="module")
def external(tmp_path_factory):
    """A one-type task of kind external (the structure's weight is added), as a file."""
    task = make_generator("paper-external", n_max=5)(np.random.default_rng(1))
    path = tmp_path_factory.mktemp("external") / "external.json"
    task.save(path)
    return task, path


@pytest.mark.parametrize("method", ["ppo", "ppo-guided"])
def test_learned_methods_act_on_a_self_weight_task_of_one_type(external, capsys, method):
    """Greedy answers it; so do ppo and ppo-guided (with the one-type module set, as the
    anytime search's policy producer acts), alike by both doors, a verified answer of one type
    (no module list, as greedy's)."""
    task, path = external
    greedy = make_solver("greedy", n_max=5).solve(task)
    assert greedy.structure is not None
    result = make_solver(method, n_max=5).solve(task)
    assert result.structure is not None and not result.palette
    assert verified(result.structure, SearchProblem.build(task, 5))
    line = solve_json(capsys, str(path), "--method", method, "--n-max", "5")
    greedy_line = solve_json(capsys, str(path), "--method", "greedy", "--n-max", "5")
    assert line["cells"] == cells(result) and line["n_modules"] == result.n_modules
    assert set(line) - {"evaluated", "oracle_calls"} <= set(greedy_line) | {"proof"}
    assert "modules" not in line


def test_a_one_grid_model_says_why_it_cannot_decide_self_weight(external, tmp_path):
    """A grid-MLP model of one type has no module set: the refusal names the task, the model
    and what acts (not the environment's advice to build it with modules=)."""
    from sb3_contrib import MaskablePPO

    from modquad_gym.policy.policy import make_env

    path = tmp_path / "mlp" / "model.zip"
    MaskablePPO("MultiInputPolicy", make_env("planted", n_max=5), n_steps=16, batch_size=16,
                seed=0, policy_kwargs={"net_arch": [16]}, device="cpu").save(path)  # fmt: skip
    task, _ = external
    with pytest.raises(ValueError) as exc:
        make_solver("ppo", n_max=5, model=path).solve(task)
    text = str(exc.value)
    assert "kind 'external'" in text and str(path) in text and "size-free" in text
    assert "make the env" not in text


# --- finding 5: the solver classes check their options as make_solver does ---------------------


@pytest.mark.parametrize(
    "cls, option, value",
    [
        ("GuidedSolver", "dive", "no"),
        ("PPOSolver", "seed", 2.7),
        ("PPOSolver", "seed", True),
        ("PPOSolver", "seed", -1),
        ("PPOSolver", "seed", "x"),
        ("PPOSolver", "samples", -1),
        ("PPOSolver", "n_max", "7"),
        ("PPOSolver", "top_k", 0),
        ("GuidedSolver", "top_k", 0),
        ("PPOSolver", "time_limit", -1.0),
        ("GuidedSolver", "budget", 0),
        ("PPOSolver", "extra_fallbacks", (0.5, 2.0)),
        ("PPOSolver", "model", 3),
    ],
)
def test_the_solver_classes_check_options_with_make_solvers_words(cls, option, value):
    import modquad_gym.policy.guided as guided
    import modquad_gym.policy.ppo as ppo

    solver_class = {"PPOSolver": ppo.PPOSolver, "GuidedSolver": guided.GuidedSolver}[cls]
    method = "ppo" if cls == "PPOSolver" else "ppo-guided"
    with pytest.raises((ValueError, TypeError)) as theirs:
        make_solver(method, **{option: value})
    with pytest.raises(type(theirs.value)) as ours:
        solver_class(**{option: value})
    assert str(ours.value) == str(theirs.value)
    assert option in str(ours.value)


# --- finding 6: the T-module named alone is one type -------------------------------------------


def test_the_t_module_named_alone_gets_the_one_type_model(capsys, tmp_path):
    plain = make_solver("ppo", n_max=24)
    named = make_solver("ppo", n_max=24, modules=palette("t45"))
    assert plain.policy.model_path == named.policy.model_path == str(SCALE_MODEL)
    task = make_generator("planted-16-64", n_max=24)(np.random.default_rng(8))
    path = tmp_path / "planted.json"
    task.save(path)
    answer = plain.solve(task)
    assert answer.structure is not None and cells(named.solve(task)) == cells(answer)
    for extra in ((), ("--modules", "t45")):
        line = solve_json(capsys, str(path), "--method", "ppo", "--n-max", "24", *extra)
        assert line["cells"] == cells(answer)


# --- finding 7: the fault model, as the help says ----------------------------------------------


def test_the_fault_help_says_which_model_is_trained_with_failures(capsys):
    assert make_solver("ppo", fault="rotor").policy.model_path == str(shipped_model("fault"))
    for command in ("solve", "validate"):
        with pytest.raises(SystemExit):
            main([command, "--help"])
        text = " ".join(capsys.readouterr().out.split())
        assert "no model was trained with failures" not in text
        assert "ppo_fault" in text


# --- the time limit: one default by both doors --------------------------------------------------


@pytest.mark.parametrize("method", ["ppo", "ppo-guided"])
def test_the_learned_methods_default_time_limit_is_the_command_lines(method):
    args = build_parser(["solve"]).parse_args(["solve", "--task", "x.json", "--method", method])
    cli = SolveSpec.of(args).solver()
    python = make_solver(method)
    assert cli.time_limit == python.time_limit == args.time_limit == DEFAULT_TIME_LIMIT


# --- a seed where nothing is drawn ---------------------------------------------------------


def test_plain_ppo_refuses_a_seed_it_would_not_use(capsys):
    """ppo without samples draws nothing at random: a seed other than the default is refused
    at each door in the words of a method that takes none; with samples it seeds them."""
    expected = "method 'ppo' does not take it without samples: it then draws nothing at random"
    with pytest.raises(ValueError, match=f"^seed=1: {expected}"):
        make_solver("ppo", seed=1)
    with pytest.raises(ValueError, match=f"^seed=2: {expected}"):
        from modquad_gym.policy.ppo import PPOSolver

        PPOSolver(seed=2)
    assert make_solver("ppo", seed=1, samples=2).seed == 1
    assert make_solver("ppo", seed=0).name == "ppo"
    for argv, said in ((["--seed", "1"], "--seed 1"), (["--option", "seed=2"], "--option seed=2")):
        code = main(["solve", "--task", "example:planted_seed1", "--method", "ppo", *argv])
        assert code == 2
        assert capsys.readouterr().err.strip() == f"modquad: error: {said}: {expected} (its " \
            "sampled rollouts do: ppo-kN)"  # fmt: skip
    for argv in (["--method", "ppo-k2", "--seed", "1"],
                 ["--method", "ppo", "--option", "samples=2", "--seed", "1"]):  # fmt: skip
        assert solve_json(capsys, "example:planted_seed1", *argv)["n_modules"] is not None


def test_scoring_tells_the_seed_only_to_the_methods_that_draw():
    """``modquad score --seed`` reaches ppo-kN's rollouts, not ppo's single pass (which would
    refuse it); a run of plain ppo alone takes no seed."""
    from modquad_gym.scoring.agents import _solvers, takes_seed

    solvers = _solvers(("ppo", "ppo-k2", "beam"), 7, None, 3, None)
    assert solvers["ppo-k2"].seed == 3 and solvers["beam"].settings.seed == 3
    assert solvers["ppo"].seed == 0
    assert not takes_seed("ppo", {}) and takes_seed("ppo-k2", {}) and takes_seed("beam", {})
