"""The shipped pair of one network (issue 36, item 3): without ``--model`` a learned method acts
with the default model below SCALE_FROM modules of budget and with the model after expert
iteration at 8-32 modules from there on; both are size-free, so either acts at any size."""

from __future__ import annotations

import json

import pytest

pytest.importorskip("sb3_contrib")

from modquad_gym.geometry.module import palette  # noqa: E402
from modquad_gym.policy import DEFAULT_MODEL, SCALE_FROM, SCALE_MODEL, default_model  # noqa: E402
from modquad_gym.policy.policy import Policy  # noqa: E402
from modquad_gym.search import verified  # noqa: E402
from modquad_gym.solvers import make_solver  # noqa: E402


def test_the_budget_picks_the_model():
    assert default_model(None) == default_model(7) == default_model(SCALE_FROM - 1) == DEFAULT_MODEL
    assert default_model(SCALE_FROM) == default_model(64) == SCALE_MODEL
    assert default_model(64, palette("t45,t45m,flat")) == DEFAULT_MODEL  # trained on one type
    assert Policy(None, n_max=7).model_path == str(DEFAULT_MODEL)
    assert Policy(None, n_max=SCALE_FROM).model_path == str(SCALE_MODEL)
    assert Policy(str(DEFAULT_MODEL), n_max=40).model_path == str(DEFAULT_MODEL)  # --model wins


def test_the_scale_model_says_how_it_was_made():
    config = json.loads(SCALE_MODEL.with_name("config.json").read_text())
    made = config["expert_iteration"]
    while made["start"] != "modquad_gym/data/models/ppo_default/model.zip":  # warm starts
        assert made["start"].endswith("model.zip") and made["command"].startswith(
            "python -m agents.expert_iteration"
        )
        made = made["start_made_by"]  # how the start model was made, back to the default
    assert made["command"].startswith("python -m agents.expert_iteration")
    assert 1 <= made["round"] <= made["rounds"] and made["learner"] and made["replay"] > 0
    assert config["env_kwargs"]["lookahead"] == "exact" and Policy(SCALE_MODEL).size_free


def test_ppo_at_scale_acts_with_the_scale_model_and_its_answer_is_verified():
    from benchmarks.scale_suites import draw

    task = draw("torque", 16, 0, validation=True)
    ppo = make_solver("ppo", n_max=24)
    result = ppo.solve(task)
    assert ppo.policy.model_path == str(SCALE_MODEL)
    assert result.structure is not None and verified(result.structure, task)
    mixed = make_solver("ppo-guided", n_max=24, modules=palette("t45,t45m,flat"))
    assert mixed.policy.model_path == str(DEFAULT_MODEL)


def test_the_portfolios_policy_producer_follows_the_same_rule(monkeypatch):
    from modquad_gym.policy import guided
    from modquad_gym.search.problem import SearchProblem

    seen = []
    real = guided.GuidedSolver
    monkeypatch.setattr(guided, "GuidedSolver", lambda **k: seen.append(k["model"]) or real(**k))
    task = draw_small()
    for n_max, modules in ((24, None), (7, None), (24, palette("t45,t45m,flat"))):
        problem = SearchProblem.build(task, n_max, modules=modules)
        assert guided.guided_producer(problem, time_limit=5.0) is not None
    assert seen == [SCALE_MODEL, DEFAULT_MODEL, DEFAULT_MODEL]


def draw_small():
    import numpy as np

    from modquad_gym.tasks import PlantedTasks

    return PlantedTasks(n_modules=(3, 4), n_wrenches=(4, 6))(np.random.default_rng(0))
