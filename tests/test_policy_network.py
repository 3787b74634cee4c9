"""The size-free policy (modquad_gym/policy/network.py): one saved network acts at any n_max and
with any palette, and its choices do not depend on the grid it is given."""

from __future__ import annotations

import json

import numpy as np
import pytest

from modquad_gym.geometry.module import palette
from modquad_gym.search import verified
from modquad_gym.solvers import make_solver
from modquad_gym.tasks import PlantedTasks, make_generator

torch = pytest.importorskip("torch")
pytest.importorskip("sb3_contrib")


@pytest.fixture(scope="module")
def size_free_model(tmp_path_factory):
    """A briefly trained CandidatePolicy on 4-module grids, saved like a training run."""
    from sb3_contrib import MaskablePPO

    from modquad_gym.policy.inference import type_features
    from modquad_gym.policy.network import CandidatePolicy
    from modquad_gym.policy.policy import make_env

    torch.set_num_threads(1)
    folder = tmp_path_factory.mktemp("size_free")
    env = make_env("planted", n_max=4, lookahead=True)
    kwargs = {"hidden": 16, "types": type_features(palette("t45"))}
    model = MaskablePPO(CandidatePolicy, env, n_steps=32, batch_size=32, n_epochs=1, seed=0,
                        device="cpu", policy_kwargs=kwargs)  # fmt: skip
    model.learn(32)
    model.save(folder / "model.zip")
    config = {"env_kwargs": {"tasks": "planted", "n_max": 4, "lookahead": True}}
    (folder / "config.json").write_text(json.dumps(config))
    return folder / "model.zip"


def test_one_network_acts_at_every_size(size_free_model):
    """Trained at n_max 4, the same weights decode and guide at 4, 7 and 12 modules; every
    answer is verified."""
    task = PlantedTasks(n_modules=5, n_wrenches=12)(np.random.default_rng(1))
    for n_max in (4, 7, 12):
        for method in ("ppo", "ppo-k2", "ppo-guided"):
            solver = make_solver(method, n_max=n_max, model=size_free_model)
            assert solver.policy.env.n_max == n_max and solver.policy.size_free
            r = solver.solve(task)
            assert r.evaluated >= 1 or r.certified  # or every level is ruled out unevaluated
            assert r.structure is None or verified(r.structure, task)
            assert r.structure is None or r.n_modules <= n_max


def test_one_network_acts_with_any_palette(size_free_model):
    """The one-type network is rebuilt for a palette: (cell, type) actions from each start
    type, typed answers verified with their self-weight."""
    types = palette("t45,t45m,flat")
    solver = make_solver("ppo", n_max=6, model=size_free_model, modules=types)
    assert solver.policy.starts == [0, 1, 2] and solver.policy.palette == types
    task = make_generator("planted-mixed-external")(np.random.default_rng(0))
    r = solver.solve(task)
    assert r.structure is None or verified(r.structure, task)
    assert r.structure is None or set(r.structure.modules) <= set(types)


def test_choices_do_not_depend_on_the_grid_size(size_free_model):
    """The same structure and task on a 9 x 9 and a 17 x 17 grid: the policy gives the same
    probabilities to the same cells (the inputs are de-normalised from n_max, up to float32
    rounding)."""
    task = PlantedTasks(n_modules=4, n_wrenches=12)(np.random.default_rng(3))
    cells = [(1, 0), (1, 1)]
    probs = []
    for n_max in (5, 9):
        policy = make_solver("ppo", n_max=n_max, model=size_free_model).policy
        env = policy.env
        obs, _ = policy.reset(task)
        for cell in cells:
            obs, *_ = env.step(env.action_of(cell))
        mask = env.action_masks()
        p = policy.probabilities(obs, mask)
        probs.append({env.cell_of(a): p[a] for a in np.flatnonzero(mask)})
    assert probs[0].keys() == probs[1].keys() and len(probs[0]) >= 4
    for cell, p in probs[0].items():
        assert p == pytest.approx(probs[1][cell], abs=1e-4), cell


def test_a_fixed_size_model_keeps_its_grid(tmp_path):
    """A model of SB3's MultiInputPolicy is tied to its grid: a larger n_max is refused."""
    from sb3_contrib import MaskablePPO

    from modquad_gym.policy.policy import make_env

    env = make_env("planted", n_max=3)
    kwargs = {"net_arch": [8]}
    model = MaskablePPO("MultiInputPolicy", env, seed=0, device="cpu", policy_kwargs=kwargs)
    model.save(tmp_path / "model.zip")
    with pytest.raises(ValueError, match="exceeds the n_max=3"):
        make_solver("ppo", n_max=4, model=tmp_path / "model.zip")
