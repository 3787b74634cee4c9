"""``ppo``'s further deterministic passes (option ``extra_fallbacks``): one tree that shares the
dockings its passes agree on must answer as the best of the separate passes does (the plain
reference: one ``Policy.rollout`` per fallback), evaluate no more structures than they do
together, and with none give the single pass's own structure; bad values are refused in Python
and on the command line alike."""

from __future__ import annotations

import pytest

from modquad_gym.cli import main
from modquad_gym.policy.models import (
    DEFAULT_MODEL,
    EXTRA_FALLBACKS,
    EXTRA_FROM,
    SCALE_FROM,
    SMALL_EXTRA_FALLBACKS,
)
from modquad_gym.policy.policy import Policy
from modquad_gym.policy.ppo import PPOSolver
from modquad_gym.scoring.scale_tasks import draw
from modquad_gym.scoring.suites import draw_task
from modquad_gym.search import verified
from modquad_gym.solvers import make_solver
from modquad_gym.tasks import make_generator


def small_tasks(n: int) -> list:
    generator = make_generator("mixed")
    return [draw_task(generator, 9300 + i) for i in range(n)]


def separate_passes(policy: Policy, task, fallbacks) -> tuple[int | None, int]:
    """The fewest modules over one plain rollout per fallback, and the structures they saw."""
    best, seen = None, set()
    for fallback in fallbacks:
        info = policy.rollout(task, seen=seen, fallback=fallback)
        n = len(info["cells"])
        if info["success"] and verified(policy.env.structure, task) and (best is None or n < best):
            best = n
    return best, len(seen)


@pytest.mark.parametrize("extra", [(0.0, 1.0), (1.0,), (0.0, 0.5, 1.0)])
def test_the_tree_answers_as_the_best_of_its_separate_passes(extra):
    policy = Policy(str(DEFAULT_MODEL), n_max=7, top_k=8)
    tree = PPOSolver(policy, fallback=0.7, extra_fallbacks=extra)
    assert tree.fallbacks == (0.7, *extra)
    branched = 0
    for task in small_tasks(12):
        result = tree.solve(task)
        best, seen = separate_passes(policy, task, tree.fallbacks)
        assert result.n_modules == best
        assert result.evaluated <= seen
        branched += seen > separate_passes(policy, task, (0.7,))[1]
    assert branched  # some task where the passes went different ways


def test_at_scale_too():
    task = draw("torque", 16, 2, validation=True)  # a draw where the shortlisted passes differ
    policy = Policy(None, n_max=64, top_k=8)
    tree = PPOSolver(policy, fallback=0.7, extra_fallbacks=(0.0, 1.0))
    best, seen = separate_passes(policy, task, (0.7, 0.0, 1.0))
    result = tree.solve(task)
    assert result.n_modules == best and result.evaluated <= seen


def test_without_extra_passes_it_is_the_single_pass():
    policy = Policy(str(DEFAULT_MODEL), n_max=7, top_k=8)
    solver = PPOSolver(policy, fallback=0.0, extra_fallbacks=())
    for task in small_tasks(8):
        info = policy.rollout(task, fallback=0.0)
        reference = policy.env.structure if info["success"] else None
        result = solver.solve(task)
        assert (result.structure is None) == (reference is None)
        if reference is not None:
            assert result.structure.key == reference.key


def test_the_default_follows_the_budget_and_what_the_model_sees(blind_model):
    ppo = make_solver("ppo", 7)
    small = ppo.inner(7, None)  # the policy's pass, greedy's choice's beside it at every size
    assert small.fallbacks == (0.0, *SMALL_EXTRA_FALLBACKS) and small.extra_from == 0
    scale = ppo.inner(SCALE_FROM, None)  # the extra passes where the first ends above EXTRA_FROM
    expected = tuple(dict.fromkeys((scale.fallback, *EXTRA_FALLBACKS)))
    assert scale.fallbacks == expected and scale.extra_from == EXTRA_FROM
    for n_max in (7, SCALE_FROM):  # a model blind to greedy's choice: none
        assert PPOSolver(str(blind_model), n_max=n_max).fallbacks == (0.0,)
    given = make_solver("ppo", SCALE_FROM, extra_fallbacks=0.5).inner(SCALE_FROM, None)
    assert given.extra_from == 0  # given values run whatever the first pass's size
    assert make_solver("ppo", 7, extra_fallbacks=0.5).inner(7, None).fallbacks == (0.0, 0.5)


@pytest.mark.parametrize("bad", [(1.5,), (-0.1,), ("x",), (None,), "0.5", True])
def test_bad_values_are_refused(bad):
    with pytest.raises((ValueError, TypeError), match="extra_fallbacks"):
        make_solver("ppo", 7, extra_fallbacks=bad).inner(7, None)


def test_a_model_blind_to_greedys_choice_refuses_them(blind_model):
    with pytest.raises(ValueError, match="extra_fallbacks=0.5: the model .* does not see"):
        PPOSolver(str(blind_model), n_max=7, extra_fallbacks=(0.5,))
    assert PPOSolver(str(blind_model), n_max=7, extra_fallbacks=(0.0,)).fallbacks == (0.0,)


def test_only_ppo_takes_them():
    with pytest.raises(TypeError, match="extra_fallbacks"):
        make_solver("ppo-guided", 7, extra_fallbacks=(0.0,))


@pytest.mark.parametrize(
    "option, message",
    [
        ("extra_fallbacks=0,2", "extra_fallbacks must be <= 1"),
        ("extra_fallbacks=0,x", "extra_fallbacks takes"),
    ],
)
def test_the_command_line_refuses_bad_values_in_one_line(option, message, capsys):
    code = main(["solve", "--task", "example:planted_seed1", "--method", "ppo", "--option",
                 option])  # fmt: skip
    err = capsys.readouterr().err.strip()
    assert code == 2 and "\n" not in err and message in err and "Traceback" not in err
