"""The exact lookahead's shortlist (``lookahead_top_k``): with k at least the number of valid
actions the observation is today's exactly; the support bounds never fall below the exact share
and margin (the plain references: the exact rows, themselves checked against HiGHS); the other
actions leave the action set and come back after the next docking."""

from __future__ import annotations

import numpy as np
import pytest

from modquad_gym.envs.assembly import ModQuadAssemblyEnv
from modquad_gym.envs.assembly.bounds import (
    FLAT,
    margin_bound,
    ratios,
    ray_bounds,
    support_bounds,
)
from modquad_gym.envs.assembly.exact import exact_rows
from modquad_gym.envs.assembly.lookahead import (
    GREEDY,
    MARGIN,
    SHARE,
    child_bounds,
    child_keys,
    children,
    greedy_choice,
    parent_directions,
    ranked,
)
from modquad_gym.geometry.structure import Structure
from modquad_gym.oracle import margin
from modquad_gym.tasks import TaskRequirement

WIDTH = 8


@pytest.mark.parametrize(
    "kwargs",
    [
        {"tasks": "mixed"},
        {"tasks": "planted-mixed-external", "modules": "t45,t45m,flat"},
        {"tasks": "mixed", "actions": "faces"},
    ],
)
def test_a_shortlist_as_long_as_the_valid_actions_changes_nothing(kwargs):
    full = ModQuadAssemblyEnv(n_max=5, lookahead="exact", **kwargs)
    long = ModQuadAssemblyEnv(n_max=5, lookahead="exact", lookahead_top_k=10**6, **kwargs)
    rng = np.random.default_rng(0)
    for episode in range(4):
        a, b = full.reset(seed=episode), long.reset(seed=episode)
        done = False
        while not done:
            for key in a[0]:
                np.testing.assert_array_equal(a[0][key], b[0][key])
            assert a[-1]["oracle_calls"] == b[-1]["oracle_calls"]
            action = int(rng.choice(np.flatnonzero(a[0]["action_mask"])))
            a, b = full.step(action), long.step(action)
            done = a[2] or a[3]
        assert a[-1]["cells"] == b[-1]["cells"]


@pytest.mark.parametrize(
    "source, kwargs",
    [
        ("mixed", {}),
        ("planted", {}),  # wrenches near the boundary of a hidden structure
        ("planted-mixed-external", {"modules": "t45,t45m,flat"}),  # weight grows per child
        ("motions", {}),  # each child on its own wrenches
        ("planted", {"fault": "rotor"}),
    ],
)
def test_the_bounds_never_fall_below_the_exact_share_and_margin(source, kwargs):
    env = ModQuadAssemblyEnv(tasks=source, n_max=5, lookahead="exact", **kwargs)
    checked = 0
    rng = np.random.default_rng(3)
    for episode in range(5):
        env.reset(seed=episode)
        done = False
        while not done:
            ep, state = env.unwrapped._episode, env.state
            valid = np.flatnonzero(state.mask)
            rays = None if state.task.per_structure else parent_directions(ep, state)
            for _acts, cells, k, mass in children(ep, state, valid):
                bounds = child_bounds(ep, state, cells, k, mass, rays)
                share, mean_margin = bounds.share, margin_bound(bounds.gamma)
                keys = child_keys(ep, state, cells, k)
                exact = exact_rows(env.evaluator, keys, state.task, mass, ep.memo, ep.exact_memo)
                for s, m, (s_exact, m_exact) in zip(share, mean_margin, exact):
                    assert s >= s_exact and m >= m_exact - 1e-9
                    checked += 1
            *_, terminated, truncated, _ = env.step(int(rng.choice(valid)))
            done = terminated or truncated
    assert checked > 40


def test_the_margin_bounds_hold_against_highs_on_the_boundary_and_rank_deficient_lines():
    """Per wrench, on a straight line (rank 5: wrenches off its range), an L (rank 6), on the
    boundary (gamma = 1), at the centre and deep inside or outside: each gamma bound (feature
    directions, a parent's dual-metric directions, random ones) is at most the LP's, so the
    margin bound is at least the LP's clipped margin."""
    env = ModQuadAssemblyEnv(n_max=4, lookahead="exact")
    env.reset(seed=0)
    ev = env.evaluator
    rng = np.random.default_rng(1)
    signs = set()
    for cells in (((0, 0), (1, 0), (2, 0)), ((0, 0), (1, 0), (1, 1))):
        A = Structure(cells).configuration_matrix()
        centre = A.sum(axis=1) / 2.0
        u = rng.uniform(0, 1, (6, A.shape[1]))
        u[0] = np.round(u[0])  # a vertex: on the boundary
        W = np.vstack([u @ A.T, centre, [0.0, 0.0, 3.0, 0.0, 0.0, 2.0], centre * 1.5])
        task = ev.task_arrays(TaskRequirement(W, name="edges"))
        h, slack, c = ev.supports_of([Structure(cells).key], centres=True)
        reference = np.clip(margin(A, W, 1.0, "scipy"), -1.0, 1.0)
        share, gamma = support_bounds(h, slack, c, task.WD)
        assert share[0] >= np.mean(reference >= 0)
        for parent in (cells[:1], cells[:2], cells):  # the dual-metric direction of a parent
            P = Structure(parent).configuration_matrix()
            D = (W - P.sum(axis=1) / 2.0) @ np.linalg.pinv(P @ P.T, 1e-10, True)
            gamma = np.maximum(gamma, ray_bounds(A[None], D, W, 1.0))
        for _ in range(20):  # any direction bounds gamma from below
            D = rng.standard_normal(W.shape) * rng.integers(0, 2, (len(W), 1))
            gamma = np.maximum(gamma, ray_bounds(A[None], D, W, 1.0))
        assert np.all(np.clip(1.0 - gamma[0], -1, 1) >= reference - 1e-7)
        signs |= set(np.sign(reference).tolist())
    assert {-1.0, 1.0} <= signs


def test_the_compiled_support_bounds_are_numpys_bit_for_bit():
    """:func:`support_bounds` (one compiled pass) gives exactly the numpy formula of its
    docstring: deficits against the slack, and ratios of offsets to widths with flat widths
    (zero, or below FLAT) and offsets on both sides of FLAT, on children of a real task."""
    env = ModQuadAssemblyEnv(tasks="mixed", n_max=16, lookahead="exact")
    env.reset(seed=4)
    for _ in range(5):
        env.step(int(np.flatnonzero(env.action_masks())[0]))
    ev, state = env.evaluator, env.state
    keys = [env.module_set.key((*state.cells, c), ()) for c in ((-1, 0), (0, -1), (9, 9))]
    h, slack, c = ev.supports_of(keys, centres=True)
    WD = state.task.WD
    h[0, :5], c[0, :5] = c[0, :5], c[0, :5] + FLAT / 2  # flat directions: width 0 and FLAT / 2
    WD = np.vstack([WD, c[0] + FLAT / 4, c[0] + 2 * FLAT])  # offsets below and above FLAT
    share, gamma = support_bounds(h, slack, c, WD)
    deficit = (WD[None] - h[:, None]).max(axis=2)
    want_share = np.count_nonzero(deficit <= slack[:, None], axis=1) / len(WD)
    want_gamma = ratios(np.abs(WD[None] - c[:, None]), h[:, None] - c[:, None], FLAT).max(axis=2)
    np.testing.assert_array_equal(share, want_share)
    np.testing.assert_array_equal(gamma, want_gamma)
    assert np.isinf(gamma[0]).any() and (gamma[1:] > 0).all()


def test_the_shortlist_keeps_the_k_best_and_its_rows_are_the_full_ones():
    full = ModQuadAssemblyEnv(tasks="mixed", n_max=6, lookahead="exact")
    short = ModQuadAssemblyEnv(tasks="mixed", n_max=6, lookahead="exact", lookahead_top_k=3)
    rng = np.random.default_rng(2)
    cut = 0
    for episode in range(5):
        (a, _), (b, _) = full.reset(seed=episode), short.reset(seed=episode)
        done = False
        while not done:
            valid, kept = np.flatnonzero(a["action_mask"]), np.flatnonzero(b["action_mask"])
            assert len(kept) == min(3, len(valid)) and set(kept) <= set(valid)
            state = short.state
            assert state.free is None or np.array_equal(state.free, a["action_mask"])
            ep = short.unwrapped._episode
            assert list(ranked(ep, state, valid)[:3]) == sorted(kept, key=list(
                ranked(ep, state, valid)).index)  # fmt: skip
            rows_a, rows_b = a["candidates"].reshape(-1, WIDTH), b["candidates"].reshape(-1, WIDTH)
            np.testing.assert_array_equal(rows_a[kept, :GREEDY], rows_b[kept, :GREEDY])
            assert not rows_b[b["action_mask"] == 0].any()
            scores = {int(x): tuple(rows_b[x, SHARE : MARGIN + 1]) for x in kept}
            cells = {int(x): short.cell_of(int(x)) for x in kept}
            assert rows_b[greedy_choice(scores, cells, short.encoding), GREEDY] == 1.0
            outside = sorted(set(valid) - set(kept))
            if outside:  # an action off the shortlist is invalid: nothing docks, it costs
                cut += 1
                before = short.state
                _, reward, _, _, info = short.step(int(outside[0]))
                assert info["invalid_action"] and info["cells"] == [list(c) for c in before.cells]
                assert reward < 0
                short.restore(before)
            action = int(rng.choice(kept))
            (a, _, done, trunc, _), (b, *_) = full.step(action), short.step(action)
            done = done or trunc
    assert cut > 5


def test_bad_shortlists_are_refused_with_the_option_named():
    for bad in (0, -2, 2.0, "3", True):
        with pytest.raises(ValueError, match="lookahead_top_k"):
            ModQuadAssemblyEnv(lookahead="exact", lookahead_top_k=bad)
    for lookahead in (False, True):
        with pytest.raises(ValueError, match="lookahead_top_k=4 .*lookahead='exact'"):
            ModQuadAssemblyEnv(lookahead=lookahead, lookahead_top_k=4)


def test_the_learned_solvers_act_on_the_shortlist_unless_told_otherwise():
    """The solvers default to the shortlist; a bare Policy (training, expert labels) does not."""
    pytest.importorskip("sb3_contrib")
    from modquad_gym.policy.models import TOP_K
    from modquad_gym.policy.policy import Policy
    from modquad_gym.solvers import make_solver

    assert Policy(n_max=7).env.rules.top_k is None  # training and labelling: every child

    ppo = make_solver("ppo", n_max=7)
    assert ppo.policy.env.rules.top_k == TOP_K
    every = make_solver("ppo", n_max=7, top_k=None)
    assert every.policy.env.rules.top_k is None
    guided = make_solver("ppo-guided", n_max=7, top_k=2)
    assert guided.policy.env.rules.top_k == 2
    with pytest.raises(ValueError, match="top_k"):
        make_solver("ppo", n_max=7, top_k=0)
    task = TaskRequirement([[0.0, 0.0, 6.0, 0.1, 0.0, 0.0]], name="lift")
    for solver in (ppo, every, guided):
        assert solver.solve(task).n_modules is not None
