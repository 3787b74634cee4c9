"""``ppo-guided``'s budget: 64 structures below 16 modules; from 16, BUDGET_PER_MODULE per
module of its dive's answer (its time grows with the structure as beam's does)."""

from __future__ import annotations

import pytest

from modquad_gym.policy.guided import nbytes
from modquad_gym.policy.models import (
    BUDGET_PER_MODULE,
    GUIDED_BUDGET,
    QUEUE_MEMORY,
    SCALE_FROM,
    SMALL_EXTRA_FALLBACKS,
)
from modquad_gym.scoring.scale_tasks import draw
from modquad_gym.search import verified
from modquad_gym.solvers import make_solver


def test_the_default_budget_per_size_and_a_given_one_everywhere():
    small, scale = make_solver("ppo-guided", n_max=7), make_solver("ppo-guided", n_max=64)
    assert small.budget is None and scale.budget is None
    assert small.budget_for(5) == GUIDED_BUDGET
    assert scale.budget_for(2) == GUIDED_BUDGET  # never below it
    assert scale.budget_for(30) == BUDGET_PER_MODULE * 30
    assert SCALE_FROM <= 64
    for n_max in (7, 64):
        assert make_solver("ppo-guided", n_max=n_max, budget=100).budget_for(30) == 100


def test_the_default_budget_keeps_its_queued_states_within_queue_memory():
    """As many states as fit in QUEUE_MEMORY at most (never below 64); a given budget is the
    user's and is kept; a state's bytes are its arrays' (at n_max 64: the grid's masks)."""
    scale = make_solver("ppo-guided", n_max=64)
    assert scale.budget_for(30, 1) == BUDGET_PER_MODULE * 30
    assert scale.budget_for(100, QUEUE_MEMORY // 150) == 150
    assert scale.budget_for(30, QUEUE_MEMORY) == GUIDED_BUDGET
    assert make_solver("ppo-guided", n_max=64, budget=999).budget_for(30, QUEUE_MEMORY) == 999
    env = scale.policy.env
    scale.policy.reset(draw("planted", 16, 0, validation=True), scale.policy.starts[0])
    state = env.state
    assert nbytes(state) >= state.mask.nbytes + state.occupancy.nbytes >= 2 * 127 * 127


@pytest.mark.parametrize("index", [0, 1])
def test_a_scale_search_evaluates_up_to_its_dives_budget_and_never_ends_above_64s(index):
    """On validation draws of the low-force, high-torque family at 16 modules (where the
    search does not stop at a lower bound at once): the search evaluates more than 64
    structures and at most the budget of its dive's answer (the single pass: the dive is that
    episode), and ends with no more modules than with 64 (the same best-first order, cut
    later)."""
    task = draw("torque", 16, index, validation=True)
    dive = make_solver("ppo", n_max=64).solve(task)
    default = make_solver("ppo-guided", n_max=64).solve(task)
    b64 = make_solver("ppo-guided", n_max=64, budget=GUIDED_BUDGET).solve(task)
    assert dive.structure is not None and verified(default.structure, task)
    assert GUIDED_BUDGET < default.evaluated <= BUDGET_PER_MODULE * dive.n_modules
    assert b64.evaluated <= GUIDED_BUDGET
    assert default.n_modules <= b64.n_modules <= dive.n_modules


def test_without_a_dive_the_queue_memory_bounds_the_search_too(monkeypatch):
    """``-nodive``: the budget is that of n_max, still within QUEUE_MEMORY (here made to hold
    100 states): the search evaluates at most 100 structures."""
    import modquad_gym.policy.guided as guided

    solver = make_solver("ppo-guided-nodive", n_max=64)
    task = draw("torque", 16, 0, validation=True)
    solver.policy.reset(task, solver.policy.starts[0])
    monkeypatch.setattr(guided, "QUEUE_MEMORY", 100 * nbytes(solver.policy.env.state))
    result = solver.solve(task)
    assert GUIDED_BUDGET < result.evaluated <= 100


def test_from_scale_from_it_dives_from_each_start_type_as_the_single_pass_decodes():
    """With a budget of one structure the dives are the single pass: one tree of episodes per
    start type, with the extra fallbacks' branches."""
    from modquad_gym.scoring.scale_tasks import task_palette

    for band, i in ((16, 0), (32, 1)):
        task = draw("mixed", band, i, validation=True)
        palette = task_palette(task)
        single = make_solver("ppo", 64, modules=palette).solve(task)
        dives = make_solver("ppo-guided", 64, modules=palette, budget=1).solve(task)
        assert dives.n_modules == single.n_modules  # budget 1: the dives alone
        assert dives.evaluated == single.evaluated  # the same episodes and their branches
        search = make_solver("ppo-guided", 64, modules=palette).solve(task)
        assert search.n_modules <= single.n_modules


def test_below_scale_from_it_dives_from_the_first_start_type_only():
    """Below 16 modules the dive is the policy's own pass from the first start type; ``ppo``'s
    passes from every start type close the search where it ends uncertified, so that with a
    palette too it never ends above ``ppo`` (which decodes from every start type)."""
    from modquad_gym.geometry.module import palette
    from modquad_gym.policy.guided import Run
    from modquad_gym.policy.policy import Policy
    from modquad_gym.scoring.suites import draw_task
    from modquad_gym.search.bounds import bound_levels
    from modquad_gym.tasks import make_generator

    types = palette("t45,t45m,flat")
    policy = Policy(None, n_max=7, top_k=8)
    policy.use_palette(types)
    ppo = make_solver("ppo", 7, modules=types)
    guided = make_solver("ppo-guided", 7, modules=types, budget=1)
    inner = guided.inner(7, types)
    for seed in (9400, 9401, 9419, 9440):  # 9419, 9440: ppo's answer starts with another type
        task = draw_task(make_generator("mixed"), seed)
        first: set = set()
        policy.rollout(task, seen=first, start=policy.starts[0])
        problem = inner.policy.problem(task)
        run = Run(inner, problem, bound_levels(problem), float("inf"))
        run.dive()
        assert run.evaluated == first
        mine, theirs = guided.solve(task), ppo.solve(task)
        assert mine.n_modules <= theirs.n_modules


def test_below_scale_from_ppos_extra_passes_close_the_search_not_open_it():
    """Below 16 modules the dive is the policy's own pass and ``ppo``'s other passes run last,
    where the search ends uncertified: in the dive their structures took the 64-structure
    budget's place, and the fault tier's fault-8000000 ended at 9 modules (optimum 8)."""
    from modquad_gym.policy.models import MODELS_DIR
    from modquad_gym.scoring.tiers import TIERS

    tier = TIERS["fault"]
    model = str(MODELS_DIR / "ppo_fault" / "model.zip")
    guided = make_solver("ppo-guided", tier.n_max, model=model, fault="rotor").inner(
        tier.n_max, None, fault=("rotor", 0.0)
    )
    assert guided.single.fallbacks == (guided.fallback,)
    assert guided.closing.fallbacks == (guided.fallback, *SMALL_EXTRA_FALLBACKS)
    (task,) = [t for ts in tier.load_suites().values() for t in ts if t.name == "fault-8000000"]
    result = guided.solve(task)
    assert result.n_modules == task.meta["optimum"] == 8 and result.evaluated > GUIDED_BUDGET
