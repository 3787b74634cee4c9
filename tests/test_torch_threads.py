"""The package's torch network acts on one torch thread and leaves the caller's thread count as it
found it (reading a model set the whole process to one thread, for good)."""

from __future__ import annotations

import shutil

import pytest

from modquad_gym.policy.models import DEFAULT_MODEL
from modquad_gym.solvers import make_solver
from modquad_gym.tasks import load_task


def test_the_torch_network_acts_on_one_thread_and_restores_the_callers(tmp_path, monkeypatch):
    torch = pytest.importorskip("torch")
    pytest.importorskip("sb3_contrib")
    folder = tmp_path / "no_export"  # without model_actor.npz: the torch network acts
    folder.mkdir()
    for name in ("model.zip", "config.json"):
        shutil.copy(DEFAULT_MODEL.parent / name, folder / name)
    before = torch.get_num_threads()
    try:
        torch.set_num_threads(3)
        solver = make_solver("ppo", n_max=7, model=folder / "model.zip")
        assert solver.policy.actor is None
        net, acting = solver.policy.net, []
        assert torch.get_num_threads() == 3  # reading the model changed nothing
        original = net.get_distribution

        def get_distribution(*args, **kwargs):
            acting.append(torch.get_num_threads())
            return original(*args, **kwargs)

        monkeypatch.setattr(net, "get_distribution", get_distribution)
        assert solver.solve(load_task("example:planted_seed1")).structure is not None
        assert acting and set(acting) == {1}  # one thread while it acts
        assert torch.get_num_threads() == 3  # the caller's count after
    finally:
        torch.set_num_threads(before)
