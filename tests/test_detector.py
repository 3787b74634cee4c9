"""The failure detector in the flight (issue 47): a momentum observer on noisy velocity and body
rate decides when and which rotors failed; the allocator switches on its decision."""

import re

import pytest

import modquad_gym as mq
from modquad_gym.oracle.fault_delay import margin_for_delay
from modquad_gym.sim import fault_flight as ff
from modquad_gym.sim.detector import DetectorConfig, SensorNoise
from modquad_gym.sim.failure import Failure
from modquad_gym.tasks import load_task


@pytest.fixture(scope="module")
def screwdriver():
    task = load_task("example:screwdriver")
    s = mq.exhaustive_search(task, n_max=7, fault="rotor").structure
    return task, s


def test_the_detector_names_the_failed_rotor_within_30_ms(screwdriver):
    task, s = screwdriver
    f = ff.fly_with_failure(
        s, task, "rotor", failure="worst", seconds=3.0, detector=DetectorConfig()
    )
    record = f.summary()
    assert 0.0 < record["fault_detected_after_s"] <= 0.03
    assert record["fault_detected_rotors"] == list(f.worst.columns)
    assert f.within_goal


def test_no_false_alarm_in_an_intact_hover_with_sensor_noise(screwdriver):
    task, s = screwdriver
    W = task.rotor_wrenches(s)
    worst = ff.worst_failure(s, W, task.f_max, "rotor")
    never = Failure((0,), 1e9, 0.0, "rotor")
    for seed in (0, 1):
        noisy = (DetectorConfig(), SensorNoise(seed=seed))
        run = ff.hover_with_failure(s, W[worst.row], never, 10.0, task.f_max, detector=noisy)
        assert run.detection is None
        assert 0.0 < run.detector.peak  # the noise is on


def test_without_noise_the_residual_is_the_missing_thrust(screwdriver):
    task, s = screwdriver
    noiseless = (DetectorConfig(), SensorNoise(0.0, 0.0))
    f = ff.fly_with_failure(s, task, "rotor", failure="worst", seconds=3.0, detector=noiseless)
    assert f.summary()["fault_detected_rotors"] == list(f.worst.columns)


def test_validate_designs_for_the_delay_and_flies_with_the_detector(tmp_path, capsys):
    import json

    from modquad_gym.cli import main

    argv = ["validate", "--task", "example:screwdriver", "--out", str(tmp_path / "out"),
            "--max-hover-wrenches", "1", "--hover-seconds", "0.5", "--known-load-only",
            "--fault", "rotor", "--detection-delay", "0.05", "--detect", "--json",
            "--failure", "worst"]  # fmt: skip
    assert main(argv) == 0
    record = json.loads(capsys.readouterr().out.strip().splitlines()[-1])
    assert record["fault_margin_required"] == pytest.approx(margin_for_delay(0.05))
    assert record["fault_worst_margin"] >= margin_for_delay(0.05) - 1e-6
    assert 0.0 < record["fault_detected_after_s"] <= 0.03 and record["fault_within_5cm"]
    assert record["without_margin"]["n_modules"] <= record["n_modules"]
    # the delay flown is the detector's, not --detection-delay's: the record and report say so
    assert record["fault_detection_delay_s"] is None and record["fault_margin_delay_s"] == 0.05
    assert record["without_margin"]["fault_detection_delay_s"] is None
    report = (tmp_path / "out" / "report.md").read_text()
    assert "0.05 s later" not in report and "the delay flown is the detector's" in report
    assert f"| {record['fault_detected_after_s']:.3g} s (detector) |" in report
    bad = ["validate", "--task", "example:screwdriver", "--out", str(tmp_path / "o2"), "--detect"]
    assert main(bad) == 2
    assert "--detect" in capsys.readouterr().err


def test_a_delay_beside_the_detector_is_refused_not_reported(screwdriver):
    """The detector decides when the controller knows: a detection_delay_s beside it would be
    reported as flown while it was not."""
    task, s = screwdriver
    with pytest.raises(ValueError, match="detection_delay_s = 0.04: not flown with a detector"):
        ff.fly_with_failure(
            s, task, "rotor", failure="worst", detector=DetectorConfig(), detection_delay_s=0.04
        )
    flown = ff.fly_with_failure(
        s, task, "rotor", failure="worst", seconds=1.1, detection_delay_s=0.04
    )
    assert flown.summary()["fault_detection_delay_s"] == 0.04 and "fault_detected_after_s" not in (
        flown.summary()
    )


def test_the_detector_flies_a_trajectory_with_a_payload():
    from pathlib import Path

    from modquad_gym.tasks.suites import load_suite

    suite = Path(mq.__file__).parent / "data" / "suites" / "dynamic_motions.json"
    task = load_suite(suite)[1]  # carries a payload off the structure's centre
    assert task.payload is not None
    # anytime_search(task, n_max=8, time_limit=10, fault="rotor")'s certified answer on an Intel
    # machine, given here: the search's answer under a busy machine's time limit is not fixed
    s = mq.Structure([(0, 0), (0, 1), (1, 0), (2, 0)])
    f = ff.fly_with_failure(s, task, "rotor", failure="worst", detector=DetectorConfig())
    record = f.summary()
    assert 0.0 < record["fault_detected_after_s"] <= 0.03
    assert record["fault_detected_rotors"] == list(f.worst.columns) and f.within_goal


def _fly_a_rotor_failure(A, failed: int, decide_first: int, steps: int = 200, revise=True):
    """A rigid body (level, unit inertia, no gravity, noiseless sensors) whose rotor ``failed``
    stops at step 10 while the controller commands every rotor it believes working at half
    thrust; the detector's decisions (time, set) in order."""
    import numpy as np

    from modquad_gym.oracle.faults import failure_sets
    from modquad_gym.sim.detector import FailureDetector

    m, dt, mass = A.shape[1], 0.002, 2.0
    watch = FailureDetector(A, mass, np.eye(3), 1.0, failure_sets(m, "rotor"), dt,
                            DetectorConfig(revise=revise), SensorNoise(0.0, 0.0))  # fmt: skip
    v, omega, believed, decisions = np.zeros(3), np.zeros(3), None, []
    for k in range(steps):
        u = np.full(m, 0.5)
        if believed is not None:
            u[believed] = 0.0
        actual = u.copy()
        if k >= 10:
            actual[failed] = 0.0
        hit = watch.update(k * dt, np.eye(3), v, omega, u, np.zeros(6), np.zeros(3))
        if hit is not None:
            believed = list(hit[1])
            decisions.append((k, believed))
        wrench = A @ actual
        v, omega = v + wrench[:3] / mass * dt, omega + wrench[3:] * dt
    assert decisions[0][1] == [decide_first]  # the case the test is about
    return watch, decisions


def test_a_wrong_isolation_is_revised_when_the_residual_does_not_fall():
    """Two rotors with the same column of A: the first decision names the lower one (a tie),
    the dead one still gets its command and the residual stays; the detector then names the
    dead one, and once it is dropped the residual falls and nothing more is decided."""
    import numpy as np

    A0 = mq.Structure([(0, 0), (1, 0)]).configuration_matrix()
    A = np.hstack([A0, A0[:, :1]])  # rotor 8 acts as rotor 0
    watch, decisions = _fly_a_rotor_failure(A, failed=8, decide_first=0)
    assert [d[1] for d in decisions] == [[0], [8]]
    assert watch.detected[0] == decisions[0][0] * 0.002  # when it first decided
    assert list(watch.detected[1]) == [8]  # what it names in the end
    _, decisions = _fly_a_rotor_failure(A, failed=8, decide_first=0, revise=False)
    assert [d[1] for d in decisions] == [[0]]  # the first decision stands


def test_a_right_isolation_is_kept():
    watch, decisions = _fly_a_rotor_failure(
        mq.Structure([(0, 0), (1, 0)]).configuration_matrix(), failed=5, decide_first=5
    )
    assert len(decisions) == 1 and list(watch.detected[1]) == [5]


def test_a_margin_design_of_motions_9500001_stays_within_5_cm_with_the_detector():
    """Review 18's case: the detector first names another rotor where rotor 29 failed (their
    missing wrenches point almost the same way); it must not keep the working rotor out and the
    dead one in. Rotor 29 is flown by number: four rotors leave the smallest margin within
    3e-15 of each other, so which of them ``failure="worst"`` picks is the CPU's rounding (29 on
    the AMD machine the case was found on, 14 on an Intel one)."""
    from modquad_gym.scoring.suites import draw_task
    from modquad_gym.tasks import make_generator

    task = draw_task(make_generator("motions"), 9_500_001, "motions-9500001")
    cells = [(0, 1), (0, 2), (0, 3), (0, 4), (1, 0), (1, 1), (1, -1), (0, -1), (1, 4)]
    s = mq.Structure(cells)  # anytime_search's certified answer for a required margin 0.1025
    W = task.rotor_wrenches(s)
    assert mq.fault_margin(s, W, task.f_max, fault="rotor").min() == pytest.approx(0.1027, abs=1e-4)
    f = ff.fly_with_failure(s, task, "rotor", failure=29, detector=DetectorConfig())
    record = f.summary()
    assert record["fault_detected_rotors"] == list(f.worst.columns)
    assert f.within_goal and record["fault_saturated_fraction"] < 0.1
    from modquad_gym.sim.validate_fault import fault_markdown  # the report says when it revised

    told = "".join(f"; revised at {t:.3g} s" for t, _ in record["fault_detector_decisions"][1:])
    page = fault_markdown(record)
    assert f"| {record['fault_detected_after_s']:.3g} s (detector{told}) |" in page
    # kept at its first (wrong) decision, it asks the dead rotor for thrust and leaves a
    # working one out: saturated nearly throughout, it leaves 5 cm (docs/faults.md)
    kept = ff.fly_with_failure(s, task, "rotor", failure=29, detector=DetectorConfig(revise=False))
    first = kept.summary()
    assert len(first["fault_detector_decisions"]) == 1
    assert first["fault_detected_rotors"] != list(kept.worst.columns)
    assert not kept.within_goal and first["fault_saturated_fraction"] > 0.9


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"persistence": 0}, "DetectorConfig.persistence must be >= 1, got 0"),
        ({"persistence": 2.5}, "DetectorConfig.persistence must be an integer, got 2.5"),
        ({"persistence": True}, "DetectorConfig.persistence must be an integer, got True"),
        ({"bandwidth": -1.0}, "DetectorConfig.bandwidth must be positive, got -1"),
        ({"bandwidth": float("inf")}, "DetectorConfig.bandwidth must be finite, got inf"),
        ({"threshold": float("nan")}, "DetectorConfig.threshold must be finite, got nan"),
        ({"threshold": "0.1"}, "DetectorConfig.threshold must be a real number, got '0.1'"),
        ({"z": 0}, "DetectorConfig.z must be positive, got 0"),
        ({"revise": 1}, "DetectorConfig.revise must be True or False, got 1"),
    ],
)
def test_a_detector_config_out_of_its_domain_is_refused(kwargs, match):
    with pytest.raises(ValueError, match=re.escape(match)):
        DetectorConfig(**kwargs)


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"velocity": -0.001}, "SensorNoise.velocity must be >= 0, got -0.001"),
        ({"rate": float("nan")}, "SensorNoise.rate must be finite, got nan"),
        ({"seed": -1}, "SensorNoise.seed must be >= 0, got -1"),
        ({"seed": 1.5}, "SensorNoise.seed must be an integer, got 1.5"),
    ],
)
def test_sensor_noise_out_of_its_domain_is_refused(kwargs, match):
    with pytest.raises(ValueError, match=re.escape(match)):
        SensorNoise(**kwargs)


def test_a_bandwidth_past_the_control_rate_or_a_detector_of_another_type_is_refused(
    screwdriver,
):
    task, s = screwdriver
    with pytest.raises(ValueError, match=re.escape("at most 1 / control period = 500 /s")):
        ff.fly_with_failure(
            s, task, "rotor", failure="worst", seconds=1.1, detector=DetectorConfig(bandwidth=600)
        )
    for bad in ("yes", (DetectorConfig(),), (DetectorConfig(), None)):
        with pytest.raises(ValueError, match="detector must be a DetectorConfig or a"):
            ff.fly_with_failure(s, task, "rotor", failure="worst", seconds=1.1, detector=bad)
