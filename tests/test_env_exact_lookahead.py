"""The exact lookahead (``lookahead="exact"``): per action, the child's exact satisfied share,
its clipped mean margin and greedy's choice. Checked against plain references: the greedy
search itself, a step to each child, and the HiGHS LP's margins."""

from __future__ import annotations

import numpy as np
import pytest

from modquad_gym.envs.assembly import ModQuadAssemblyEnv
from modquad_gym.envs.assembly.exact import CLIP_GAMMA
from modquad_gym.envs.assembly.features import CANDIDATE_FEATURES, lookahead_width
from modquad_gym.geometry.structure import Structure
from modquad_gym.oracle import margin
from modquad_gym.oracle.kernels import GAP
from modquad_gym.policy.policy import lookahead_of
from modquad_gym.search.baselines import greedy_search
from modquad_gym.tasks import PlantedTasks, make_generator

ACCURACY = CLIP_GAMMA * GAP
"""The exact margins' documented accuracy: a walked gamma is taken only where its two bounds
(the allocation's above, the direction's below) agree to the relative gap GAP, and the margins
clip gamma at CLIP_GAMMA."""
WIDTH = lookahead_width("exact")
SHARE, MARGIN, GREEDY = CANDIDATE_FEATURES, CANDIDATE_FEATURES + 1, CANDIDATE_FEATURES + 2


def rows_of(obs) -> np.ndarray:
    return obs["candidates"].reshape(-1, WIDTH)


def follow_greedy_flag(env: ModQuadAssemblyEnv, task, seed: int = 0) -> dict:
    """Play the episode that always takes the flagged action; the last info."""
    obs, info = env.reset(seed=seed, options={"task": task})
    done = info["success"]
    while not done:
        flagged = np.flatnonzero(rows_of(obs)[:, GREEDY])
        assert len(flagged) == 1 and obs["action_mask"][flagged[0]]
        obs, _, terminated, truncated, info = env.step(int(flagged[0]))
        done = terminated or truncated
    return info


def same_answer(info: dict, result) -> bool:
    if result.structure is None:
        return not info["success"]
    return info["success"] and Structure(info["cells"]) == result.structure


@pytest.mark.parametrize("source", ["mixed", "planted"])
def test_following_the_flag_builds_what_the_greedy_search_builds(source):
    generate, rng = make_generator(source), np.random.default_rng(11)
    env = ModQuadAssemblyEnv(tasks=source, n_max=6, lookahead="exact")
    for i in range(12):
        task = generate(rng)
        assert same_answer(follow_greedy_flag(env, task, i), greedy_search(task, n_max=6))


def test_greedy_completes_a_prefix_of_its_own_episode_to_its_answer():
    # greedy_search(start=): the completion expert iteration labels a learner's states by
    rng = np.random.default_rng(5)
    task = PlantedTasks(n_modules=(4, 5), n_wrenches=(6, 10))(rng)
    env = ModQuadAssemblyEnv(tasks=[task], n_max=7, lookahead="exact")
    whole = greedy_search(task, n_max=7)
    assert whole.n_modules > 3  # the prefix of two dockings is not the answer
    obs, info = env.reset(seed=0, options={"task": task})
    for _ in range(2):
        obs, *_, info = env.step(int(np.flatnonzero(rows_of(obs)[:, GREEDY])[0]))
    prefix = Structure(info["cells"])
    assert greedy_search(task, n_max=7, start=prefix).structure == whole.structure
    odd = Structure([(0, 0), (0, 1), (0, 2)])  # not greedy's: its completion contains it
    done = greedy_search(task, n_max=7, start=odd)
    assert done.structure is None or {(0, 0), (0, 1), (0, 2)} <= set(done.structure.cells)
    as_cells = greedy_search(task, n_max=7, start=[(0, 0), (0, 1), (0, 2)])
    assert as_cells.structure == done.structure
    with pytest.raises(ValueError, match="start"):  # not connected
        greedy_search(task, n_max=7, start=[(0, 0), (0, 2)])


def test_the_flag_follows_greedy_on_dynamic_tasks_and_under_a_rotor_fault():
    rng = np.random.default_rng(3)
    motions = make_generator("motions")
    env = ModQuadAssemblyEnv(tasks="motions", n_max=5, lookahead="exact")
    for i in range(3):
        task = motions(rng)
        assert same_answer(follow_greedy_flag(env, task, i), greedy_search(task, n_max=5))
    planted = PlantedTasks(n_modules=(2, 3), n_wrenches=(3, 6))
    env = ModQuadAssemblyEnv(tasks=planted, n_max=5, lookahead="exact", fault="rotor")
    for i in range(3):
        task = planted(rng)
        result = greedy_search(task, n_max=5, fault="rotor")
        assert same_answer(follow_greedy_flag(env, task, i), result)


def test_each_share_is_what_the_step_reports_and_each_margin_the_lps():
    task = PlantedTasks(n_modules=(4, 5), n_wrenches=(8, 12))(np.random.default_rng(2))
    env = ModQuadAssemblyEnv(tasks=[task], n_max=6, lookahead="exact")
    obs, _ = env.reset(seed=0)
    obs, *_ = env.step(env.action_of((1, 0)))
    state, rows = env.state, rows_of(obs).copy()
    W = np.asarray(task.wrenches)
    for a in np.flatnonzero(obs["action_mask"]):
        child = Structure([(0, 0), (1, 0), env.cell_of(int(a))])
        reference = np.clip(margin(child.configuration_matrix(), W, task.f_max, "scipy"), -1, 1)
        np.testing.assert_allclose(rows[a, MARGIN], reference.mean(), atol=1e-6)
        _, _, _, _, info = env.step(int(a))
        assert rows[a, SHARE] == np.float32(info["satisfied_fraction"])
        env.restore(state)
    assert np.all(rows[obs["action_mask"] == 0] == 0.0)


def test_near_the_boundary_and_rank_deficient_children_keep_their_meaning():
    # a one-row structure is rank deficient (no torque about its axis): wrenches off its range
    # have margin -inf, clipped to -1; a wrench on the boundary of a child has margin ~0
    lift = Structure([(0, 0), (1, 0)]).configuration_matrix().sum(axis=1) * 2.0  # all rotors
    off_range = np.array([0.0, 0.0, 5.0, 0.0, 0.0, 3.0])
    from modquad_gym.tasks import TaskRequirement

    task = TaskRequirement(np.array([lift, off_range]), f_max=2.0, name="edge")
    env = ModQuadAssemblyEnv(tasks=[task], n_max=3, lookahead="exact")
    obs, _ = env.reset(seed=0)
    rows = rows_of(obs)
    a = env.action_of((1, 0))
    reference = np.clip(margin(Structure([(0, 0), (1, 0)]).configuration_matrix(),
                               task.wrenches, 2.0, "scipy"), -1, 1)  # fmt: skip
    np.testing.assert_allclose(rows[a, MARGIN], reference.mean(), atol=1e-6)
    assert rows[a, SHARE] == np.float32(np.mean(reference >= 0))


def test_exact_rows_count_their_oracle_tests_and_replay_the_same():
    env = ModQuadAssemblyEnv(tasks="mixed", n_max=5, lookahead="exact")
    plain = ModQuadAssemblyEnv(tasks="mixed", n_max=5)
    _, with_rows = env.reset(seed=4)
    _, without = plain.reset(seed=4)
    assert with_rows["oracle_calls"] > without["oracle_calls"]
    again = ModQuadAssemblyEnv(tasks="mixed", n_max=5, lookahead="exact")
    first, second = env.reset(seed=9)[0], again.reset(seed=9)[0]
    np.testing.assert_array_equal(first["candidates"], second["candidates"])
    assert env.observation_space.contains(first)


def test_the_exact_width_is_read_back_from_the_space_and_bad_values_refused():
    exact = ModQuadAssemblyEnv(tasks="mixed", n_max=4, lookahead="exact")
    assert exact.observation_space["candidates"].shape == (49 * WIDTH,)
    assert lookahead_of(exact.observation_space) == "exact"
    assert lookahead_of(ModQuadAssemblyEnv(n_max=4, lookahead=True).observation_space) is True
    assert lookahead_of(ModQuadAssemblyEnv(n_max=4).observation_space) is False
    faces = ModQuadAssemblyEnv(n_max=4, lookahead="exact", actions="faces")
    obs, _ = faces.reset(seed=0)
    assert faces.observation_space.contains(obs)
    for bad in ("yes", 1, None, "support"):
        with pytest.raises(ValueError, match="lookahead must be False, True or 'exact'"):
            ModQuadAssemblyEnv(lookahead=bad)


def test_the_candidate_policy_acts_on_exact_rows():
    torch = pytest.importorskip("torch")
    from sb3_contrib import MaskablePPO

    from modquad_gym.policy.network import CandidatePolicy

    env = ModQuadAssemblyEnv(tasks="planted", n_max=4, lookahead="exact")
    model = MaskablePPO(CandidatePolicy, env, seed=0, n_steps=32, batch_size=16)
    obs, _ = env.reset(seed=0)
    action, _ = model.predict(obs, action_masks=env.action_masks(), deterministic=True)
    assert env.action_masks()[int(action)]
    assert model.policy.features_extractor.width == WIDTH
    assert torch.is_tensor(next(model.policy.parameters()))


def test_a_full_support_cache_is_refilled_for_every_key_asked(monkeypatch):
    """When the support cache overflows it is cleared: keys cached before must be computed
    again in the same call (a long guided search at 36 modules raised KeyError here), with the
    same rows."""
    import modquad_gym.envs.assembly.evaluator as evaluator

    env = ModQuadAssemblyEnv(n_max=8, lookahead=True)
    env.reset(seed=0)
    ev = env.evaluator
    ev.supports.clear()
    keys = [Structure(cells).key for cells in ([(0, 0), (1, 0)], [(0, 0), (0, 1)])]
    first = ev.supports_of(keys[:1])
    assert len(ev.supports) == 1
    monkeypatch.setattr(evaluator, "CACHE_SIZE", 1)
    h, slack = ev.supports_of(keys)  # the new key overflows: the cache is cleared
    np.testing.assert_array_equal(h[0], first[0][0])
    assert set(keys) <= set(ev.supports)


def reference_rows(ev, keys, task, mass) -> list[tuple[float, float]]:
    """The exact rows as first built: every child decided by the certified screened oracle
    (:meth:`evaluate`, a fresh memo) and every wrench's gamma by the compiled walk to its
    optimum (no cap)."""
    from modquad_gym.oracle.backends import gamma_with
    from modquad_gym.oracle.tolerance import margin_from_gamma

    out = []
    for k in keys:
        own = ev.task_of(task, k)
        n_sat, _, _ = ev.evaluate(k, own, mass, {})
        W = ev.at_mass(own, mass)[0]
        gamma = gamma_with(ev.oracle.zonotope(ev.capability_of(k).A, key=k), W, "compiled")
        out.append((n_sat / len(W), float(np.clip(margin_from_gamma(gamma), -1, 1).mean())))
    return out


@pytest.mark.parametrize(
    "source, kwargs",
    [
        ("mixed", {}),
        ("planted", {}),  # wrenches on the boundary of a hidden structure: gamma ~ 1
        ("planted-mixed-external", {"modules": "t45,t45m,flat"}),  # weight grows per child
        ("motions", {}),  # each child on its own wrenches
        ("planted", {"fault": "rotor"}),
        ("paper", {}),
    ],
)
def test_the_exact_rows_are_those_of_the_plain_reference_on_many_states(
    source, kwargs, monkeypatch
):
    """The capped walk started at the parent's optimal vertices and the shares read off gamma
    give the rows of the plain reference (every child decided, every gamma to its optimum by a
    cold walk): shares equal, margins within ACCURACY (each walk's gamma is certified to it;
    a degenerate optimum may be measured at another of its vertices), on every state of
    random episodes."""
    from modquad_gym.envs.assembly import lookahead

    env = ModQuadAssemblyEnv(tasks=source, n_max=5, lookahead="exact", **kwargs)
    checked, warm = [], []

    def checking(ev, keys, task, mass, memo, exact_memo, walks=None, lines=None):
        got = original(ev, keys, task, mass, memo, exact_memo, walks, lines)
        warm.append(lines is not None and lines[0].start is not None)
        want = reference_rows(ev, keys, task, mass)
        for (share, margin_), (share_ref, margin_ref) in zip(got, want):
            assert share == share_ref
            assert abs(margin_ - margin_ref) <= ACCURACY
        checked.extend(got)
        return got

    rng = np.random.default_rng(7)
    original = lookahead.exact_rows
    monkeypatch.setattr(lookahead, "exact_rows", checking)
    for episode in range(6):
        env.reset(seed=episode)
        done = False
        while not done:
            valid = np.flatnonzero(env.action_masks())
            *_, terminated, truncated, _ = env.step(int(rng.choice(valid)))
            done = terminated or truncated
    assert len(checked) > 30 and any(warm)
    margins = np.array([m for _, m in checked])
    assert (margins > -1).any() and (margins < 1).any()


def test_a_wrench_within_the_band_of_the_threshold_is_decided_as_the_step_decides():
    """A wrench put at gamma = 1 + TOL of a child (where round-off decides) takes its share
    from the certified decision, the one the step to that child reports."""
    from modquad_gym.oracle import Zonotope
    from modquad_gym.oracle.backends import gamma_with
    from modquad_gym.oracle.tolerance import TOL
    from modquad_gym.tasks import TaskRequirement

    child = Structure([(0, 0), (1, 0), (1, 1)])
    A = child.configuration_matrix()
    centre = A.sum(axis=1) / 2.0
    w = centre + np.array([0.3, -0.2, 0.5, 0.05, 0.04, -0.03])
    g = gamma_with(Zonotope(A), w[None], "compiled")[0]
    for gamma in (1.0 + TOL, 1.0 + TOL - 1e-12, 1.0 + TOL + 1e-12):
        edge = centre + (w - centre) * gamma / g
        task = TaskRequirement(np.array([edge, centre]), name="band")
        env = ModQuadAssemblyEnv(tasks=[task], n_max=4, lookahead="exact")
        obs, _ = env.reset(seed=0)
        obs, *_ = env.step(env.action_of((1, 0)))
        state, rows = env.state, rows_of(obs).copy()
        a = env.action_of((1, 1))
        _, _, _, _, info = env.step(a)
        assert rows[a, SHARE] == np.float32(info["satisfied_fraction"])
        env.restore(state)


def test_the_per_structure_caches_are_bounded_by_columns_not_entries(monkeypatch):
    """At 128 modules a structure's matrix and zonotope take ~150 kB: the caches hold 256 of
    them (not 16,384: GBs), while every structure of at most 7 modules still fits at n_max 7."""
    import modquad_gym.envs.assembly.evaluator as evaluator

    small = ModQuadAssemblyEnv(n_max=7, lookahead="exact")
    small.reset(seed=0)
    assert small.evaluator.cache_size >= 1067  # structures of at most 7 modules
    large = ModQuadAssemblyEnv(n_max=128, lookahead="exact", actions="faces")
    large.reset(seed=0)
    assert large.evaluator.cache_size == evaluator.CACHED_COLUMNS // (4 * 128) == 256
    assert large.evaluator.oracle.cache_size == 256
    monkeypatch.setattr(large.evaluator, "cache_size", 3)
    large.evaluator.oracle.cache_size = 3
    for _ in range(3):
        valid = np.flatnonzero(large.action_masks())
        large.step(int(valid[0]))
        assert len(large.evaluator.capability) <= 3
        assert len(large.evaluator.oracle._cache) <= 3


@pytest.mark.parametrize(
    "source, kwargs, n_max",
    [
        ("mixed", {}, 7),
        ("paper", {}, 7),
        ("planted", {}, 7),
        ("planted-mixed-external", {"modules": "t45,t45m,flat"}, 6),
        ("motions", {}, 6),
        (PlantedTasks(n_modules=(10, 16)), {}, 16),
        (PlantedTasks(n_modules=(16, 24)), {}, 24),
    ],
)
def test_what_a_parent_passes_on_leaves_the_shipped_observation_as_it_was(
    source, kwargs, n_max, monkeypatch
):
    """The shipped policy's observation (``"exact"`` with its shortlist) with what each state
    takes from its own exact entries and the shortlist (its children's walks started at its
    optimal vertices or a walked sibling's, the shortlist's directions read off those
    vertices where they are unique optima, the shortlist's supports for its support rows, no
    walk where its bounds prove gamma past the clip) equals the plain path's (every walk from
    the dual-metric direction, every support computed again, every wrench walked, every
    child's zonotope from the SVD), state by state on random episodes: masks and the flag on
    greedy's choice identical, every entry within float32 round-off; and each shortcut was
    taken (the whitened zonotopes from 16 modules)."""
    from modquad_gym.envs.assembly import exact, lookahead, transitions
    from modquad_gym.envs.assembly.evaluator import StructureEvaluator
    from modquad_gym.oracle import WrenchOracle, vertices
    from modquad_gym.oracle.whitened import WhitenedZonotope

    def episodes(env) -> list:
        rng, out = np.random.default_rng(3), []
        for episode in range(4):
            obs, _ = env.reset(seed=episode)
            done = False
            while not done:
                out.append(obs)
                valid = np.flatnonzero(obs["action_mask"])
                obs, _, terminated, truncated, _ = env.step(int(rng.choice(valid)))
                done = terminated or truncated
        return out

    taken = {"start": 0, "proved": 0, "supports": 0, "read": 0, "sibling": 0, "whitened": 0}
    walk, rows, sibling = (
        exact.gamma_capped_from,
        StructureEvaluator.candidate_rows,
        exact.from_sibling,
    )
    read, prepared = vertices.vertex_directions, WrenchOracle.gamma_zonotope

    def counting_zonotope(oracle, A, key):
        z = prepared(oracle, A, key)
        taken["whitened"] += isinstance(z, WhitenedZonotope)
        return z

    def counting_walk(z, W, cap, start=None, lower=None):
        taken["start"] += start is not None
        taken["proved"] += 0 if lower is None else int(exact.proved_above(lower, cap).sum())
        return walk(z, W, cap, start, lower)

    def counting_rows(ev, keys, task, mass, memo, supports=None):
        taken["supports"] += supports is not None
        return rows(ev, keys, task, mass, memo, supports)

    def counting_read(G, R, starts, signs, cap, dirs, found):
        read(G, R, starts, signs, cap, dirs, found)
        taken["read"] += int(found.sum())

    def counting_sibling(start, line, walked, r):
        got = sibling(start, line, walked, r)
        taken["sibling"] += int((got[0] != start[0]).any(axis=1).sum())
        return got

    monkeypatch.setattr(exact, "gamma_capped_from", counting_walk)
    monkeypatch.setattr(exact, "from_sibling", counting_sibling)
    monkeypatch.setattr(vertices, "vertex_directions", counting_read)
    monkeypatch.setattr(StructureEvaluator, "candidate_rows", counting_rows)
    monkeypatch.setattr(WrenchOracle, "gamma_zonotope", counting_zonotope)
    make = dict(tasks=source, n_max=n_max, lookahead="exact", lookahead_top_k=8, **kwargs)
    fast = episodes(ModQuadAssemblyEnv(**make))
    assert taken["start"] and taken["supports"] and taken["sibling"]
    assert taken["read"] or source == "motions"  # a dynamic task ranks by supports alone
    shortlist = transitions.shortlisted  # the plain path: nothing passed on
    monkeypatch.setattr(transitions, "shortlisted", lambda ep, state: (shortlist(ep, state)[0], {}))
    monkeypatch.setattr(lookahead, "inherited", lambda ep, state: None)
    monkeypatch.setattr(WrenchOracle, "gamma_zonotope", WrenchOracle.zonotope)
    plain = episodes(ModQuadAssemblyEnv(**make))
    assert len(fast) == len(plain) > 8
    for got, want in zip(fast, plain):
        assert got.keys() == want.keys()
        np.testing.assert_array_equal(got["action_mask"], want["action_mask"])
        rows = got["candidates"].reshape(len(got["action_mask"]), -1)
        np.testing.assert_array_equal(rows[:, -1], want["candidates"].reshape(rows.shape)[:, -1])
        for name in got:
            np.testing.assert_allclose(got[name], want[name], rtol=1e-6, atol=1e-7)
    assert taken["proved"] or n_max < 16  # wrenches proved past the clip: larger structures
    assert taken["whitened"] or n_max <= 16  # children of 17 modules and more


@pytest.mark.parametrize("source", ["planted", "paper", "motions"])
def test_a_docked_child_is_decided_as_without_the_lookahead(source):
    """A step to a child whose exact entry the lookahead holds takes its satisfied count from
    that entry (no second decision): the same count, success and structure vector as an env
    without the lookahead (the screened oracle) reports after the same actions."""
    exact = ModQuadAssemblyEnv(tasks=source, n_max=8, lookahead="exact", lookahead_top_k=4)
    plain = ModQuadAssemblyEnv(tasks=source, n_max=8)
    rng = np.random.default_rng(5)
    steps = 0
    for episode in range(4):
        (obs, _), (want, _) = exact.reset(seed=episode), plain.reset(seed=episode)
        done = False
        while not done:
            action = int(rng.choice(np.flatnonzero(obs["action_mask"])))
            obs, _, terminated, truncated, info = exact.step(action)
            want, _, _, _, want_info = plain.step(action)
            assert info["satisfied_fraction"] == want_info["satisfied_fraction"]
            assert info["success"] == want_info["success"]
            np.testing.assert_array_equal(obs["structure"], want["structure"])
            done, steps = terminated or truncated, steps + 1
    assert steps > 12
