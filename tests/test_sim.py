"""MuJoCo validation: the model's actuation, the wrench bench, hover, and validate()."""

from __future__ import annotations

import os

os.environ.setdefault("MUJOCO_GL", "egl")  # before mujoco is imported: headless rendering

import json  # noqa: E402
import math  # noqa: E402

import mujoco  # noqa: E402
import numpy as np  # noqa: E402
import pytest  # noqa: E402

import modquad_gym as mq  # noqa: E402
from modquad_gym.sim import (  # noqa: E402
    actuator_wrench,
    build_model,
    render_structure,
    run_bench,
    run_hover,
    validate,
)
from modquad_gym.sim.validate import infeasible_wrench  # noqa: E402

L3 = [(0, 0), (1, 0), (0, 1)]
SQUARE = [(0, 0), (1, 0), (0, 1), (1, 1)]


def _interior_wrenches(structure: mq.Structure, t: int, seed: int) -> np.ndarray:
    """t wrenches A u with u drawn inside the box: feasible by construction."""
    rng = np.random.default_rng(seed)
    A = structure.configuration_matrix()
    return rng.uniform(0.15, 0.85, (t, A.shape[1])) @ A.T


def _random_quaternion(rng: np.random.Generator) -> np.ndarray:
    q = rng.normal(size=4)
    return q / np.linalg.norm(q)


@pytest.mark.parametrize("cells", [[(0, 0)], [(0, 0), (1, 0), (2, 0)], L3, SQUARE])
def test_model_actuation_equals_Au(cells):
    s = mq.Structure(cells)
    sim = build_model(s, f_max=1.0)
    data = sim.new_data()
    rng = np.random.default_rng(len(cells))
    assert sim.model.nu == 4 * s.n_modules and sim.model.nv == 6
    np.testing.assert_allclose(sim.model.actuator_ctrlrange, [[0.0, 1.0]] * sim.model.nu)
    np.testing.assert_allclose(sim.model.body_ipos[sim.body_id], 0.0, atol=1e-12)  # COM = {S}
    for _ in range(5):
        data.qpos[3:7] = _random_quaternion(rng)  # the body frame need not match the world
        u = rng.uniform(0.0, 1.0, sim.n_rotors)
        data.ctrl[:] = u
        mujoco.mj_forward(sim.model, data)
        np.testing.assert_allclose(
            actuator_wrench(sim, data), s.configuration_matrix() @ u, atol=1e-9
        )


def test_model_clamps_ctrl_to_f_max():
    s = mq.Structure(L3)
    sim = build_model(s, f_max=2.0)
    data = sim.new_data()
    data.ctrl[:] = 5.0  # beyond f_max: MuJoCo clamps to ctrlrange
    mujoco.mj_forward(sim.model, data)
    expected = s.configuration_matrix() @ np.full(12, 2.0)
    np.testing.assert_allclose(actuator_wrench(sim, data), expected, atol=1e-9)


def test_model_rejects_bad_input():
    with pytest.raises(ValueError, match="f_max"):
        build_model(mq.Structure(L3), f_max=0.0)
    with pytest.raises(ValueError, match="module_mass"):
        build_model(mq.Structure(L3), module_mass=-1.0)
    with pytest.raises(ValueError, match="Structure"):
        build_model([(0, 0)])


def test_bench_on_L_structure_reads_commanded_wrench():
    s = mq.Structure(L3)
    W = _interior_wrenches(s, 6, seed=1)
    assert mq.feasible(s.configuration_matrix(), W).all()
    res = run_bench(s, W, allocation="exact")
    assert res.max_error <= 1e-6
    assert res.max_sensor_error <= 1e-6
    assert res.feasible.all()
    assert np.all((res.u >= 0) & (res.u <= 1.0))
    # the paper's pinv + clip: the bench reads what the clipped inputs make, exactly
    clip = run_bench(s, W, allocation="pinv_clip")
    assert clip.max_sensor_error <= 1e-6
    np.testing.assert_allclose(
        clip.u, np.clip(W @ np.linalg.pinv(s.configuration_matrix()).T, 0, 1)
    )


def test_bench_sensor_is_not_a_gravity_only_reading():
    """Different inputs give different readings, and zero input reads zero after the weight."""
    s = mq.Structure(L3)
    W = np.vstack([np.zeros(6), _interior_wrenches(s, 1, seed=3)])
    res = run_bench(s, W, allocation="pinv_clip")
    np.testing.assert_allclose(res.measured[0], 0.0, atol=1e-9)
    assert np.linalg.norm(res.measured[1]) > 1.0


def test_bench_rejects_bad_allocation_and_shape():
    s = mq.Structure(L3)
    with pytest.raises(ValueError, match="allocation"):
        run_bench(s, np.zeros((1, 6)), allocation="magic")
    with pytest.raises(ValueError, match="shape"):
        run_bench(s, np.zeros((2, 5)))


def test_hover_2x2_holds_a_feasible_wrench():
    s = mq.Structure(SQUARE)
    w = _interior_wrenches(s, 1, seed=5)
    assert mq.margin(s.configuration_matrix(), w)[0] > 0.3
    res = run_hover(s, w, seconds_per_wrench=1.5, takeoff_seconds=2.0)
    takeoff = res.segment_metrics[0]
    assert takeoff["segment"] == -1 and takeoff["max_position_error_m"] <= 0.01
    assert res.max_position_error <= 0.01
    assert res.max_attitude_error <= 0.01
    assert res.saturated_fraction == 0.0
    assert not res.diverged.any()
    assert np.all((res.u >= 0) & (res.u <= 1.0))


def test_hover_infeasible_wrench_saturates_and_drifts():
    s = mq.Structure(SQUARE)
    A = s.configuration_matrix()
    w_bad = infeasible_wrench(A, _interior_wrenches(s, 1, seed=6)[0], 1.0, 1.3)
    assert not mq.feasible(A, w_bad[None])[0]
    res = run_hover(s, w_bad[None], seconds_per_wrench=1.5, takeoff_seconds=0.0)
    assert res.saturated_fraction > 0.5
    assert res.max_position_error > 0.01 or res.max_attitude_error > 0.1
    assert np.all((res.u >= 0) & (res.u <= 1.0))


def test_hover_rank_deficient_structure_does_not_crash():
    s = mq.Structure([(0, 0), (1, 0)])  # a straight line: rank 5
    w = np.array([0.2, 0.3, 3.0, 0.1, -0.1, 0.05])
    res = run_hover(s, w, seconds_per_wrench=0.5, takeoff_seconds=0.5)
    assert len(res.segment_metrics) == 2
    assert math.isinf(res.gamma[0]) and not res.feasible[0]
    assert np.all(np.isfinite(res.position_error))


def test_render_matplotlib_fallback(tmp_path):
    path = tmp_path / "s.png"
    assert render_structure(mq.Structure(L3), path, backend="matplotlib") == "matplotlib"
    assert path.stat().st_size > 1000


def test_validate_writes_files_and_keys(tmp_path):
    s = mq.Structure(L3)
    W = _interior_wrenches(s, 2, seed=7)
    out = validate(
        s, W, out_dir=tmp_path, hover_seconds=0.5, render=True, include_infeasible_demo=True
    )
    json.dumps(out)  # JSON-serialisable
    for key in (
        "bench_max_error",
        "bench_max_error_pinv_clip",
        "hover_max_position_error_m",
        "hover_max_attitude_error_rad",
        "saturated_fraction",
        "n_modules",
        "cells",
        "feasible",
        "files",
    ):
        assert key in out
    assert out["n_modules"] == 3 and out["cells"] == [list(c) for c in L3]
    assert out["feasible"] is True
    assert out["bench_max_error"] <= 1e-6
    assert out["infeasible_demo"]["feasible"] is False
    assert out["infeasible_demo"]["saturated_fraction"] > 0.5
    for name in ("rotor_inputs", "bench_wrench", "hover", "structure", "report"):
        assert (tmp_path / f"{name}{'.md' if name == 'report' else '.png'}").stat().st_size > 100
    assert "bench" in (tmp_path / "report.md").read_text().lower()
    assert out["render_backend"] in ("mujoco", "matplotlib")  # matplotlib where no GL exists
