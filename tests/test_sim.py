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
    ValidationReport,
    actuator_wrench,
    build_model,
    render_structure,
    run_bench,
    run_hover,
    validate,
)
from modquad_gym.sim.hover import (  # noqa: E402
    body_inertia,
    hover_linearization,
    step_headroom,
    unreachable_wrench_directions,
    wrench_axis,
)
from modquad_gym.sim.validate import infeasible_wrench  # noqa: E402

L3 = [(0, 0), (1, 0), (0, 1)]
SQUARE = [(0, 0), (1, 0), (0, 1), (1, 1)]
LINE4 = [(0, 0), (1, 0), (2, 0), (-1, 0)]  # the hidden structure of examples/planted_seed1.json


def _interior_wrenches(
    structure: mq.Structure, t: int, seed: int, lo: float = 0.15, hi: float = 0.85
) -> np.ndarray:
    """t wrenches A u with u drawn inside the box: feasible by construction."""
    rng = np.random.default_rng(seed)
    A = structure.configuration_matrix()
    return rng.uniform(lo, hi, (t, A.shape[1])) @ A.T


def _trim(s: mq.Structure) -> np.ndarray:
    """The take-off trim: every rotor at half thrust."""
    return s.configuration_matrix().sum(axis=1) / 2.0


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


@pytest.mark.parametrize("bench", [False, True])
def test_model_is_built_with_mjspec_and_its_mjcf_loads_back(bench):
    from modquad_gym.sim.model import model_spec, model_xml

    s = mq.Structure(L3, modules=[mq.TModule(), mq.ModuleType.from_tilts([0.3] * 4), mq.TModule()])
    spec = model_spec(s, f_max=2.0, bench=bench)
    assert isinstance(spec, mujoco.MjSpec)
    compiled = build_model(s, f_max=2.0, bench=bench).model
    loaded = mujoco.MjModel.from_xml_string(model_xml(s, f_max=2.0, bench=bench))
    assert loaded.nu == compiled.nu == 12 and loaded.nbody == compiled.nbody
    # MuJoCo's XML writer keeps 6 significant digits
    for name in ("site_pos", "site_quat", "actuator_gear", "actuator_ctrlrange", "body_mass",
                 "body_inertia", "body_ipos", "geom_size", "eq_data"):  # fmt: skip
        np.testing.assert_allclose(getattr(loaded, name), getattr(compiled, name), atol=2e-6)


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


@pytest.mark.parametrize("cells", [[(0, 0), (1, 0)], [(0, 0), (1, 0), (2, 0)], LINE4])
def test_unreachable_direction_of_a_line(cells):
    """A line along x cannot make 0.1497 f_y + 0.9887 tau_x: no moment about the axis parallel
    to the line 0.151 m above the COM; the same for every length. Along y: f_x and tau_y."""
    A = mq.Structure(cells).configuration_matrix()
    N = unreachable_wrench_directions(A)
    assert N.shape == (6, 1)
    n = N[:, 0]
    np.testing.assert_allclose(A.T @ n, 0.0, atol=1e-12)
    np.testing.assert_allclose(n, [0, 0.1497, 0, 0.9887, 0, 0], atol=1e-4)
    axis = wrench_axis(n)
    np.testing.assert_allclose(axis["axis"], [1, 0, 0], atol=1e-12)
    np.testing.assert_allclose(axis["point"], [0, 0, 0.1514], atol=1e-4)
    assert axis["pitch"] == 0.0
    ny = unreachable_wrench_directions(mq.Structure([(0, 0), (0, 1)]).configuration_matrix())
    assert np.count_nonzero(np.abs(ny[:, 0]) > 1e-9) == 2
    assert abs(ny[0, 0]) > 0.1 and abs(ny[4, 0]) > 0.9
    assert unreachable_wrench_directions(mq.Structure(SQUARE).configuration_matrix()).shape == (
        6,
        0,
    )
    assert unreachable_wrench_directions(mq.Structure([(0, 0)]).configuration_matrix()).shape == (
        6,
        2,
    )


def test_hover_linearization_matches_mujoco():
    """The controller's model (world-fixed load: tilting steers the rotor wrench) equals
    MuJoCo's finite-difference linearisation of the flight model."""
    s = mq.Structure(LINE4)
    sim = build_model(s)
    A, m, J = sim.A, sim.mass, body_inertia(sim)
    w = _interior_wrenches(s, 1, seed=11)[0]
    F, B = hover_linearization(A, w, m, J, "world")
    data = sim.new_data()
    data.ctrl[:] = mq.oracle.allocate(A, w)[0]
    data.xfrc_applied[sim.body_id, :3] = -w[:3] - m * np.array(sim.model.opt.gravity)
    data.xfrc_applied[sim.body_id, 3:] = -w[3:]
    Ad = np.zeros((12, 12))
    Bd = np.zeros((12, A.shape[1]))
    mujoco.mjd_transitionFD(sim.model, data, 1e-6, True, Ad, Bd, None, None)
    dt = sim.model.opt.timestep
    np.testing.assert_allclose((Ad[6:] - np.eye(12)[6:]) / dt, F[6:], atol=1e-6)
    np.testing.assert_allclose(Bd[6:] / dt, B[6:], atol=1e-6)
    _, B_body = hover_linearization(A, w, m, J, "body")
    assert np.array_equal(B_body, B)


def test_hover_line_attitude_stays_bounded():
    """The audited creep: a 4-module line (rank 5) held 0.07 -> 0.55 rad of roll over six
    feasible wrenches. With the world-fixed load the LQR holds position and attitude."""
    s = mq.Structure(LINE4)
    W = _interior_wrenches(s, 4, seed=12, lo=0.3, hi=0.7)
    assert mq.feasible(s.configuration_matrix(), W).all()
    res = run_hover(s, W, seconds_per_wrench=1.5, takeoff_seconds=2.0)
    task = [m for m in res.segment_metrics if m["segment"] >= 0]
    assert all(m["controller"] == "lqr" for m in res.segment_metrics)
    assert res.max_attitude_error <= 0.01
    assert res.max_position_error <= 0.01
    att = [m["max_attitude_error_rad"] for m in task]
    assert att[-1] <= att[0] + 1e-6  # no creep from segment to segment
    assert res.saturated_fraction == 0.0
    assert not res.diverged.any()


def test_hover_body_following_load_on_a_line_falls_back():
    """With the load following the body, the line's unreachable direction is uncontrollable in
    the linearisation: no stabilising LQR exists and the projected PD runs (documented)."""
    s = mq.Structure(LINE4)
    W = _interior_wrenches(s, 1, seed=13, lo=0.3, hi=0.7)
    res = run_hover(s, W, seconds_per_wrench=0.2, takeoff_seconds=0.2, load_frame="body")
    assert {m["controller"] for m in res.segment_metrics} == {"pd_fallback"}
    with pytest.raises(ValueError, match="load_frame"):
        run_hover(s, W, load_frame="tool")


@pytest.mark.parametrize("cells", [SQUARE, [(0, 0), (1, 0), (2, 0)]])
def test_hover_unknown_load_settles_within_1cm(cells):
    """The controller is not told the load, which ramps from one task wrench to the next over
    1 s (cosine): the observer and integral action find it; position <= 1 cm once settled and
    no rotor ever saturates."""
    s = mq.Structure(cells)
    W = _interior_wrenches(s, 2, seed=14, lo=0.3, hi=0.7)
    res = run_hover(
        s, W, seconds_per_wrench=2.0, takeoff_seconds=1.5, known_load=False, load_ramp_seconds=1.0
    )
    assert not res.known_load and res.load_ramp_seconds == 1.0
    assert res.max_position_error <= 0.01
    assert res.max_attitude_error <= 0.05
    assert res.saturated_fraction == 0.0 and res.settled_saturated_fraction == 0.0
    assert not res.diverged.any()
    assert res.max_load_estimate_error < 0.1
    task = [m for m in res.segment_metrics if m["segment"] >= 0]
    assert all(m["step_headroom"] is not None and m["step_headroom"] > 0 for m in task)
    # the applied load: a cosine ramp from the previous wrench (the take-off trim first) to the
    # next over the first 500 control steps of each segment, then held
    trim = _trim(s)
    for i, (w_from, w_to) in enumerate([(trim, W[0]), (W[0], W[1])]):
        load = res.load[res.segment == i]
        frac = (load - w_from) @ (w_to - w_from) / float((w_to - w_from) @ (w_to - w_from))
        n = np.arange(1, 501) / 500
        np.testing.assert_allclose(frac[:500], 0.5 * (1 - np.cos(np.pi * n)), atol=1e-9)
        np.testing.assert_allclose(load[499:], np.broadcast_to(w_to, load[499:].shape), atol=1e-9)
    # the estimate has followed the load when the settled window starts
    for i in range(2):
        est = res.load_estimate[res.segment == i][700]
        assert np.linalg.norm(est - W[i]) < 0.05 * np.linalg.norm(W[i])


def test_hover_load_ramp_options():
    s = mq.Structure(L3)
    W = _interior_wrenches(s, 1, seed=15, lo=0.3, hi=0.7)
    # a step (0) applies the new load at once; a known load always steps
    for kw in ({"known_load": False, "load_ramp_seconds": 0.0}, {"load_ramp_seconds": 1.0}):
        res = run_hover(s, W, seconds_per_wrench=0.1, takeoff_seconds=0.1, **kw)
        assert res.load_ramp_seconds == 0.0
        np.testing.assert_array_equal(res.load[res.segment == 0][0], W[0])
    kw = {"known_load": False, "load_ramp_seconds": 0.1, "load_ramp_profile": "linear"}
    res = run_hover(s, W, seconds_per_wrench=0.2, takeoff_seconds=0.0, **kw)
    trim = _trim(s)
    frac = (res.load[:50] - trim) @ (W[0] - trim) / float((W[0] - trim) @ (W[0] - trim))
    np.testing.assert_allclose(frac, np.arange(1, 51) / 50, atol=1e-9)
    with pytest.raises(ValueError, match="settled part"):  # the ramp must end before settling
        run_hover(s, W, seconds_per_wrench=1.0, known_load=False, load_ramp_seconds=0.8)
    with pytest.raises(ValueError, match="load_ramp_profile"):
        run_hover(s, W, known_load=False, load_ramp_profile="step")
    with pytest.raises(ValueError, match="load_ramp_seconds"):
        run_hover(s, W, known_load=False, load_ramp_seconds=-1.0)


def test_hover_divergence_restarts_next_segment_from_equilibrium():
    """An infeasible load diverges; the next segment restarts at rest from the trim (the
    infeasible load has no equilibrium) and its numbers are not contaminated."""
    s = mq.Structure(L3)
    A = s.configuration_matrix()
    W = _interior_wrenches(s, 2, seed=7)
    bad = infeasible_wrench(A, W[0], 1.0, 1.3)
    res = run_hover(
        s, np.vstack([bad, W[1]]), seconds_per_wrench=2.0, takeoff_seconds=0.5, known_load=False
    )
    seg = {m["segment"]: m for m in res.segment_metrics}
    assert res.diverged.tolist() == [True, False]
    assert seg[0]["stop_reason"] and seg[0]["stop_time_s"] < 2.0
    assert seg[1]["max_position_error_m"] <= 0.01
    assert seg[1]["settled_saturated_fraction"] == 0.0
    np.testing.assert_allclose(res.load[res.segment == 1][0], _trim(s), atol=1e-4)


def test_step_headroom():
    A = mq.Structure(SQUARE).configuration_matrix()
    centre = A @ np.full(16, 0.5)
    top = A @ np.ones(16)  # all rotors at f_max: no room further along the step from the centre
    assert step_headroom(A, top, centre) == pytest.approx(0.0, abs=1e-7)
    assert step_headroom(A, centre, top) > 1.0
    assert step_headroom(A, 2 * top, centre) is None  # infeasible
    assert step_headroom(A, centre, centre) == math.inf


def test_render_matplotlib_fallback(tmp_path):
    path = tmp_path / "s.png"
    assert render_structure(mq.Structure(L3), path, backend="matplotlib") == "matplotlib"
    assert path.stat().st_size > 1000


def test_validate_writes_files_and_keys(tmp_path):
    s = mq.Structure(L3)
    W = _interior_wrenches(s, 2, seed=7)
    report = validate(
        s, W, out_dir=tmp_path, hover_seconds=0.5, render=True, include_infeasible_demo=True
    )
    assert isinstance(report, ValidationReport)
    out = report.to_dict()
    assert report.hover.max_position_error_m == out["hover_max_position_error_m"]
    assert report.infeasible_demo.diverged == out["infeasible_demo"]["diverged"]
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
    for name in ("rotor_inputs", "bench_wrench", "hover", "hover_unknown_load", "structure"):
        assert (tmp_path / f"{name}.png").stat().st_size > 100
    report = (tmp_path / "report.md").read_text()
    assert "bench" in report.lower()
    assert out["render_backend"] in ("mujoco", "matplotlib")  # matplotlib where no GL exists
    # the JSON file holds what was returned, its own path included
    assert out["files"]["json"] == str(tmp_path / "validation.json")
    assert json.loads((tmp_path / "validation.json").read_text()) == json.loads(json.dumps(out))
    for key in (
        "hover_unknown_load_max_position_error_m",
        "hover_unknown_load_max_attitude_error_rad",
        "hover_unknown_load_saturated_fraction",
        "hover_unknown_load_settled_saturated_fraction",
    ):
        assert isinstance(out[key], float)
    assert out["rank"] == 6 and out["unreachable_wrench_directions"] == []
    demo = out["infeasible_demo"]
    assert "attitude error up to" in report
    if demo["diverged"]:  # the report says why the run stopped (or where it ended)
        assert demo["stop_reason"] in report
        assert ("stopped after" in report) == (demo["stop_time_s"] is not None)
    else:
        assert demo["stop_reason"] is None and "did not reach a drift limit" in report
    assert "all 2 wrenches" in report
    # the unknown load ramps; with 0.5 s segments the 1 s default is cut to end before settling
    assert out["hover_unknown_load_ramp_seconds"] == pytest.approx(0.35)
    assert "0.35 s ramp" in report


def test_validate_counts_the_feasible_wrenches_it_hovered_on_not_the_first_ones(tmp_path):
    s = mq.Structure([(0, 0), (1, 0)])
    inside = _interior_wrenches(s, 1, seed=3, lo=0.3, hi=0.7)[0]
    W = np.array([inside, 3.0 * inside])  # the second lies outside W: the smallest margin
    out = validate(s, W, hover_seconds=0.2, render=False, max_hover_wrenches=1,
                   unknown_load=False).to_dict()  # fmt: skip
    assert out["feasible"] is False and out["hover_wrenches"] == 1
    assert out["hover_n_feasible"] == 0  # it hovered on the infeasible one (the first is not)


def test_validate_report_names_the_hovered_subset(tmp_path):
    s = mq.Structure([(0, 0), (1, 0), (2, 0)])
    W = _interior_wrenches(s, 3, seed=8, lo=0.3, hi=0.7)
    out = validate(
        s,
        W,
        out_dir=tmp_path,
        hover_seconds=0.3,
        render=False,
        max_hover_wrenches=1,
        unknown_load=False,
    ).to_dict()
    assert out["hover_wrenches"] == 1 and "hover_unknown_load_max_position_error_m" not in out
    assert (out["hover_load_frame"], out["hover_seconds_per_wrench"]) == ("world", 0.3)
    assert out["hover_n_feasible"] == 1 and out["hover_takeoff"]["segment"] == -1
    report = (tmp_path / "report.md").read_text()
    assert "Hover on 1 of the 3 wrenches: the hardest half by margin" in report
    assert "0.151" in report  # the line's unreachable direction, explained
    assert out["unreachable_wrench_directions"][0]["point"][2] == pytest.approx(0.1514, abs=1e-4)
    assert set(out["files"]) == {"rotor_inputs", "bench_wrench", "hover", "report", "json"}


def test_validate_refuses_bad_input_before_simulating():
    s = mq.Structure([(0, 0)])
    W = _interior_wrenches(s, 1, seed=0)
    with pytest.raises(ValueError, match="structure must be a modquad_gym.Structure, got list"):
        validate([(0, 0)], W)
    with pytest.raises(ValueError, match="load_ramp_seconds must be >= 0, got -1"):
        validate(s, W, load_ramp_seconds=-1)
    with pytest.raises(ValueError, match="f_max"):
        validate(s, W, f_max=-1.0)
