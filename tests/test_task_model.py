"""One task model: every task (total, external, dynamic) answers the same questions, and the
package outside ``tasks/`` and ``dynamics/`` asks them instead of branching on the kind."""

from __future__ import annotations

import numpy as np
import pytest

import modquad_gym as mq
from benchmarks.codebase import kind_branches
from modquad_gym.dynamics import Payload, as_dynamic, circle, hover
from modquad_gym.search.dynamic import DynamicValues, UniformLiftValues, wrench_values
from modquad_gym.search.problem import SearchProblem
from modquad_gym.tasks import TaskRequirement

MAX_KIND_BRANCHES = 5
"""The issue's goal: at most this many tests of a task's kind outside the task model."""

W = np.array([[0.0, 0.0, 3.0, 0.1, 0.0, 0.0], [0.2, 0.0, 2.5, 0.0, 0.1, 0.05]])


def tasks() -> list:
    return [
        TaskRequirement(W, name="t"),
        TaskRequirement(W, name="e", f_max=4.0, kind="external"),
        circle(radius=0.5, laps=0.5, ramp=0.2, hold=0.1, rate=20.0, payload=Payload(0.1)),
    ]


def test_kind_branches_outside_the_task_model_are_at_most_five():
    found = kind_branches()
    assert len(found) <= MAX_KIND_BRANCHES, "\n".join(f"{f}:{n}: {c}" for f, n, c in found)


@pytest.mark.parametrize("task", tasks(), ids=lambda t: t.kind)
def test_every_task_answers_the_same_interface(task):
    s = mq.Structure([(0, 0), (1, 0)])
    assert np.allclose(task.rotor_wrenches(s), task.wrench_model.for_structure(s))
    assert task.describe().startswith(f"{task.n_wrenches} wrenches")
    assert task.with_kind(None) is task and task.with_f_max(None) is task
    assert task.with_f_max(7.0).f_max == 7.0
    again = task.relabelled("other", {"seed": 3})
    assert (again.name, again.meta) == ("other", {"seed": 3})
    assert task.check_liftable([s.module]) >= 1
    assert task.flight_seconds(2.0) > 0
    assert isinstance(task.per_structure, bool) and isinstance(task.normalised_units, bool)
    p = SearchProblem.build(task, n_max=3)
    assert p.task is task and p.kind == task.kind
    assert p.model is task.decision_model or np.array_equal(p.model.base, task.decision_model.base)


def test_kinds_answer_differently_where_they_differ():
    total, external, dynamic = tasks()
    assert [t.describe() for t in (total, external)] == ["2 wrenches", "2 wrenches (external)"]
    assert dynamic.describe().endswith("(dynamic)")
    assert (total.normalised_units, external.normalised_units, dynamic.normalised_units) == (
        True, False, False)  # fmt: skip
    assert [t.per_structure for t in (total, external, dynamic)] == [False, False, True]
    assert [t.policy_tier for t in (total, external, dynamic)] == [None, None, "dynamic"]
    assert total.with_kind("external") == TaskRequirement(W, name="t", kind="external")
    with pytest.raises(ValueError, match="a task with a trajectory is 'dynamic'"):
        dynamic.with_kind("total")
    assert dynamic.flight_seconds(2.0) == dynamic.trajectory.duration
    with pytest.raises(ValueError, match="task must be a DynamicTask, got TaskRequirement"):
        as_dynamic(total)


def test_uniform_lift_values_equal_the_general_ones_where_both_apply():
    """A task whose every wrench gains the same weight term (external, a level hover) is
    decided through :class:`UniformLiftValues`; its values and wrenches are those the general
    :class:`DynamicValues` gives (exact there: no inertia term)."""
    palette = [mq.TModule()]
    rng = np.random.default_rng(0)
    D = rng.normal(size=(9, 6))
    for task in (tasks()[1], hover(duration=1.0, rate=10.0, payload=Payload(0.2))):
        model = task.decision_model
        fast, general = wrench_values(model, palette), DynamicValues(model, palette)
        assert isinstance(fast, UniformLiftValues)
        for mass, n in ((0.3, 1), (1.2, 4)):
            assert np.allclose(fast.values(D, mass, n), general.values(D, mass, n))
            assert np.array_equal(fast.wrenches(mass, None), general.wrenches(mass, None))
    assert isinstance(wrench_values(tasks()[2].decision_model, palette), DynamicValues)
