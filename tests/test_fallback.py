"""The learned methods' fallback to greedy's choice (option ``fallback``,
:meth:`~modquad_gym.policy.policy.Policy.decide`): at 0 each docking of the single pass (and of
the guided search's dive) is the policy's most likely, at 1 greedy's (with every child decided:
the greedy search's own structure, the plain reference), in between the one the rule names; a
model that never sees greedy's choice refuses a fallback, in Python and on the command line
alike."""

from __future__ import annotations

import numpy as np
import pytest

from modquad_gym.cli import main
from modquad_gym.envs.assembly.lookahead import GREEDY
from modquad_gym.policy.models import DEFAULT_MODEL, FALLBACK, SCALE_FROM
from modquad_gym.policy.policy import Policy
from modquad_gym.policy.ppo import PPOSolver
from modquad_gym.scoring.suites import draw_task
from modquad_gym.solvers import make_solver
from modquad_gym.tasks import make_generator


def tasks(n: int) -> list:
    generator = make_generator("mixed")
    return [draw_task(generator, 9100 + i) for i in range(n)]


def test_fallback_one_docks_what_greedy_docks():
    ppo = make_solver("ppo", 7, fallback=1.0, top_k=None)
    greedy = make_solver("greedy", 7)
    for task in tasks(6):
        mine, ref = ppo.solve(task), greedy.solve(task)
        assert (mine.structure is None) == (ref.structure is None)
        if ref.structure is not None:
            assert mine.structure.key == ref.structure.key


def test_the_guided_dive_with_fallback_one_is_greedys_episode():
    greedy = make_solver("greedy", 7)
    dive = make_solver("ppo-guided", 7, fallback=1.0, top_k=None, budget=1)  # the dive alone
    search = make_solver("ppo-guided", 7, fallback=1.0, top_k=None)
    for task in tasks(6):
        ref = greedy.solve(task)
        if ref.structure is None:
            continue
        assert dive.solve(task).structure.key == ref.structure.key
        assert search.solve(task).n_modules <= ref.n_modules  # the search only improves on it


def test_each_docking_is_the_one_the_rule_names():
    policy = Policy(str(DEFAULT_MODEL), n_max=7, top_k=8)
    env, rng = policy.env, np.random.default_rng(0)
    took = {"policy": 0, "greedy": 0}
    for task in tasks(8):
        obs, info = policy.reset(task)
        done = info["success"]
        while not done:
            mask = env.action_masks()
            probs = policy.probabilities(obs, mask)
            flags = obs["candidates"].reshape(len(mask), -1)[:, GREEDY]
            assert flags.sum() == 1 and mask[int(np.argmax(flags))]
            own, theirs = int(np.argmax(probs)), int(np.argmax(flags))
            assert policy.decide(obs, mask, 0.0) == policy.greedy(obs, mask) == own
            for fallback in (0.5, 0.7, 0.9):
                expected = theirs if probs[own] <= fallback else own
                assert policy.decide(obs, mask, fallback) == expected
                took["greedy" if own != theirs and probs[own] <= fallback else "policy"] += 1
            obs, _, terminated, truncated, info = env.step(int(rng.choice(np.flatnonzero(mask))))
            done = terminated or truncated
    assert took["greedy"] and took["policy"]  # both branches of the rule were exercised


@pytest.mark.parametrize("method", ["ppo", "ppo-guided"])
def test_the_default_follows_the_budget_and_what_the_model_sees(method, blind_model):
    ppo = make_solver(method, 7)
    assert ppo.inner(7, None).fallback == 0.0  # small budgets: the policy alone
    assert ppo.inner(SCALE_FROM, None).fallback == FALLBACK
    assert make_solver(method, 7, fallback=0.5).inner(7, None).fallback == 0.5
    assert make_solver(method, 7, fallback=0.0).inner(SCALE_FROM, None).fallback == 0.0
    assert PPOSolver(str(blind_model), n_max=7).fallback == 0.0  # no greedy choice to take


@pytest.mark.parametrize(
    ("model", "value", "words"),
    [
        ("blind", 0.5, "fallback=0.5: the model"),
        (DEFAULT_MODEL, 1.5, "fallback must be <= 1"),
        (DEFAULT_MODEL, -0.1, "fallback must be >= 0"),
    ],
)
@pytest.mark.parametrize("method", ["ppo", "ppo-guided"])
def test_a_fallback_the_model_cannot_take_is_refused_by_both_doors(
    method, model, value, words, capsys, blind_model
):
    model = blind_model if model == "blind" else model
    with pytest.raises(ValueError, match=words):
        make_solver(method, 7, model=str(model), fallback=value)
    argv = ["solve", "--task", "example:screwdriver", "--method", method, "--model", str(model),
            "--option", f"fallback={value}", "--quiet"]  # fmt: skip
    capsys.readouterr()
    assert main(argv) == 2
    err = capsys.readouterr().err.strip()
    assert words in err and len(err.splitlines()) == 1


def test_the_benchmark_reports_each_variant_beside_its_rival(tmp_path):
    from benchmarks import fallback

    out = tmp_path / "fb"
    argv = ["--method", "ppo-guided", "--rival", "beam", "--bands", "16", "--families", "torque",
            "--per-family", "1", "--fallbacks", "0.7", "--k", "8", "--budgets", "auto", "8",
            "--small", "1", "--out", str(out)]  # fmt: skip
    assert fallback.main(argv) == 0
    rows = (out / "rows.csv").read_text().splitlines()
    methods = {line.split(",")[3] for line in rows[1:]}
    assert methods == {"ppo-guided-top8-f0.7", "ppo-guided-top8-f0.7-b8", "beam"}
    assert len(rows) == 1 + 2 * 3  # (one small task, one torque draw) x three variants
    report = (out / "report.md").read_text()
    assert "| 16 | torque | ppo-guided-top8-f0.7-b8 |" in report and "## Small tasks" in report
    assert report.startswith("# `ppo-guided`'s fallback to greedy's choice and budget, beside beam")
    assert (out / "versus.png").stat().st_size > 0
    again = tmp_path / "again"  # re-rendered from the rows: the same page but its first lines
    assert fallback.main([*argv[:-1], str(again), "--rows", str(out / "rows.csv")]) == 0
    assert (again / "rows.csv").read_text() == (out / "rows.csv").read_text()
    redone = (again / "report.md").read_text()
    assert redone.splitlines()[3:] == report.splitlines()[3:] and "re-rendered" in redone


def test_the_benchmark_names_each_set_of_extra_passes(tmp_path):
    from benchmarks import fallback

    out = tmp_path / "fb"
    argv = ["--bands", "--fallbacks", "0", "--k", "8", "--extra-fallbacks", "none", "1", "auto",
            "--small", "2", "--out", str(out)]  # fmt: skip
    assert fallback.main(argv) == 0
    rows = [line.split(",") for line in (out / "rows.csv").read_text().splitlines()[1:]]
    assert {r[3] for r in rows} == {"ppo-top8-f0-x", "ppo-top8-f0-x1", "ppo-top8-f0", "greedy"}
    assert len({(r[2], r[3]) for r in rows}) == len(rows) == 2 * 4  # each small task its name
    found = {(r[2], r[3]): int(r[4]) for r in rows}
    for task in {r[2] for r in rows}:  # a further pass never ends above the single one
        assert found[task, "ppo-top8-f0-x1"] <= found[task, "ppo-top8-f0-x"]
        assert found[task, "ppo-top8-f0"] == found[task, "ppo-top8-f0-x"]  # none below 16
    assert "| ppo-top8-f0-x1 | 2 |" in (out / "report.md").read_text()


def test_each_small_task_has_its_own_name_and_is_the_generators_draw():
    """The benchmarks' rows pair small tasks by name (benchmarks.fallback, lookahead_top_k):
    each is named after its draw, and is still exactly what the generator draws."""
    import numpy as np

    from benchmarks.lookahead_top_k import tasks_of
    from modquad_gym.tasks import make_generator

    tasks = tasks_of([], [], 1, 40, 3)
    names = [t[0].name for t in tasks]
    assert len(set(names)) == len(names) == 40 and names[7].startswith("small-3-7-")
    mixed = make_generator("mixed")
    for i, (task, n_max, *_, family, band) in enumerate(tasks):
        drawn = mixed(np.random.default_rng([3, i]))
        assert np.array_equal(task.wrenches, drawn.wrenches) and task.f_max == drawn.f_max
        assert task.kind == drawn.kind and task.name.endswith(drawn.name)
        assert (n_max, family, band) == (7, "small", 7)


@pytest.mark.parametrize(
    ("argv", "match"),
    [
        (["--fallbacks", "1.5"], "--fallbacks"),
        (["--fallbacks", "nan"], "--fallbacks"),
        (["--k", "0"], "--k"),
        (["--per-family", "0"], "--per-family"),
        (["--bands", "129"], "--bands"),
        (["--time-limit", "0"], "--time-limit"),
        (["--method", "beam"], "--method"),
        (["--method", "ppo-guided", "--budgets", "0"], "--budgets"),
        (["--budgets", "64"], "--budgets"),  # ppo has no budget
        (["--extra-fallbacks", "0,2"], "--extra-fallbacks"),
        (["--extra-fallbacks", "0,,1"], "--extra-fallbacks"),
        (["--method", "ppo-guided", "--extra-fallbacks", "0"], "--extra-fallbacks"),
        (["--rows", "tests/test_fallback.py"], "--rows"),
    ],
)
def test_the_benchmark_refuses_bad_options_before_work(tmp_path, capsys, argv, match):
    from benchmarks import fallback
    from benchmarks.common import run_main

    out = tmp_path / "fb"
    assert run_main(fallback.main, "fallback", [*argv, "--small", "0", "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip()
    assert match in err.splitlines()[-1] and "Traceback" not in err
    assert not (out / "rows.csv").exists()
