"""The free-faces action encoding (``actions="faces"``, ``ModQuadAssemblyScale-v0``), the
environment at n_max up to 64 and the conventions of issue 25 (limits, terminal masks, human
rendering)."""

from __future__ import annotations

import os
import subprocess
import sys
import warnings

import gymnasium as gym
import numpy as np
import pytest

import modquad_gym.envs  # noqa: F401  (registers the environments)
from modquad_gym.envs import ENV_IDS, ModQuadAssemblyEnv
from modquad_gym.envs.assembly.evaluator import (
    COMPILED_FROM,
    MixedStructureEvaluator,
    StructureEvaluator,
)
from modquad_gym.envs.assembly.faces import FACE_FEATURES, RING
from modquad_gym.envs.assembly.modules import OneType
from modquad_gym.geometry.cells import free_neighbours, normalise, normalise_typed
from modquad_gym.geometry.module import palette
from modquad_gym.geometry.structure import Structure
from modquad_gym.oracle import TOL
from modquad_gym.tasks import PlantedTasks
from modquad_gym.tasks.generators import random_cells

SMALL = PlantedTasks(n_modules=(2, 5), n_wrenches=(4, 16))


def play_cells(env: ModQuadAssemblyEnv, cells: list, seed: int) -> list:
    """Reset with ``seed`` and dock ``cells`` in order (each a free face); every step's result."""
    out = [env.reset(seed=seed)]
    for cell in cells:
        out.append(env.step(env.action_of(cell)))
        if out[-1][2] or out[-1][3]:
            break
    return out


def random_cells_episode(env: ModQuadAssemblyEnv, seed: int) -> list:
    """The cells a seeded random masked episode docks, in order."""
    rng = np.random.default_rng(seed)
    obs, _ = env.reset(seed=seed)
    cells, done = [], False
    while not done:
        a = int(rng.choice(np.flatnonzero(obs["action_mask"])))
        cells.append(env.cell_of(a))
        obs, _, term, trunc, _ = env.step(a)
        done = term or trunc
    return cells


@pytest.mark.parametrize("kwargs", [{}, {"modules": "t45,flat"}])
def test_faces_and_grid_make_the_same_episodes(kwargs):
    """The faces encoding re-indexes the grid's valid actions: docking the same cells gives the
    same rewards, infos and task and structure features."""
    grid = ModQuadAssemblyEnv(tasks=SMALL, n_max=6, **kwargs)
    faces = ModQuadAssemblyEnv(tasks=SMALL, n_max=6, actions="faces", **kwargs)
    for seed in range(4):
        cells = random_cells_episode(faces, seed)
        for g, f in zip(play_cells(grid, cells, seed), play_cells(faces, cells, seed)):
            g_obs, f_obs, g_info, f_info = g[0], f[0], g[-1], f[-1]
            for key in ("task", "structure"):
                np.testing.assert_array_equal(g_obs[key], f_obs[key])
            assert g[1:-1] == f[1:-1]  # reward, terminated, truncated
            for key in set(g_info) - {"action_mask"}:
                assert g_info[key] == f_info[key], key


def test_faces_are_the_free_neighbours_in_row_major_order_and_fit_the_slots():
    env = ModQuadAssemblyEnv(tasks=SMALL, n_max=9, actions="faces")
    slots = env.encoding.slots
    assert slots == 2 * 9 + 2 and env.action_space.n == slots
    for seed in range(5):
        rng = np.random.default_rng(seed)
        obs, info = env.reset(seed=seed)
        done = False
        while True:
            cells = [tuple(c) for c in info["cells"]]
            free = sorted(free_neighbours(cells), key=lambda c: (c[1], c[0]))
            n_free = len(free)
            assert n_free <= 2 * len(cells) + 2
            assert [env.cell_of(a) for a in range(n_free)] == free
            np.testing.assert_array_equal(obs["action_mask"], np.arange(slots) < n_free)
            rows = obs["candidates"].reshape(slots, FACE_FEATURES)
            assert not rows[n_free:].any()
            assert env.observation_space.contains(obs)
            if done:
                break
            a = int(rng.integers(n_free))
            obs, _, term, trunc, info = env.step(a)
            done = term or trunc


def test_candidate_rows_describe_each_face():
    env = ModQuadAssemblyEnv(tasks=SMALL, n_max=8, actions="faces", modules="t45,flat")
    obs, info = env.reset(seed=3)
    for a in (0, 2, 1):
        obs, *_, info = env.step(a)
    cells = {tuple(c) for c in info["cells"]}
    xy = np.array(sorted(cells), dtype=float)
    centre, reach = xy.mean(axis=0), np.abs(xy - xy.mean(axis=0)).max() + 1
    rows = obs["candidates"].reshape(2, env.encoding.slots, -1)
    for i in range(int(obs["action_mask"].sum()) // 2):
        x, y = env.cell_of(i)
        ring = [float((x + dx, y + dy) in cells) for dx, dy in RING]
        expected = [(x - centre[0]) / reach, (y - centre[1]) / reach, sum(ring[0::2]) / 4, *ring]
        for k in range(2):
            np.testing.assert_allclose(rows[k, i, :FACE_FEATURES], expected, atol=1e-6)
            np.testing.assert_array_equal(rows[k, i, FACE_FEATURES:], np.eye(2)[k])
            assert env.action_of((x, y), k) == k * env.encoding.slots + i


def test_faces_lookahead_rows_are_the_grids():
    faces = ModQuadAssemblyEnv(tasks=SMALL, n_max=6, actions="faces", lookahead=True)
    grid = ModQuadAssemblyEnv(tasks=SMALL, n_max=6, lookahead=True)
    cells = random_cells_episode(faces, 2)
    f_obs, _ = faces.reset(seed=2)
    g_obs, _ = grid.reset(seed=2)
    for cell in [*cells, None]:
        n = int(f_obs["action_mask"].sum())
        order = [grid.action_of(faces.cell_of(i)) for i in range(n)]
        rows = g_obs["candidates"].reshape(-1, 5)[order]
        f_rows = f_obs["candidates"].reshape(faces.action_space.n, -1)
        np.testing.assert_array_equal(f_rows[:n, -5:], rows)
        if cell is not None:
            f_obs, *_ = faces.step(faces.action_of(cell))
            g_obs, *_ = grid.step(grid.action_of(cell))


def test_scale_id_at_n_max_64_limits_and_checkers():
    env = gym.make("ModQuadAssemblyScale-v0")
    assert env.spec.max_episode_steps is None and env.unwrapped.max_steps == 4 * 64
    assert env.action_space.n == 130 and env.observation_space["candidates"].shape == (130 * 11,)
    obs, info = env.reset(seed=0)
    rng = np.random.default_rng(0)
    done = False
    while not done:
        obs, _, term, trunc, info = env.step(int(rng.choice(np.flatnonzero(obs["action_mask"]))))
        done = term or trunc
        assert env.observation_space.contains(obs)
    assert info["success"] or info["n_modules"] == 64
    assert obs["action_mask"].any()  # terminal masks are never empty
    from gymnasium.utils.env_checker import check_env

    small = gym.make("ModQuadAssemblyScale-v0", tasks=SMALL, n_max=5, modules="t45,flat")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        check_env(small.unwrapped)
        sb3 = pytest.importorskip("stable_baselines3.common.env_checker")
        sb3.check_env(ModQuadAssemblyEnv(tasks=SMALL, n_max=5, actions="faces"), warn=True)
    assert [str(w.message) for w in caught] == []


def test_every_id_limits_episodes_at_the_envs_own_limit_without_a_time_limit():
    for env_id in ENV_IDS:
        env = gym.make(env_id)
        assert env.spec.max_episode_steps is None, env_id
        assert env.unwrapped.max_steps == 4 * env.unwrapped.n_max, env_id
        assert not any(isinstance(w, gym.wrappers.TimeLimit) for w in _wrappers(env)), env_id


def _wrappers(env: gym.Env) -> list[gym.Env]:
    """``env`` and every env it wraps, outermost first."""
    chain = [env]
    while isinstance(chain[-1], gym.Wrapper):
        chain.append(chain[-1].env)
    return chain


def test_compiled_matrices_equal_the_structures():
    rng = np.random.default_rng(4)
    one = StructureEvaluator(OneType().module, 64, 1.0, 12, "auto")
    types = palette("t45,flat,t45m")
    mixed = MixedStructureEvaluator(types, 64, 1.0, 12, "auto")
    for n in (COMPILED_FROM, 40, 64):
        key = normalise(map(tuple, random_cells(rng, n)))
        A = Structure(list(key)).configuration_matrix()
        np.testing.assert_allclose(one.matrix_of(key), A, rtol=0, atol=1e-12)
        mods = [types[t] for t in rng.integers(3, size=n)]
        key = normalise_typed(map(tuple, random_cells(rng, n)), mods)
        A = Structure([c for c, _ in key], modules=[m for _, m in key]).configuration_matrix()
        np.testing.assert_allclose(mixed.matrix_of(key), A, rtol=0, atol=1e-12)


def test_the_env_key_is_normalise():
    rng = np.random.default_rng(5)
    for n in (1, 2, 7, 30):
        cells = [tuple(int(v) - 40 for v in c) for c in random_cells(rng, n)]
        assert OneType().key(tuple(cells), ()) == normalise(cells)


def test_faces_actions_of_cells_and_errors():
    env = ModQuadAssemblyEnv(tasks=SMALL, actions="faces")
    assert [env.cell_of(a) for a in range(4)] == [(0, -1), (-1, 0), (1, 0), (0, 1)]  # pre-reset
    env.reset(seed=0)
    with pytest.raises(ValueError, match="not a free face"):
        env.action_of((0, 0))
    with pytest.raises(ValueError, match="holds no face"):
        env.cell_of(5)
    with pytest.raises(AttributeError, match="faces encoding: use env.action_of"):
        _ = env.grid
    _, r, *_, info = env.step(7)  # an empty slot: an invalid action, never an error
    assert info["invalid_action"] and r < 0


def test_maskable_ppo_runs_on_the_faces_encoding():
    sb3 = pytest.importorskip("sb3_contrib")
    import torch

    torch.set_num_threads(1)
    env = ModQuadAssemblyEnv(tasks=SMALL, n_max=5, actions="faces")
    model = sb3.MaskablePPO("MultiInputPolicy", env, n_steps=32, batch_size=16, n_epochs=1,
                            seed=0, device="cpu")  # fmt: skip
    model.learn(64)
    obs, _ = env.reset(seed=1)
    action, _ = model.predict(obs, action_masks=env.action_masks(), deterministic=True)
    assert env.action_masks()[int(action)]


def test_human_rendering_prints_no_audio_noise():
    pytest.importorskip("pygame")
    code = (
        "import gymnasium as gym, modquad_gym\n"
        "env = gym.make('ModQuadAssembly-v0', render_mode='human', tasks='screwdriver')\n"
        "env.reset(seed=0); env.render(); env.close()\n"
    )
    env = {**os.environ, "SDL_VIDEODRIVER": "dummy"}
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env)
    assert out.returncode == 0, out.stderr
    assert out.stdout == "" and "ALSA" not in out.stderr and "pygame" not in out.stderr


def test_fused_supports_equal_the_plain_ones():
    from modquad_gym.envs.assembly.features import FUSED_FROM, AssemblyFeatures

    rng = np.random.default_rng(6)
    features = AssemblyFeatures(OneType().module, 64, 1.7, 48)
    for n in (FUSED_FROM // 4 + 1, 64):
        A = Structure(random_cells(rng, n)).configuration_matrix()
        h, slack = features.support(A)
        P = features.D @ A
        plain = np.maximum(P, 0.0).sum(axis=1) * 1.7 / features.denom
        np.testing.assert_allclose(h, plain, rtol=1e-12, atol=1e-15)
        s_plain = ((2.0 * TOL * 1.7 * np.abs(P).sum(axis=1) + 1e-12) / features.denom).max()
        assert slack == pytest.approx(s_plain, rel=1e-12)
