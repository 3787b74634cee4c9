"""The learned methods with ``fault=``: trained without failures, the policy designs for the
failure zero-shot (its environment ends an episode only once every wrench survives), and every
answer is verified to survive it, with the margin asked for; a certified answer reaches the
failure's own lower bound."""

from __future__ import annotations

import json

import numpy as np
import pytest

import modquad_gym as mq
from modquad_gym.cli import main
from modquad_gym.policy.policy import Policy
from modquad_gym.tasks import load_task

TASK = "example:screwdriver"  # optimum 3 modules; 4 after any single rotor failure


def test_use_fault_keeps_the_observation_and_none_gives_back_the_intact_design():
    policy = Policy(n_max=7)
    spaces = policy.env.observation_space, policy.env.action_space
    intact = mq.make_solver("ppo", n_max=7, model=policy).solve(load_task(TASK))
    policy.use_fault("rotor")
    assert policy.env.fault == "rotor"
    assert (policy.env.observation_space, policy.env.action_space) == spaces
    tolerant = mq.make_solver("ppo", n_max=7, model=policy, fault="rotor").solve(load_task(TASK))
    assert tolerant.n_modules > intact.n_modules  # the intact optimum does not survive
    policy.use_fault(None)
    assert policy.env.fault is None
    again = mq.make_solver("ppo", n_max=7, model=policy).solve(load_task(TASK))
    assert again.structure.cells == intact.structure.cells and again.fault is None


@pytest.mark.parametrize("method", ["ppo", "ppo-guided"])
def test_an_answer_keeps_the_margin_asked_for_after_the_failure(method):
    task = load_task(TASK)
    r = mq.make_solver(method, n_max=7, fault="rotor", fault_margin=0.05).solve(task)
    assert r.structure is not None and (r.fault, r.fault_margin) == ("rotor", 0.05)
    worst = mq.fault_margin(r.structure, task.rotor_wrenches(r.structure), task.f_max, "rotor")
    assert np.all(worst >= 0.05 - 1e-9)
    exact = mq.exhaustive_search(task, n_max=7, fault="rotor", fault_margin=0.05)
    assert r.n_modules >= exact.n_modules
    assert r.certified == (r.n_modules == r.lower_bound) and r.lower_bound <= exact.n_modules


def test_the_cli_designs_for_a_detection_delay_with_a_learned_method(capsys):
    from modquad_gym.oracle.faults import margin_for_delay

    task = load_task(TASK)
    argv = ["solve", "--task", TASK, "--method", "ppo", "--fault", "rotor", "--json", "--quiet",
            "--detection-delay", "0.03"]  # fmt: skip
    capsys.readouterr()
    assert main(argv) == 0
    record = json.loads(capsys.readouterr().out)
    asked = margin_for_delay(0.03, "rotor")
    assert asked > 0 and record["fault"] == "rotor"
    assert record["fault_margin"] == pytest.approx(asked)
    python = mq.make_solver("ppo", n_max=7, fault="rotor", fault_margin=asked).solve(task)
    assert [list(c) for c in python.structure.cells] == record["cells"]
    worst = mq.fault_margin(python.structure, task.rotor_wrenches(python.structure), task.f_max)
    assert np.all(worst >= asked - 1e-9)


def test_solvers_sharing_a_policy_each_keep_their_own_fault():
    from modquad_gym.policy.guided import GuidedSolver
    from modquad_gym.policy.ppo import PPOSolver

    task = load_task(TASK)
    policy = Policy(n_max=7)
    intact, tolerant = PPOSolver(policy), PPOSolver(policy, fault="rotor")
    guided = GuidedSolver(policy, fault="module")
    for _ in range(2):  # in turn: none sees the fault the other left in the environment
        assert intact.solve(task).fault is None and intact.solve(task).n_modules == 3
        assert tolerant.solve(task).fault == "rotor" and tolerant.solve(task).n_modules >= 4
        assert guided.solve(task).fault == "module"
    with pytest.raises(ValueError, match="applies with a fault"):
        PPOSolver(policy, fault_margin=0.1)


def test_a_palette_answer_names_its_types_and_survives_with_them():
    from modquad_gym.geometry.module import palette

    task = load_task(TASK)
    r = mq.make_solver("ppo", n_max=7, modules=palette("t45,t45m,flat"), fault="rotor").solve(task)
    record = r.to_dict()
    assert record["modules"] == [m.name for m in r.structure.modules]
    assert len(record["modules"]) == r.n_modules and record["fault"] == "rotor"
    W = task.rotor_wrenches(r.structure)
    assert mq.tolerates(r.structure, W, task.f_max, fault="rotor").all()
    named = mq.make_solver("ppo", n_max=7, modules="t45,t45m,flat", fault="rotor").solve(task)
    assert named.structure.cells == r.structure.cells  # names read as --modules reads them
    assert [m.name for m in named.structure.modules] == record["modules"]


def test_a_rotor_failure_on_one_type_below_16_modules_takes_the_fault_tier_model():
    from modquad_gym.geometry.module import palette
    from modquad_gym.policy.models import SCALE_MODEL, default_model, shipped_model

    def path(**kwargs):
        return mq.make_solver("ppo", **kwargs).policy.model_path

    assert path(n_max=10, fault="rotor") == str(shipped_model("fault"))  # trained with it
    assert path(n_max=10) == path(n_max=10, fault="module") == str(default_model(10))
    assert path(n_max=16, fault="rotor") == str(SCALE_MODEL)  # zero-shot past its sizes
    mixed = path(n_max=7, fault="rotor", modules=palette("t45,t45m,flat"))
    assert mixed == str(default_model(7, palette("t45,t45m,flat")))
