"""Heterogeneous modules (issue 15): palette, mixed structures, task kinds, typed searches, the
mixed environment and MuJoCo. Every fast path is checked against a plain reference."""

from __future__ import annotations

import itertools
import json
import math

import gymnasium as gym
import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import modquad_gym as mq
from modquad_gym.cli import main
from modquad_gym.geometry.module import DEFAULT_MASS, GRAVITY, STOCK_TYPES, ModuleType, palette
from modquad_gym.geometry.structure import mixed_configuration_matrices, normalise_typed
from modquad_gym.oracle import feasible
from modquad_gym.search.bounds import count_vectors, counts_possible
from modquad_gym.tasks import (
    PaperTasks,
    PlantedTasks,
    TaskFileError,
    TaskRequirement,
    random_cells,
    rotor_wrenches,
)

T45, T45M, FLAT = STOCK_TYPES["t45"], STOCK_TYPES["t45m"], STOCK_TYPES["flat"]
HEAVY = ModuleType.from_tilts((0.3, -0.3, 0.3, -0.3), name="heavy", mass=0.5)


def plain_matrix(cells, modules):
    """Eq. (1) column by column: rotor k of module i at p = c_i - COM + p_k, torque p x d plus
    the spin-signed drag; the COM is the mass-weighted mean of the module centres."""
    masses = np.array([m.mass for m in modules])
    centres = np.array([[x, y, 0.0] for x, y in cells]) * modules[0].side
    com = (masses[:, None] * centres).sum(axis=0) / masses.sum()
    cols = []
    for c, m in zip(centres, modules):
        for p, d, s in zip(m.positions, m.directions, m.spins):
            r = c - com + p
            cols.append(np.concatenate([d, np.cross(r, d) + s * m.c_tau * d]))
    return np.array(cols).T


def random_mixed(rng, n, types):
    cells = random_cells(rng, n)
    mods = [types[int(rng.integers(len(types)))] for _ in cells]
    return mq.Structure(cells, modules=mods)


def planted_mixed(rng, structure, t=8, kind="total", f_max=1.0, slack=0.02):
    """Wrenches strictly inside a structure's feasible set (for its own mass)."""
    A = structure.configuration_matrix()
    U = rng.uniform(slack, 1 - slack, size=(t, A.shape[1])) * f_max
    W = U @ A.T
    if kind == "external":
        W[:, 2] -= structure.mass * GRAVITY
    return TaskRequirement(W, f_max=f_max, kind=kind)


# --- palette and module mass ----------------------------------------------------------------
def test_palette_names_mass_and_digest():
    assert [m.name for m in palette("t45,t45m,flat")] == ["t45", "t45m", "flat"]
    assert T45.mass == DEFAULT_MASS == 0.3 and math.isclose(T45.weight, 0.3 * GRAVITY)
    assert np.array_equal(T45.columns, mq.TModule().columns)
    assert T45.digest == mq.TModule().digest and T45.digest != T45M.digest
    assert np.allclose(T45M.directions[:, :2], -T45.directions[:, :2])
    assert np.allclose(FLAT.directions, [[0, 0, 1]] * 4)
    with pytest.raises(ValueError, match="unknown module type 'nope'"):
        palette("t45,nope")
    with pytest.raises(ValueError, match="listed twice"):
        palette(["t45", "t45"])
    with pytest.raises(ValueError, match="mass"):
        ModuleType.from_tilts((0, 0, 0, 0), mass=0.0)
    for m in STOCK_TYPES.values():  # every stock type is torque-balanced about its centre
        assert np.allclose(m.columns[3:].sum(axis=1), 0.0, atol=1e-12)


# --- mixed structures -----------------------------------------------------------------------
def test_mixed_matrix_column_by_column_against_a_plain_loop():
    rng = np.random.default_rng(0)
    types = [T45, T45M, FLAT, HEAVY]
    for _ in range(40):
        s = random_mixed(rng, int(rng.integers(1, 8)), types)
        A = s.configuration_matrix()
        assert A.shape == (6, 4 * s.n_modules)
        np.testing.assert_allclose(A, plain_matrix(s.cells, s.modules), rtol=0, atol=1e-14)
        masses = np.array([m.mass for m in s.modules])
        com = masses @ np.asarray(s.cells, float) / masses.sum()
        np.testing.assert_allclose(s.com_cell, com, atol=1e-14)
        assert math.isclose(s.mass, masses.sum())


def test_types_with_different_rotor_counts_mix():
    hexa = ModuleType(
        positions=[[0.1 * np.cos(a), 0.1 * np.sin(a), 0] for a in np.arange(6) * np.pi / 3],
        directions=[[0, 0, 1]] * 6,
        spins=[1, -1, 1, -1, 1, -1],
        name="hexa",
        mass=0.45,
    )
    s = mq.Structure([(0, 0), (1, 0), (1, 1)], modules=[T45, hexa, FLAT])
    A = s.configuration_matrix()
    assert A.shape == (6, 14)
    np.testing.assert_allclose(A, plain_matrix(s.cells, s.modules), atol=1e-14)


def test_batched_mixed_matrices_equal_each_structure():
    rng = np.random.default_rng(1)
    cells = np.array([random_cells(rng, 5) for _ in range(12)], dtype=float)
    types = rng.integers(0, 3, size=(12, 5))
    pal = [T45, FLAT, HEAVY]
    batch = mixed_configuration_matrices(cells, types, pal)
    for c, t, A in zip(cells, types, batch):
        ref = plain_matrix([tuple(map(int, x)) for x in c], [pal[k] for k in t])
        np.testing.assert_allclose(A, ref, atol=1e-14)


def test_one_type_repeated_is_the_homogeneous_structure_bit_for_bit():
    cells = [(0, 0), (1, 0), (1, 1), (2, 1)]
    m = mq.TModule()
    s = mq.Structure(cells, modules=[m] * 4)
    h = mq.Structure(cells, module=m)
    assert s.module is m and not s.is_mixed and s == h and s.key == h.key
    assert np.array_equal(s.configuration_matrix(), h.configuration_matrix())
    assert s.modules == (m,) * 4


def test_mixed_keys_identity_and_errors():
    a = mq.Structure([(0, 0), (1, 0)], modules=[T45, FLAT])
    b = mq.Structure([(5, 5), (6, 5)], modules=[T45, FLAT])
    c = mq.Structure([(0, 0), (1, 0)], modules=[FLAT, T45])
    assert a == b and hash(a) == hash(b) and a != c
    assert a.key == normalise_typed(a.cells, a.modules)
    assert "A = t45, B = flat" in a.to_text()
    with pytest.raises(ValueError, match="2 types for 3 cells"):
        mq.Structure([(0, 0), (1, 0), (2, 0)], modules=[T45, FLAT])
    with pytest.raises(ValueError, match="not both"):
        mq.Structure([(0, 0)], module=T45, modules=[T45])
    wide = ModuleType.from_tilts((0, 0, 0, 0), side=0.5)
    with pytest.raises(ValueError, match="same side"):
        mq.Structure([(0, 0), (1, 0)], modules=[T45, wide])
    with pytest.raises(ValueError, match="modules\\[1\\]"):
        mq.Structure([(0, 0), (1, 0)], modules=[T45, "flat"])


def test_centrosymmetric_mixed_structures_are_torque_balanced():
    s = mq.Structure([(0, 0), (1, 0), (2, 0)], modules=[HEAVY, T45, HEAVY])
    assert s.is_centrosymmetric() and s.is_torque_balanced()
    assert not mq.Structure(
        [(0, 0), (1, 0), (2, 0)], modules=[HEAVY, T45, T45]
    ).is_centrosymmetric()


# --- task kinds -----------------------------------------------------------------------------
def test_task_kind_files_round_trip(tmp_path):
    W = np.array([[0.1, 0.0, 2.0, 0.0, 0.0, 0.01]])
    t = TaskRequirement(W, name="ext", f_max=2.0, kind="external")
    for suffix in (".json", ".csv"):
        back = TaskRequirement.load(t.save(tmp_path / f"t{suffix}"))
        assert back == t and back.kind == "external"
    with pytest.raises(ValueError, match="kind=external"):
        TaskRequirement(W, kind="external").save(tmp_path / "t.npy")
    (tmp_path / "old.json").write_text(json.dumps({"wrenches": W.tolist()}))
    assert TaskRequirement.load(tmp_path / "old.json").kind == "total"
    assert "kind" not in TaskRequirement(W).to_dict()  # total files are written as before
    (tmp_path / "bad.json").write_text(json.dumps({"wrenches": W.tolist(), "kind": "net"}))
    with pytest.raises(TaskFileError, match="'kind' must be one of total, external"):
        TaskRequirement.load(tmp_path / "bad.json")
    assert t != TaskRequirement(W, name="ext", f_max=2.0)


def test_external_kind_adds_the_structure_weight():
    """A flat module lifts 4 f_max; an external task must leave room for its 2.943 N weight."""
    one = mq.Structure([(0, 0)], module=FLAT)
    ok = np.array([[0, 0, 4.0 - one.mass * GRAVITY - 1e-3, 0, 0, 0]])
    bad = ok + [0, 0, 2e-3, 0, 0, 0]
    for W, expect in ((ok, True), (bad, False)):
        task = TaskRequirement(W, kind="external")
        assert feasible(one.configuration_matrix(), task.rotor_wrenches(one.mass)).all() == expect
        assert TaskRequirement(W).rotor_wrenches(one.mass) is not None  # total: unchanged
    np.testing.assert_array_equal(rotor_wrenches(ok, "total", 5.0), ok)
    # 2 N on the environment: one flat module (4 N) cannot also lift itself, two (8 N) can
    task = TaskRequirement([[0, 0, 2.0, 0, 0, 0]], kind="external")
    r = mq.exhaustive_search(task, n_max=4, modules=[FLAT])
    assert r.n_modules == 2 and r.certified and r.to_dict()["kind"] == "external"
    assert (
        mq.exhaustive_search(TaskRequirement([[0, 0, 2.0, 0, 0, 0]]), 4, module=FLAT).n_modules == 1
    )
    # modules too heavy to lift themselves: proven impossible without any search
    lead = ModuleType.from_tilts((0, 0, 0, 0), name="lead", mass=1.0)
    r = mq.exhaustive_search(
        TaskRequirement([[0, 0, 0.1, 0, 0, 0]], kind="external"), 6, modules=[lead]
    )
    assert r.structure is None and r.evaluated == 0 and "lift its own weight" in r.proof


def test_planted_external_tasks_keep_the_hidden_structure_feasible():
    gen = PlantedTasks(n_modules=(2, 4), n_wrenches=10, kind="external", f_max=2.0)
    for seed in range(5):
        task = gen(np.random.default_rng(seed))
        hidden = mq.tasks.planted_structure(task)
        assert task.kind == "external"
        assert feasible(hidden.configuration_matrix(), task.rotor_wrenches(hidden.mass), 2.0).all()


# --- exact bounds ---------------------------------------------------------------------------
def test_count_bound_never_rejects_a_feasible_structure():
    rng = np.random.default_rng(2)
    pal = [T45, T45M, FLAT, HEAVY]
    for kind in ("total", "external"):
        for _ in range(30):
            s = random_mixed(rng, int(rng.integers(1, 7)), pal)
            task = planted_mixed(rng, s, kind=kind, slack=0.0)
            counts = [sum(m is p for m in s.modules) for p in pal]
            assert counts_possible(task.wrench_model, pal, [counts], 1.0)[0]
    assert len(count_vectors(7, 3)) == math.comb(9, 2)


# --- searches -------------------------------------------------------------------------------
def brute_force(task, pal, n_max):
    """Plain reference: every fixed polyomino (grown cell by cell, deduplicated by translation)
    times every type assignment, decided by the HiGHS LP; (n*, set of typed keys at n*)."""
    shapes = {((0, 0),)}
    for n in range(1, n_max + 1):
        if n > 1:
            grown = set()
            for key in shapes:
                for cell in mq.geometry.structure.free_neighbours(key):
                    grown.add(mq.geometry.structure.normalise(key + (cell,)))
            shapes = grown
        found = set()
        for key in shapes:
            for types in itertools.product(pal, repeat=n):
                s = mq.Structure(key, modules=types)
                W = rotor_wrenches(task.wrenches, task.kind, s.mass)
                if feasible(s.configuration_matrix(), W, task.f_max, method="scipy").all():
                    found.add(normalise_typed(s.cells, s.modules))
        if found:
            return n, found
    return None, set()


@pytest.mark.parametrize("kind", ["total", "external"])
def test_typed_search_equals_brute_force(kind):
    rng = np.random.default_rng(3 if kind == "total" else 4)
    pal = [T45, T45M, FLAT]
    f_max = 1.0 if kind == "total" else 2.0
    for _ in range(2):
        hidden = random_mixed(rng, 3, pal)
        task = planted_mixed(rng, hidden, t=6, kind=kind, f_max=f_max)
        n_ref, keys_ref = brute_force(task, pal, 3)
        n, keys = mq.optimal_structures(task, n_max=3, modules=pal)
        assert n == n_ref and set(keys) == keys_ref
        r = mq.exhaustive_search(task, n_max=3, modules=pal)
        typed_key = normalise_typed(r.structure.cells, r.structure.modules)
        assert r.n_modules == n_ref and typed_key in keys_ref and r.certified


@settings(max_examples=12, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(seed=st.integers(0, 10**6), kind=st.sampled_from(["total", "external"]))
def test_a_palette_never_needs_more_modules_than_its_best_type(seed, kind):
    rng = np.random.default_rng(seed)
    pal = [T45, T45M, FLAT]
    hidden = random_mixed(rng, int(rng.integers(2, 5)), pal)
    task = planted_mixed(rng, hidden, t=int(rng.integers(3, 12)), kind=kind, f_max=2.0)
    mixed = mq.exhaustive_search(task, n_max=4, modules=pal)
    assert mixed.structure is not None and mixed.n_modules <= hidden.n_modules
    for m in pal:
        alone = mq.exhaustive_search(task, n_max=4, modules=[m])
        if alone.structure is not None:
            assert mixed.n_modules <= alone.n_modules
        else:  # no single type works up to n_max: the mix may still
            assert alone.certified


@pytest.mark.parametrize("kind", ["total", "external"])
def test_every_search_result_is_verified_by_the_lp(kind):
    pal = [T45, T45M, FLAT]
    task = PaperTasks(n_wrenches=30, kind=kind, f_max=2.0 if kind == "external" else 1.0)(
        np.random.default_rng(7)
    )
    results = [
        mq.exhaustive_search(task, n_max=7, modules=pal),
        mq.centrosymmetric_search(task, n_max=9, modules=pal, block_seed=True),
        mq.greedy_search(task, n_max=9, modules=pal),
        mq.random_search(task, n_max=9, modules=pal, restarts=5),
    ]
    best = results[0].n_modules
    assert best is not None
    for r in results:
        assert r.to_dict()["modules"] == (
            None if r.structure is None else [m.name for m in r.structure.modules]
        )
        if r.structure is None:
            continue
        assert r.n_modules >= best
        W = rotor_wrenches(task.wrenches, kind, r.structure.mass)
        assert feasible(r.structure.configuration_matrix(), W, task.f_max, method="scipy").all()
        assert all(m in pal for m in r.structure.modules)
    centro = results[1].structure
    if centro is not None:
        assert centro.is_centrosymmetric()


def test_one_type_searches_are_unchanged_by_the_typed_machinery():
    task = PaperTasks()(np.random.default_rng(0))
    plain = mq.exhaustive_search(task, n_max=7)
    typed = mq.exhaustive_search(task, n_max=7, modules=[mq.TModule()])
    assert plain.structure.cells == typed.structure.cells
    assert (plain.evaluated, plain.oracle_calls) == (typed.evaluated, typed.oracle_calls)
    assert "modules" not in plain.to_dict() and "modules" in typed.to_dict()
    for search in (mq.centrosymmetric_search, mq.greedy_search, mq.random_search):
        a, b = search(task, n_max=7), search(task, n_max=7, modules=[mq.TModule()])
        assert a.structure.cells == b.structure.cells and a.evaluated == b.evaluated


def test_typed_search_counts_skipped_pairs_and_refuses_huge_levels():
    task = PaperTasks()(np.random.default_rng(1))
    r = mq.exhaustive_search(task, n_max=7, modules=[T45, T45M])
    # levels below the force bound hold 1*2 + 2*4 + 6*8 pairs, all skipped
    assert r.skipped >= 58 and r.n_modules is not None
    with pytest.raises(ValueError, match="pairs per level"):
        mq.exhaustive_search(task, n_max=12, modules=[T45, T45M, FLAT])
    with pytest.raises(ValueError, match="not both"):
        mq.exhaustive_search(task, n_max=3, module=T45, modules=[T45])


# --- environment ----------------------------------------------------------------------------
def test_mixed_env_spaces_masks_and_oracle_agreement():
    from gymnasium.utils.env_checker import check_env

    env = gym.make("ModQuadAssembly-v0", modules="t45,t45m,flat", n_max=5, tasks="paper")
    base = gym.make("ModQuadAssembly-v0", n_max=5)
    G, K = 9, 3
    assert env.action_space.n == G * G * K and base.action_space.n == G * G
    assert env.observation_space["types"].shape == (G * G * K,)
    assert "types" not in base.observation_space.spaces
    check_env(env.unwrapped, skip_render_check=True)
    u = env.unwrapped
    rng = np.random.default_rng(0)
    for episode in range(3):
        obs, info = env.reset(seed=episode)
        while True:
            mask = obs["action_mask"].reshape(K, G * G)
            assert (mask == mask[0]).all()  # every type of a valid cell is valid
            assert np.array_equal(obs["types"].reshape(K, -1).sum(axis=0), obs["occupancy"])
            s = u.structure
            W = rotor_wrenches(u.task.wrenches, u.task.kind, s.mass)
            assert info["success"] == bool(feasible(s.configuration_matrix(), W).all())
            if not mask.any():
                break
            obs, _, term, trunc, info = env.step(
                int(rng.choice(np.flatnonzero(obs["action_mask"])))
            )
            if term or trunc:
                break
        assert info["modules"] == [m.name for m in u.structure.modules]
    for bad in (-1, G * G * K, 2.5, None, "3"):
        env.reset(seed=0)
        _, _, _, _, info = env.step(bad)
        assert info["invalid_action"]
    assert gym.make("ModQuadAssemblyMixed-v1").unwrapped.n_types == 3


def test_mixed_env_initial_type_action_layout_and_external_tasks():
    task = TaskRequirement([[0, 0, 2.0, 0, 0, 0]], kind="external")
    env = gym.make("ModQuadAssembly-v0", modules=[FLAT, T45], tasks=task, n_max=4)
    u = env.unwrapped
    _, info = env.reset(seed=0)
    assert info["modules"] == ["flat"] and not info["success"]  # 2 N + own weight > 4 N
    a = u.action_of((1, 0), 0)
    assert u.cell_of(a) == (1, 0) and u.type_of(a) == 0
    _, _, term, _, info = env.step(a)
    assert term and info["success"] and info["mass_kg"] == pytest.approx(0.6)
    _, info = env.reset(options={"initial_type": 1})
    assert info["modules"] == ["t45"]
    env2 = gym.make("ModQuadAssembly-v0", modules="t45,flat", initial_type="random", n_max=3)
    starts = {env2.reset(seed=s)[1]["modules"][0] for s in range(20)}
    assert starts == {"t45", "flat"}
    with pytest.raises(ValueError, match="initial_type"):
        gym.make("ModQuadAssembly-v0", modules="t45,flat", initial_type=2)
    with pytest.raises(ValueError, match="of kind 'external'"):  # the one-type env refuses
        gym.make("ModQuadAssembly-v0", tasks=task).reset(seed=0)
    one = gym.make("ModQuadAssembly-v0", modules=[FLAT], tasks=task, n_max=3)
    assert one.action_space.n == 25 and not one.reset(seed=0)[1]["success"]


def test_mixed_env_lookahead_rows_match_the_child_supports():
    env = gym.make("ModQuadAssembly-v0", modules="t45,flat", n_max=4, lookahead=True, tasks="paper")
    obs, _ = env.reset(seed=3)
    u = env.unwrapped
    rows = obs["candidates"].reshape(-1, 5)
    valid = np.flatnonzero(obs["action_mask"])
    assert np.all(rows[np.setdiff1d(np.arange(len(rows)), valid)] == 0)
    feats, task = u.evaluator.features, u.state.task
    for a in valid[:6]:
        child = mq.Structure(
            [*u.state.cells, u.cell_of(a)],
            modules=[*u.structure.modules, u.palette[u.type_of(a)]],
        )
        h, slack = feats.support(child.configuration_matrix())
        ref = feats.candidates(h[None], np.array([slack]), task.h_Tn, task.WD)[0]
        np.testing.assert_allclose(rows[a], ref, atol=1e-6)


# --- command line ---------------------------------------------------------------------------
def test_cli_solve_with_modules_and_external_generation(tmp_path, capsys):
    out = tmp_path / "ext.json"
    assert main(["task", "generate", "--kind", "planted", "--task-kind", "external",
                 "--seed", "2", "--out", str(out)]) == 0  # fmt: skip
    data = json.loads(out.read_text())
    assert data["kind"] == "external" and data["f_max"] == 2.0
    capsys.readouterr()
    assert (
        main(["solve", "--task", str(out), "--modules", "t45,flat", "--json", "--n-max", "6"]) == 0
    )
    record = json.loads(capsys.readouterr().out)
    assert record["kind"] == "external" and len(record["modules"]) == record["n_modules"]
    assert main(["solve", "--task", str(out), "--modules", "t45,zz"]) == 2
    assert "--modules: unknown module type 'zz'" in capsys.readouterr().err


# --- pictures and MuJoCo --------------------------------------------------------------------
def test_mixed_pictures(tmp_path):
    from modquad_gym.viz.drawing import save_structure_figure, structure_image, type_colour

    s = mq.Structure([(0, 0), (1, 0), (0, 1)], modules=[T45, FLAT, T45M])
    img = structure_image(s, size=(128, 128))
    assert img.shape == (128, 128, 3)
    fill = tuple(int(type_colour(FLAT)[k : k + 2], 16) for k in (1, 3, 5))
    assert (img.reshape(-1, 3) == fill).all(axis=1).any()  # the flat module's fill is drawn
    assert (tmp_path / "s.png").exists() is False
    save_structure_figure(
        s, tmp_path / "s.png", task=TaskRequirement([[0, 0, 1, 0, 0, 0]], kind="external")
    )
    assert (tmp_path / "s.png").stat().st_size > 0


def test_mujoco_bench_and_hover_on_a_mixed_structure_with_self_weight():
    pytest.importorskip("mujoco")
    from modquad_gym.sim import build_model, run_bench, run_hover

    s = mq.Structure([(0, 0), (1, 0), (0, 1), (2, 0)], modules=[T45, HEAVY, T45M, FLAT])
    assert s.com_cell != (0.75, 0.25)  # the heavy module moves the COM off the plain mean
    task = PaperTasks(n_wrenches=6, kind="external", fz_offset=0.5, fz_gain=2.0, f_max=2.0)(
        np.random.default_rng(0)
    )
    W = task.rotor_wrenches(s.mass)
    assert feasible(s.configuration_matrix(), W, 2.0).all()
    bench = build_model(s, f_max=2.0, bench=True)
    assert bench.mass == pytest.approx(s.mass)
    r = run_bench(bench, W)
    assert r.max_error <= 1e-6 and r.max_sensor_error <= 1e-6
    hover = run_hover(build_model(s, f_max=2.0), W[:2], seconds_per_wrench=1.0)
    assert hover.max_position_error <= 0.01


def test_cli_validate_accepts_mixed_structures_of_external_tasks(tmp_path, capsys):
    pytest.importorskip("mujoco")
    task = PaperTasks(n_wrenches=4, kind="external", f_max=2.0, fz_offset=1.0, fz_gain=4.0)(
        np.random.default_rng(0)
    )
    path = task.save(tmp_path / "ext.json")
    args = ["validate", "--task", str(path), "--modules", "t45,t45m,flat", "--json"]
    args += ["--out", str(tmp_path / "v"), "--max-hover-wrenches", "2", "--hover-seconds", "1"]
    assert main([*args, "--known-load-only"]) == 0  # no unknown load: nothing to ramp
    report = json.loads(capsys.readouterr().out)
    assert report["task_kind"] == "external" and report["feasible"]
    assert len(report["modules"]) == report["n_modules"]
    assert report["mass_kg"] == pytest.approx(0.3 * report["n_modules"])
    assert report["bench_max_error"] <= 1e-6 and report["hover_max_position_error_m"] <= 0.01
