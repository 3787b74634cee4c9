"""The dynamic tier: random motion tasks, suites of dynamic tasks, certified optima, scoring."""

from __future__ import annotations

import csv
from collections import Counter

import gymnasium as gym
import numpy as np
import pytest

import modquad_gym as mq
from modquad_gym.dynamics import DynamicTask
from modquad_gym.dynamics.random_motions import RANGES, MotionTasks
from modquad_gym.scoring.agents import main as bench_main
from modquad_gym.scoring.agents_report import _goals
from modquad_gym.scoring.suites import draw_task, with_optimum
from modquad_gym.scoring.tiers import TIERS
from modquad_gym.search import exhaustive_search, verified
from modquad_gym.tasks import load_suite, make_generator, save_suite


def test_motion_tasks_are_seeded_varied_and_within_their_ranges():
    gen = make_generator("motions")
    assert isinstance(gen, MotionTasks)
    tasks = [gen(np.random.default_rng(s)) for s in range(60)]
    again = gen(np.random.default_rng(7))
    assert again.to_dict() == tasks[7].to_dict()
    assert all(isinstance(t, DynamicTask) for t in tasks)
    assert set(Counter(t.meta["motion"] for t in tasks)) == set(mq.dynamics.MOTIONS)
    for t in tasks:
        motion = t.meta["motion"]
        assert t.f_max == 2.0 and t.trajectory.n_samples < 1000
        if motion == "hover":  # a hover always carries a payload, held off the centre
            lo, hi = RANGES["hover_payload_kg"]
            assert t.payload is not None and lo <= t.payload.mass <= hi
        if t.payload is not None:
            radius = np.hypot(*t.payload.offset[:2])
            assert radius <= RANGES["payload_radius_m"][1] + 1e-12
            assert -RANGES["payload_drop_m"][1] <= t.payload.offset[2] <= 0
        if motion == "push":  # the tool below the COM turns the contact force into a torque
            arm = np.array([0.0, 0.0, -t.meta["tool_length_m"]])
            f = t.exerted[:, :3]
            np.testing.assert_allclose(t.exerted[:, 3:], np.cross(arm, f), atol=1e-12)
        if motion == "circle":
            assert RANGES["circle_speed"][0] <= t.meta["speed"] <= RANGES["circle_speed"][1]


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"motions": ("spiral",)}, "motions: unknown 'spiral'"),
        ({"motions": ()}, "motions: unknown 'empty list'"),
        ({"payload_share": 1.5}, "payload_share"),
        ({"rate": 0}, "rate"),
        ({"f_max": float("nan")}, "f_max"),
    ],
)
def test_motion_tasks_refuse_bad_settings_in_one_line(kwargs, message):
    with pytest.raises(ValueError, match=message) as info:
        MotionTasks(**kwargs)
    assert "\n" not in str(info.value)


def test_one_motion_only():
    gen = MotionTasks(motions="circle")
    assert {gen(np.random.default_rng(s)).meta["motion"] for s in range(5)} == {"circle"}


def test_suites_round_trip_dynamic_and_static_tasks(tmp_path):
    gen = MotionTasks()
    dynamic = [draw_task(gen, s, name=f"d{s}") for s in range(3)]
    static = draw_task(make_generator("planted"), 0, name="s0")
    path = save_suite([*dynamic, static], tmp_path / "both.json")
    back = load_suite(path)
    assert [type(t) for t in back] == [DynamicTask] * 3 + [mq.TaskRequirement]
    for a, b in zip(dynamic, back, strict=False):
        assert a.to_dict() == b.to_dict() and b.meta["seed"] == a.meta["seed"]
    np.testing.assert_array_equal(back[3].wrenches, static.wrenches)
    drawn = make_generator(str(path))(np.random.default_rng(0))  # a suite as a task source
    assert drawn.name in {t.name for t in back}


def test_a_bad_dynamic_task_in_a_suite_is_named(tmp_path):
    path = save_suite([draw_task(MotionTasks(), 0)], tmp_path / "s.json")
    path.write_text(path.read_text().replace('"f_max": 2.0', '"f_max": -1'))
    with pytest.raises(ValueError, match=r"s\.json: task 1: f_max"):
        load_suite(path)


def test_with_optimum_certifies_a_dynamic_task():
    task = with_optimum(draw_task(MotionTasks(), 11), n_max=6)
    n = task.meta["optimum"]
    assert n is not None and task.meta["optimum_n_max"] == 6
    best = mq.Structure([tuple(c) for c in task.meta["optimum_cells"]])
    assert best.n_modules == n and verified(best, task)
    # no structure of one module fewer flies it (the search's certificate, recomputed)
    assert exhaustive_search(task, n_max=n - 1).structure is None


def test_shipped_dynamic_optima_fly_their_own_tasks():
    tier = TIERS["dynamic"]
    tasks = tier.load_suites(limit=12)["dynamic_motions"]
    assert all(isinstance(t, DynamicTask) for t in tasks)
    for task in tasks:
        if task.meta["optimum"] is None:
            continue
        s = mq.Structure([tuple(c) for c in task.meta["optimum_cells"]])
        assert s.n_modules == task.meta["optimum"] and verified(s, task)
        # the structure's own weight matters: the same wrenches without it are not the task's
        assert not np.allclose(task.rotor_wrenches(s), task.static_wrenches())


def test_dynamic_tier_env_is_registered_with_its_limits():
    env = gym.make("ModQuadAssemblyDynamic-v0")
    assert env.unwrapped.n_max == 7 and env.unwrapped.max_steps == 28
    _, info = env.reset(seed=5)
    assert info["task_name"] == "motions"
    env.close()


def test_bench_agents_scores_the_dynamic_tier(tmp_path):
    out = tmp_path / "rep"
    code = bench_main(["--tier", "dynamic", "--methods", "exhaustive", "greedy", "ppo",
                       "--limit", "4", "--out", str(out), "--no-progress"])  # fmt: skip
    assert code == 0
    with open(out / "benchmark.csv", newline="") as fh:
        rows = list(csv.DictReader(fh))
    assert {r["method"] for r in rows} == {"exhaustive", "greedy", "ppo"}
    exhaustive = [r for r in rows if r["method"] == "exhaustive"]
    assert len(exhaustive) == 4
    assert all(r["optimal"] == "1" for r in exhaustive if r["optimum"])
    assert all(r["success"] == "0" or int(r["gap"]) >= 0 for r in rows if r["optimum"])
    report = (out / "benchmark.md").read_text()
    assert "tier `dynamic`" in report and "--tier dynamic" in report


def test_one_run_goals_name_each_methods_own_goal():
    def row(method, success, optimal):
        return {"method": method, "success_rate": success, "optimal_share": optimal,
                "mean_evaluated": 5.0}  # fmt: skip

    summary = [row("greedy", 1.0, 0.9), row("ppo", 0.99, 0.8), row("ppo-guided", 1.0, 0.96)]
    goals = {"ppo-guided": {"success": 0.98, "optimal": 0.95}, "ppo": {"optimal": "greedy"}}
    lines = {line.split("|")[1].strip(): line for line in _goals(summary, goals)[4:]}
    assert "80.0 % (goal >= greedy's 90.0 %): NOT met" in lines["ppo"]
    assert "96.0 % (goal >= 95 %): met" in lines["ppo-guided"]
    assert "99.0 %" in lines["ppo"] and "goal >= 98" not in lines["ppo"]  # ppo's own goals
