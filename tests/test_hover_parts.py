"""The hover's parts one by one (config, load profile, headroom LP, allocator, estimator, gains,
recorder, rotations), each against a plain reference, and run_hover's two call styles."""

from __future__ import annotations

import math

import numpy as np
import pytest

import modquad_gym as mq
from modquad_gym.oracle import TOL, feasible, lambda_ratio, ray_lp
from modquad_gym.sim.hover import (
    Allocator,
    HoverConfig,
    HoverGains,
    LoadEstimator,
    LoadRamp,
    Plant,
    Recorder,
    design_gains,
    external_wrench,
    hover_linearization,
    ramp_fraction,
    rotation_angle,
    rotation_vector,
    step_headroom,
)
from modquad_gym.sim.hover.controller import HoverController
from modquad_gym.sim.hover.gains import LQR, PD_FALLBACK, corrections, integral_rate
from modquad_gym.sim.hover.recorder import drift_reason

L3 = mq.Structure([(0, 0), (1, 0), (0, 1)])
LINE3 = mq.Structure([(0, 0), (1, 0), (2, 0)])
J_L3 = np.diag([0.05, 0.06, 0.1])


def _plant(s: mq.Structure = L3, f_max: float = 1.0) -> Plant:
    return Plant.build(s.configuration_matrix(), f_max, 0.3 * s.n_modules, J_L3)


def _interior(s: mq.Structure, t: int, seed: int, lo=0.2, hi=0.8) -> np.ndarray:
    A = s.configuration_matrix()
    return np.random.default_rng(seed).uniform(lo, hi, (t, A.shape[1])) @ A.T


# -- config ---------------------------------------------------------------------------------------
def test_config_defaults_and_checks():
    cfg = HoverConfig()
    assert cfg.seconds_per_wrench == 2.0 and cfg.control_hz == 500.0 and cfg.known_load
    assert cfg.gains == HoverGains() and cfg.ramp_seconds == 0.0  # a known load steps
    assert HoverConfig(known_load=False).ramp_seconds == 1.0
    assert cfg.control_steps(0.001) == (2, 0.002)
    assert cfg.segment_steps() == (1000, 1000, 300)
    # a known load ignores the ramp, so short segments with the default ramp are fine
    assert HoverConfig(seconds_per_wrench=0.5).ramp_seconds == 0.0
    bad = [
        ({"settle_fraction": 0.0}, "settle_fraction"),
        ({"settle_fraction": 1.5}, "settle_fraction"),
        ({"seconds_per_wrench": -1.0}, "seconds_per_wrench"),
        ({"f_max": 0.0}, "f_max"),
        ({"load_frame": "tool"}, "load_frame"),
        ({"load_ramp_profile": "step"}, "load_ramp_profile"),
        ({"known_load": False, "load_ramp_seconds": -1.0}, "load_ramp_seconds"),
        ({"known_load": False, "seconds_per_wrench": 1.0}, "settled part"),
        ({"known_load": 1}, "known_load"),
        ({"initial_offset": (0.0, 0.0)}, "initial_offset"),
        ({"gains": {"omega_pos": 1.0}}, "gains"),
    ]
    for kw, match in bad:
        with pytest.raises(ValueError, match=match):
            HoverConfig(**kw)
    with pytest.raises(ValueError, match="omega_pos"):
        HoverGains(omega_pos=0.0)
    with pytest.raises(ValueError, match="divide the physics rate"):
        HoverConfig(control_hz=300.0).control_steps(0.001)


def test_config_make_replaces_fields():
    base = HoverConfig(seconds_per_wrench=0.5)
    cfg = HoverConfig.make(base, known_load=False, load_ramp_seconds=0.2, gains=None)
    assert cfg.seconds_per_wrench == 0.5 and not cfg.known_load and cfg.ramp_seconds == 0.2
    assert cfg.gains == HoverGains() and base.known_load  # the base is unchanged
    assert HoverConfig.make() == HoverConfig()
    with pytest.raises(ValueError, match="unknown hover option"):
        HoverConfig.make(seconds=1.0)
    with pytest.raises(ValueError, match="config must be a HoverConfig"):
        HoverConfig.make({"seconds_per_wrench": 1.0})


# -- load profile ---------------------------------------------------------------------------------
def test_ramp_fraction_profiles():
    xs = np.linspace(0.0, 1.0, 11)
    cos = [ramp_fraction(x, "cosine") for x in xs]
    np.testing.assert_allclose(cos, 0.5 * (1 - np.cos(np.pi * xs)), atol=1e-15)
    assert [ramp_fraction(x, "linear") for x in xs] == list(xs)
    assert ramp_fraction(-1.0, "cosine") == 0.0 and ramp_fraction(2.0, "linear") == 1.0
    assert np.all(np.diff(cos) > 0)


def test_load_ramp_steps_and_holds():
    a, b = np.zeros(6), np.arange(6.0)
    ramp = LoadRamp(a, b, 4, "linear")
    np.testing.assert_allclose([ramp.at(k) for k in range(4)], [b * (k + 1) / 4 for k in range(4)])
    assert ramp.at(4) is b and ramp.at(100) is b
    assert ramp.changes(4) and not ramp.changes(5)
    step = LoadRamp(a, b, 0)
    assert step.at(0) is b and step.changes(0) and not step.changes(1)


def test_external_wrench_cancels_gravity_and_load():
    w = np.array([0.1, -0.2, 3.0, 0.01, 0.02, -0.03])
    g = np.array([0.0, 0.0, -9.81])
    d = external_wrench(w, 1.2, g)
    np.testing.assert_allclose(d[:3] + w[:3] + 1.2 * g, 0.0, atol=1e-15)
    np.testing.assert_allclose(d[3:], -w[3:])
    c, s = math.cos(0.3), math.sin(0.3)
    R = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
    d_body = external_wrench(w, 1.2, g, R)
    np.testing.assert_allclose(d_body[:3], -(R @ w[:3]) - 1.2 * g)
    np.testing.assert_allclose(d_body[3:], -(R @ w[3:]))
    np.testing.assert_array_equal(external_wrench(w, 1.2, g, np.eye(3)), d)


# -- headroom LP (the oracle's ray_lp) ------------------------------------------------------------
def _headroom_bisection(A, w, w_prev, f_max=1.0, hi=100.0) -> float:
    """Plain reference: bisection on the oracle's exact feasibility test."""
    d = (w - w_prev) / np.linalg.norm(w - w_prev)
    lo = 0.0
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if feasible(A, (w + mid * d)[None], f_max)[0] else (lo, mid)
    return lo


def test_step_headroom_matches_bisection_on_feasibility():
    A = L3.configuration_matrix()
    W = _interior(L3, 4, seed=1)
    for w, w_prev in zip(W[1:], W[:-1]):
        got = step_headroom(A, w, w_prev)
        # feasible() accepts the zonotope scaled by 1 + TOL about its centre: a few TOL apart
        assert got == pytest.approx(_headroom_bisection(A, w, w_prev), abs=20 * TOL)
    assert step_headroom(A, W[0], W[0]) == math.inf
    assert step_headroom(A, 10 * W[0], W[1]) is None


def test_ray_lp_from_origin_is_lambda_ratio():
    A = L3.configuration_matrix()
    W = _interior(L3, 3, seed=2)
    for w in W:
        lam = ray_lp(A, np.zeros(6), w, 0.0, 1.0)
        assert lam / np.linalg.norm(w) == pytest.approx(lambda_ratio(A, w[None])[0], rel=1e-6)


# -- allocator ------------------------------------------------------------------------------------
def test_allocator_exact_inside_and_priorities():
    plant = _plant()
    alloc = Allocator(plant)
    A = plant.A
    w = _interior(L3, 1, seed=3)[0]
    gamma = alloc.recentre(w)
    assert gamma <= 1.0
    u, exact = alloc(w, w, np.zeros(6))
    assert exact and alloc.in_box(u)
    np.testing.assert_allclose(A @ u, w, atol=1e-9)
    np.testing.assert_allclose(alloc.u_ref, u, atol=1e-9)  # the reference itself
    # an impossible position correction is scaled down along its direction; the rest is kept
    w_pos = 50.0 * (A @ np.ones(A.shape[1]))
    u, exact = alloc(w + w_pos, w, np.zeros(6))
    assert not exact and alloc.in_box(u)
    alpha = float((A @ u - w) @ w_pos / (w_pos @ w_pos))
    assert 0.0 <= alpha < 1.0
    np.testing.assert_allclose(A @ u, w + alpha * w_pos, atol=1e-8)
    # an infeasible feed-forward: bounded least squares in acceleration units
    u, exact = alloc(3 * w_pos, 3 * w_pos, np.zeros(6))
    assert not exact and np.all((u >= 0) & (u <= 1.0))
    np.testing.assert_allclose(u, 1.0)  # every rotor flat out towards the unreachable lift
    assert alloc.saturated(u) and not alloc.saturated(np.full(A.shape[1], 0.5))


def test_allocator_interior_projection_finds_exact_allocation():
    plant = _plant()
    alloc = Allocator(plant)
    A = plant.A
    u_true = np.random.default_rng(4).uniform(0.05, 0.95, A.shape[1])
    u_true[0] = 0.999  # near a bound: the pseudo-inverse step around the centre leaves the box
    w = A @ u_true
    u = alloc.exact(w)
    assert u is not None and alloc.in_box(u)
    np.testing.assert_allclose(A @ u, w, atol=1e-8)


# -- estimator ------------------------------------------------------------------------------------
def test_observer_converges_to_the_rotor_wrench_at_rest():
    plant = _plant()
    dt = 0.002
    est = LoadEstimator(plant, omega_obs=40.0, ctrl_dt=dt, w_start=plant.trim)
    np.testing.assert_array_equal(est.estimate, plant.trim)
    u = np.random.default_rng(5).uniform(0.2, 0.8, plant.A.shape[1])
    zero = np.zeros(3)
    for _ in range(50):  # at rest: the needed wrench is A u, filtered at first order
        est.observe(zero, zero)
        est.sent(zero, zero, u, np.eye(3))
    est.observe(zero, zero)
    target = plant.P @ (plant.A @ u)
    expected = target + (1 - (1 - math.exp(-40.0 * dt))) ** 50 * (plant.trim - target)
    np.testing.assert_allclose(est.w_obs, expected, atol=1e-12)


def test_integral_anti_windup():
    plant = _plant()
    alloc = Allocator(plant)
    rate = np.arange(6.0)
    est = LoadEstimator(plant, omega_obs=40.0, ctrl_dt=0.01, w_start=plant.trim)
    est.integrate(rate, exact=False, alloc=alloc)  # saturated: no integration
    np.testing.assert_array_equal(est.w_hat, np.zeros(6))
    est.integrate(rate, exact=True, alloc=alloc)
    np.testing.assert_allclose(est.w_hat, 0.01 * rate)
    # without the observer: integrates while the estimate stays allocatable
    bare = LoadEstimator(plant, omega_obs=0.0, ctrl_dt=0.01, w_start=plant.trim)
    np.testing.assert_array_equal(bare.estimate, plant.trim)
    bare.integrate(1e-3 * plant.trim, exact=False, alloc=alloc)
    np.testing.assert_allclose(bare.w_hat, plant.trim * (1 + 1e-5))
    bare.integrate(1e6 * plant.trim, exact=False, alloc=alloc)  # would leave the feasible set
    np.testing.assert_allclose(bare.w_hat, plant.trim * (1 + 1e-5))


# -- gains ----------------------------------------------------------------------------------------
def test_lqr_stabilises_and_corrections_equal_minus_A_K_x():
    plant = _plant()
    w = _interior(L3, 1, seed=6)[0]
    des = design_gains(plant.A, w, plant.mass, plant.J, HoverGains(), "world", integral=False)
    assert des.kind == LQR and des.K.shape == (plant.A.shape[1], 12)
    F, B = hover_linearization(plant.A, w, plant.mass, plant.J)
    assert np.linalg.eigvals(F - B @ des.K).real.max() < -0.5
    rng = np.random.default_rng(7)
    e_p, theta, v, omega = (rng.normal(scale=0.01, size=3) for _ in range(4))
    w_att, w_pos = corrections(des, plant, HoverGains(), (np.eye(3), e_p, theta, v, omega))
    gyro = plant.P @ np.concatenate([np.zeros(3), np.cross(omega, plant.J @ omega)])
    x = np.concatenate([e_p, theta, v, omega])
    np.testing.assert_allclose(w_att + w_pos, -plant.A @ des.K @ x + gyro, atol=1e-12)


def test_integral_design_and_pd_fallback_on_a_line():
    line = _plant(LINE3)
    w = _interior(LINE3, 1, seed=8, lo=0.3, hi=0.7)[0]
    lqi = design_gains(line.A, w, line.mass, line.J, HoverGains(), "world", integral=True)
    assert lqi.kind == LQR and lqi.C.shape == (5, 6)  # e_p and two pinnable attitude directions
    rate = integral_rate(lqi, line, HoverGains(), np.eye(3), np.full(3, 0.01), np.zeros(3))
    np.testing.assert_allclose(line.P @ rate, rate, atol=1e-12)  # in range(A)
    body = design_gains(line.A, w, line.mass, line.J, HoverGains(), "body", integral=False)
    assert body.kind == PD_FALLBACK
    e_p = np.array([0.01, -0.02, 0.005])
    w_att, w_pos = corrections(body, line, HoverGains(), (np.eye(3), e_p, *np.zeros((3, 3))))
    kp = HoverGains().omega_pos ** 2
    np.testing.assert_allclose(w_att, 0.0, atol=1e-15)
    np.testing.assert_allclose(w_pos, line.P @ np.r_[-line.mass * kp * e_p, 0, 0, 0], atol=1e-12)


def test_controller_holds_a_known_load_at_rest():
    plant = _plant()
    w = _interior(L3, 1, seed=9)[0]
    ctrl = HoverController(plant, HoverConfig(), ctrl_dt=0.002)
    assert ctrl.begin_segment(w) <= 1.0
    zero = np.zeros(3)
    u, w_ff = ctrl.command(w, (np.eye(3), zero, zero, zero, zero))
    assert w_ff is w
    np.testing.assert_allclose(plant.A @ u, w, atol=1e-9)


# -- recorder, rotations --------------------------------------------------------------------------
def test_recorder_metrics_over_the_settled_window():
    segments = [(-1, np.zeros(6), 2), (0, np.ones(6), 4)]
    rec = Recorder(segments, n_rotors=4)
    for k in range(2):
        rec.record(k, 9.0, 9.0, np.full(4, 0.5), np.zeros(6), np.zeros(6), False, k == 1)
    rec.close(-1, 0, 0.5, "lqr", None, cut_short=False, ctrl_dt=1.0, load_estimate_error=None,
              step_headroom=None)  # fmt: skip
    errs = [0.5, 0.4, 0.02, 0.01]
    for k, e in enumerate(errs):
        rec.record(2 + k, e, e / 10, np.full(4, 0.5), np.ones(6), np.ones(6), k == 0, k >= 2)
    rec.close(0, 2, 0.7, "lqr", None, cut_short=False, ctrl_dt=1.0, load_estimate_error=0.1,
              step_headroom=2.0)  # fmt: skip
    m = rec.metrics[1]
    assert m["max_position_error_m"] == 0.02 and m["max_attitude_error_rad"] == 0.002
    assert m["saturated_fraction"] == 0.25 and m["settled_saturated_fraction"] == 0.0
    assert m["step_headroom"] == 2.0 and not m["diverged"] and rec.gamma[0] == 0.7
    res = rec.result(np.ones((1, 6)), HoverConfig(), 1.0, [True])
    assert res.max_position_error == 0.02 and res.settled.sum() == 2  # take-off excluded


def test_recorder_cut_segment_counts_in_full():
    rec = Recorder([(0, np.ones(6), 5)], n_rotors=4)
    for k, e in enumerate([0.1, 0.5, 2.0]):
        rec.record(k, e, 0.0, np.zeros(4), np.ones(6), np.ones(6), True, False)
    cut = drift_reason(2.0, 0.0, HoverConfig())
    assert cut == "position error passed 1 m"
    assert drift_reason(float("nan"), 0.0, HoverConfig()) == "non-finite state"
    rec.close(0, 0, 1.5, "lqr", cut, cut_short=True, ctrl_dt=0.5, load_estimate_error=None,
              step_headroom=None)  # fmt: skip
    m = rec.metrics[0]
    assert m["diverged"] and m["stop_time_s"] == 1.5 and m["max_position_error_m"] == 2.0
    assert rec.diverged[0]


def test_rotation_vector_and_angle_match_scipy():
    from scipy.spatial.transform import Rotation

    rng = np.random.default_rng(10)
    for rv in [np.zeros(3), 1e-14 * np.ones(3), *rng.normal(size=(5, 3))]:
        R = Rotation.from_rotvec(rv).as_matrix()
        np.testing.assert_allclose(rotation_vector(R), rv, atol=1e-9)
        assert rotation_angle(R) == pytest.approx(np.linalg.norm(rv), abs=1e-9)


# -- the run --------------------------------------------------------------------------------------
def test_run_hover_config_and_keywords_agree():
    pytest.importorskip("mujoco")
    from modquad_gym.sim import run_hover

    W = _interior(L3, 2, seed=11, lo=0.3, hi=0.7)
    cfg = HoverConfig(seconds_per_wrench=0.3, takeoff_seconds=0.1, known_load=False,
                      load_ramp_seconds=0.1)  # fmt: skip
    a = run_hover(L3, W, cfg)
    b = run_hover(L3, W, seconds_per_wrench=0.3, takeoff_seconds=0.1, known_load=False,
                  load_ramp_seconds=0.1)  # fmt: skip
    np.testing.assert_array_equal(a.position_error, b.position_error)
    np.testing.assert_array_equal(a.load_estimate, b.load_estimate)
    assert a.segment_metrics == b.segment_metrics and a.load_ramp_seconds == 0.1
    with pytest.raises(ValueError, match="unknown hover option"):
        run_hover(L3, W, cfg, seconds=1.0)
