"""The failure detector in the flight (issue 47): a momentum observer on noisy velocity and body
rate decides when and which rotors failed; the allocator switches on its decision."""

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
    f = ff.fly_with_failure(s, task, "rotor", seconds=3.0, detector=DetectorConfig())
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
    f = ff.fly_with_failure(s, task, "rotor", seconds=3.0, detector=noiseless)
    assert f.summary()["fault_detected_rotors"] == list(f.worst.columns)


def test_validate_designs_for_the_delay_and_flies_with_the_detector(tmp_path, capsys):
    import json

    from modquad_gym.cli import main

    argv = ["validate", "--task", "example:screwdriver", "--out", str(tmp_path / "out"),
            "--max-hover-wrenches", "1", "--hover-seconds", "0.5", "--known-load-only",
            "--fault", "rotor", "--detection-delay", "0.05", "--detect", "--json"]  # fmt: skip
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
        ff.fly_with_failure(s, task, "rotor", detector=DetectorConfig(), detection_delay_s=0.04)
    flown = ff.fly_with_failure(s, task, "rotor", seconds=1.0, detection_delay_s=0.04)
    assert flown.summary()["fault_detection_delay_s"] == 0.04 and "fault_detected_after_s" not in (
        flown.summary()
    )


def test_the_detector_flies_a_trajectory_with_a_payload():
    from pathlib import Path

    from modquad_gym.tasks.suites import load_suite

    suite = Path(mq.__file__).parent / "data" / "suites" / "dynamic_motions.json"
    task = load_suite(suite)[1]  # carries a payload off the structure's centre
    assert task.payload is not None
    s = mq.anytime_search(task, n_max=8, time_limit=10, fault="rotor").structure
    f = ff.fly_with_failure(s, task, "rotor", detector=DetectorConfig())
    record = f.summary()
    assert 0.0 < record["fault_detected_after_s"] <= 0.03
    assert record["fault_detected_rotors"] == list(f.worst.columns) and f.within_goal
