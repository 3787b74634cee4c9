"""Agents: the Solver interface, a short PPO training that learns, the default model, the CLI
round trip and the benchmark on a tiny suite."""

from __future__ import annotations

import csv
import importlib.util
import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import modquad_gym as mq
from modquad_gym.geometry.structure import Structure
from modquad_gym.oracle import feasible
from modquad_gym.policy import DEFAULT_MODEL
from modquad_gym.search import SearchResult
from modquad_gym.search.bounds import bound_levels
from modquad_gym.solvers import Solver, make_solver
from modquad_gym.tasks import PlantedTasks, TaskRequirement, save_suite

ROOT = Path(__file__).resolve().parents[1]
SUITES = ROOT / "modquad_gym" / "data" / "suites"
TINY_N_MAX = 3


def _tiny_tasks() -> list[TaskRequirement]:
    """Two planted 2-module tasks, one needing a horizontal pair, one a vertical pair."""
    gen = PlantedTasks(n_modules=2, n_wrenches=24)
    return [gen(np.random.default_rng(seed)) for seed in (0, 1)]


def _ok(cells, task: TaskRequirement) -> bool:
    A = Structure([tuple(c) for c in cells]).configuration_matrix()
    return bool(feasible(A, task.wrenches, task.f_max, method="daqp").all())


def _train_tiny(tmp: Path, *options: str) -> Path:
    """Run train.py on the tiny task set into ``tmp / "model"`` (no report); returns that
    folder. ``options`` are train.py options on top of the tiny set-up."""
    suite = save_suite(_tiny_tasks(), tmp / "tiny.json")
    spec = importlib.util.spec_from_file_location("train_script", ROOT / "train.py")
    train = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(train)
    out = tmp / "model"
    argv = ["--task-source", str(suite), "--n-max", str(TINY_N_MAX), "--out", str(out),
            "--tensorboard", str(tmp / "tb"), "--no-report", "--no-progress", "--n-eval", "4",
            *options]  # fmt: skip
    assert train.main(argv) == 0
    config = json.loads((out / "config.json").read_text())
    lookahead = {} if "mlp" in options else {"lookahead": "exact"}
    assert config["env_kwargs"] == {"tasks": str(suite), "n_max": TINY_N_MAX, **lookahead}
    return out


@pytest.fixture(scope="module")
def tiny_model(tmp_path_factory) -> Path:
    """A few thousand steps of PPO alone (no cloning) with from-scratch settings, on the grid
    MLP (the size-free network is tested in test_policy_network.py): this model shows that PPO
    itself learns."""
    hyperparameters = '{"learning_rate": 3e-4, "ent_coef": 0.01, "net_arch": [128, 128]}'
    out = _train_tiny(tmp_path_factory.mktemp("tiny"), "--timesteps", "3072", "--eval-freq",
                      "1024", "--seed", "3", "--bc-epochs", "0", "--architecture", "mlp",
                      "--hyperparameters", hyperparameters)  # fmt: skip
    config = json.loads((out / "config.json").read_text())
    assert config["timesteps"] >= 3072 and config["imitation"] is None
    assert (out / "evaluations.npz").is_file()
    return out / "model.zip"


def test_train_clones_the_expert_before_ppo(tmp_path):
    """The default recipe's path: demonstrations, cloning, DAgger (its three rounds on 16 tasks
    each), a step-0 evaluation, fine-tuning."""
    out = _train_tiny(tmp_path, "--timesteps", "512", "--eval-freq", "256", "--demo-tasks", "16",
                      "--bc-epochs", "30", "--dagger-tasks", "16", "--workers", "1")  # fmt: skip
    config = json.loads((out / "config.json").read_text())
    assert config["imitation"]["expert_episodes"] == 16
    assert [r["tasks"] for r in config["imitation"]["dagger"]] == [16, 16, 16]
    assert config["imitation"]["final_greedy_good"] == 1.0
    evals = np.load(out / "evaluations.npz")
    assert evals["timesteps"][0] == 0 and evals["results"].shape[1] == 4  # cloned, before PPO
    assert list((tmp_path / "tb" / f"{tmp_path.name}-model" / "bc").glob("events.out.tfevents.*"))
    from modquad_gym.policy.ppo import PPOSolver

    solver = PPOSolver(model=out / "model.zip", n_max=TINY_N_MAX)
    for task in _tiny_tasks():
        r = solver.solve(task)
        assert r.n_modules == 2 and _ok(r.structure.cells, task)


def test_search_solvers_share_the_interface():
    task = _tiny_tasks()[0]
    for method in ("exhaustive", "centrosymmetric", "greedy", "random"):
        solver = make_solver(method, n_max=TINY_N_MAX)
        assert isinstance(solver, Solver) and solver.name == method
        r = solver.solve(task)
        assert isinstance(r, SearchResult) and r.evaluated >= 1
        if r.structure is not None:
            assert _ok(r.structure.cells, task)
    assert make_solver("exhaustive", n_max=TINY_N_MAX).solve(task).n_modules == 2


def test_bad_method_and_options_raise():
    with pytest.raises(ValueError, match="unknown method"):
        make_solver("astar")
    with pytest.raises(TypeError, match="has no option 'model'"):
        make_solver("greedy", model="x.zip")
    with pytest.raises(ValueError, match="does not exist"):
        make_solver("ppo", model=ROOT / "no_such_model.zip")


def test_import_agents_does_not_import_torch():
    code = (
        "import sys, modquad_gym.solvers as agents; agents.make_solver('greedy'); "
        "print('torch' in sys.modules)"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "False"


def test_tiny_set_needs_the_right_orientation():
    """Premise of the learning test: each task is solved by one 2-module pair and not the other,
    so a random first docking picks the optimal structure only half the time."""
    horizontal, vertical = [(0, 0), (1, 0)], [(0, 0), (0, 1)]
    a, b = _tiny_tasks()
    assert _ok(horizontal, a) and not _ok(vertical, a)
    assert _ok(vertical, b) and not _ok(horizontal, b)


def test_short_training_beats_random_policy(tiny_model):
    from modquad_gym.envs.assembly import ModQuadAssemblyEnv
    from modquad_gym.policy.ppo import PPOSolver

    tasks = _tiny_tasks()
    env = ModQuadAssemblyEnv(tasks=tasks, n_max=TINY_N_MAX)
    rng = np.random.default_rng(0)
    random_optimal = []
    for _ in range(40):
        for task in tasks:
            _, info = env.reset(options={"task": task})
            done = info["success"]
            while not done:
                action = rng.choice(np.flatnonzero(env.action_masks()))
                _, _, term, trunc, info = env.step(action)
                done = term or trunc
            random_optimal.append(info["success"] and info["n_modules"] == 2)
    solver = PPOSolver(model=tiny_model, n_max=TINY_N_MAX)
    results = [solver.solve(task) for task in tasks]
    ppo_optimal = [r.n_modules == 2 for r in results]
    assert 0.3 < np.mean(random_optimal) < 0.7  # the premise, measured
    assert np.mean(ppo_optimal) == 1.0
    for r, task in zip(results, tasks):
        assert r.evaluated == 2 and _ok(r.structure.cells, task)


def test_ppo_sampling_and_budget(tiny_model):
    from modquad_gym.policy.ppo import PPOSolver

    task = _tiny_tasks()[1]
    sampled = make_solver("ppo", n_max=TINY_N_MAX, model=tiny_model, seed=1, samples=3)
    r = sampled.solve(task)
    assert r.method == "ppo-k3" and _ok(r.structure.cells, task)
    # the deterministic rollout finds the 2-module optimum; sampled rollouts cannot beat it,
    # so they stop at once and add no structure to the distinct count
    assert r.n_modules == 2 and r.evaluated == 2
    with pytest.raises(ValueError, match="exceeds"):
        PPOSolver(model=tiny_model, n_max=TINY_N_MAX + 1)
    # a budget of one module: the answer needs two, so it is a failure, never a success
    assert PPOSolver(model=tiny_model, n_max=1).solve(task).structure is None


def test_cli_solve_ppo_json_round_trip(tiny_model, tmp_path, capsys):
    """The command's JSON line, read back; in this process (a fresh one imports torch for
    seconds; other tests start ``python -m modquad_gym.cli`` itself)."""
    from modquad_gym.cli import main

    task = _tiny_tasks()[0]
    path = task.save(tmp_path / "task.json")
    argv = ["solve", "--task", str(path), "--method", "ppo", "--model", str(tiny_model),
            "--n-max", str(TINY_N_MAX), "--json"]  # fmt: skip
    capsys.readouterr()
    code = main(argv)
    out = capsys.readouterr()
    assert code == 0, out.err
    record = json.loads(out.out.strip().splitlines()[-1])
    assert {"cells", "n_modules", "evaluated", "feasible", "seconds"} <= set(record)
    assert record["feasible"] is True and record["n_modules"] == len(record["cells"])
    assert _ok(record["cells"], task)


def test_benchmark_runs_on_three_tasks(tiny_model, tmp_path):
    from modquad_gym.scoring import agents as benchmark
    from modquad_gym.scoring.suites import with_optimum

    tasks = [*_tiny_tasks(), PlantedTasks(n_modules=3, n_wrenches=10)(np.random.default_rng(7))]
    suite = save_suite([with_optimum(t, TINY_N_MAX) for t in tasks], tmp_path / "three.json")
    argv = ["--suite", str(suite), "--model", str(tiny_model), "--out", str(tmp_path / "rep"),
            "--n-max", str(TINY_N_MAX), "--methods", "exhaustive", "centrosymmetric", "ppo",
            "ppo-k2", "--no-progress"]  # fmt: skip
    assert benchmark.main(argv) == 0
    with open(tmp_path / "rep" / "benchmark.csv") as fh:
        rows = list(csv.DictReader(fh))
    assert len(rows) == 3 * 4
    exhaustive = [r for r in rows if r["method"] == "exhaustive"]
    assert all(r["optimal"] == "1" for r in exhaustive if r["optimum"])
    report = (tmp_path / "rep" / "benchmark.md").read_text()
    assert "| ppo |" in report and "Goals" in report
    assert (tmp_path / "rep" / "benchmark_bars.png").is_file()
    assert (tmp_path / "rep" / "learning_curve.png").is_file()


@pytest.mark.skipif(not DEFAULT_MODEL.is_file(), reason="no default model yet: run train.py")
def test_default_model_solves_example_task():
    solver = make_solver("ppo")
    task = TaskRequirement.load(ROOT / "examples" / "screwdriver.json")
    r = solver.solve(task)
    assert r.structure is not None and _ok(r.structure.cells, task)
    assert r.evaluated == r.n_modules  # one rollout: the initial module plus one per docking


def test_ppo_solver_rebuilds_a_lookahead_env_from_the_model(tmp_path):
    import torch
    from sb3_contrib import MaskablePPO

    from modquad_gym.policy.ppo import PPOSolver, env_kwargs_of, make_env

    torch.set_num_threads(1)
    model = MaskablePPO("MultiInputPolicy", make_env("planted", n_max=3, lookahead=True),
                        n_steps=32, batch_size=32, seed=0)  # fmt: skip
    inferred = env_kwargs_of(model, {})  # no config: read from the observation spaces
    assert inferred["lookahead"] is True and inferred["n_max"] == 3
    model.save(tmp_path / "model.zip")
    config = {"env_kwargs": {"tasks": "planted", "n_max": 3, "lookahead": True}}
    (tmp_path / "config.json").write_text(json.dumps(config))
    solver = PPOSolver(tmp_path / "model.zip", n_max=3)
    assert solver.policy.env.lookahead
    task = _tiny_tasks()[0]
    r = solver.solve(task)
    assert r.structure is None or _ok(r.structure.cells, task)
    assert r.evaluated >= 1


@pytest.mark.skipif(not DEFAULT_MODEL.is_file(), reason="no default model")
def test_policy_guided_search_is_verified_and_its_certificate_holds():
    from modquad_gym.policy.guided import GuidedSolver
    from modquad_gym.tasks import load_suite

    solver = GuidedSolver(budget=40)
    tasks = (
        load_suite(SUITES / "heldout_planted.json")[:6]
        + load_suite(SUITES / "heldout_paper.json")[:3]
    )
    for task in tasks:
        r = solver.solve(task)
        optimum = task.meta["optimum"]
        assert r.evaluated <= 40
        assert bound_levels(solver.policy.problem(task)) <= optimum and r.lower_bound <= optimum
        if r.structure is not None:
            assert r.n_modules >= optimum
            A = r.structure.configuration_matrix()
            assert mq.feasible(A, task.wrenches, task.f_max, method="scipy").all()
        if r.certified:
            assert r.n_modules == optimum


def test_one_solver_table_drives_cli_benchmark_and_solvers():
    from modquad_gym.cli import build_parser
    from modquad_gym.scoring.agents import SEARCH_METHODS
    from modquad_gym.search import SEARCHES
    from modquad_gym.solvers import METHODS

    solve = build_parser()._subparsers._group_actions[0].choices["solve"]
    (method,) = [a for a in solve._actions if a.dest == "method"]
    assert method.metavar == "{" + ",".join(METHODS) + "}"
    assert [method.type(m) for m in METHODS] == list(METHODS)
    assert SEARCH_METHODS == tuple(SEARCHES) == METHODS[: len(SEARCHES)]
    assert all(isinstance(make_solver(m), Solver) for m in SEARCHES)
