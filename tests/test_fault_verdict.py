"""The verdict of a flight through a failure (review 23): within 5 cm means it recovered, not
that it had not crashed yet; every failure flown by default, the worst in flight reported."""

from __future__ import annotations

import json

import numpy as np
import pytest

import modquad_gym as mq
from modquad_gym.sim.fault_verdict import SETTLE_WINDOW_S, settling

PLANTED = mq.TaskRequirement.load("examples/planted_seed1.json")
LINE6 = mq.Structure([(i, 0) for i in range(6)])  # its certified rotor-tolerant minimum
SCREWDRIVER = mq.TaskRequirement.load("examples/screwdriver.json")
ROTOR_TOLERANT = mq.Structure([(0, 0), (0, 1), (1, 0), (2, 0)])  # certified, fault="rotor"


def _series(error_of_t, saturated_of_t, end=3.0, dt=0.002):
    t = np.arange(0.0, end, dt)
    return t, error_of_t(t), saturated_of_t(t)


def test_settling_needs_a_falling_error_and_a_rotor_off_its_limits():
    t, e, sat = _series(lambda t: 0.01 * np.exp(-t), lambda t: t < 0.5)
    ok = settling(t, e, sat, 0.0)
    assert ok.settled and not ok.growing and ok.saturated_last == 0.0
    t, e, sat = _series(lambda t: 0.001 * np.exp(t), lambda t: t < 0.5)  # rising, under 5 cm
    rising = settling(t, e, sat, 0.0)
    assert not rising.settled and rising.growing and "error rising" in rising.words()
    t, e, sat = _series(lambda t: 0.01 + 0 * t, lambda t: t >= 0)  # flat but pinned at a limit
    pinned = settling(t, e, sat, 0.0)
    assert not pinned.settled and "at a limit through the last" in pinned.words()
    assert pinned.before_m == pytest.approx(0.01) and pinned.last_m == pytest.approx(0.01)
    t, e, sat = _series(lambda t: 1e-6 * (1 + t), lambda t: t < 0)  # creeping under 0.1 mm
    assert settling(t, e, sat, 0.0).settled
    short = settling(*_series(lambda t: t, lambda t: t < 0, end=SETTLE_WINDOW_S), 0.0)
    assert short.before_m is None and short.settled  # saturation alone judges it


def verdict_agrees_with_its_flight(r: dict) -> None:
    """What a flight's verdict says whatever the flight: held means settled and within 5 cm, and
    a reason is given exactly when it does not hold; a rotor pinned through the last window is
    never settled."""
    assert r["fault_within_5cm"] is (r["fault_settled"] and r["fault_max_position_error_m"] <= 0.05
                                     and r["fault_diverged"] is None)  # fmt: skip
    assert (r["fault_why_not"] is None) is r["fault_within_5cm"]
    if r["fault_last_window_saturated_fraction"] == 1.0:
        assert r["fault_settled"] is False and r["fault_why_not"].startswith("not settled")


def disturbed(r: dict) -> bool:
    """Whether the failure moved the flight at all (more than 1 mm). On the AMD machine these
    cases were found on, rotor 2's loss drifted the line for seconds; on an Intel one the same
    flights moved it by under a micrometre (6.5e-7 m). Likely why: the hover's reference
    allocation is the oracle's most centred one, an LP whose optimal face can hold many
    allocations, and HiGHS may return another vertex on another CPU (as in
    results/paper_rotor_inputs.png's LP panels, tests/test_pictures_readable.py)."""
    return r["fault_max_position_error_m"] > 1e-3


def test_a_flight_still_saturated_and_drifting_at_its_end_does_not_hold():
    """planted_seed1's 6-module line, rotor 2 (column 1: the smallest margin), 20 ms late: on
    the AMD machine within 0.6 cm 2 s after the failure, crashing 4.3 s after it; the verdict
    says not settled."""
    from modquad_gym.sim.fault_flight import fly_with_failure

    f = fly_with_failure(LINE6, PLANTED, "rotor", failure="worst")
    r = f.summary()
    assert r["fault_failed_rotors"] == [1] and r["fault_tolerates"] is True
    assert r["fault_failure"] == "worst" and r["fault_failures_flown"] == 1
    verdict_agrees_with_its_flight(r)
    if not disturbed(r):
        return
    assert r["fault_diverged"] is None and r["fault_max_position_error_m"] <= 0.05
    assert r["fault_settled"] is False and r["fault_within_5cm"] is False
    assert r["fault_why_not"].startswith("not settled")
    assert r["fault_last_window_saturated_fraction"] == 1.0
    assert r["fault_last_window_error_m"] > r["fault_window_before_error_m"]


def test_every_failure_is_flown_and_the_worst_in_flight_reported():
    """The screwdriver's rotor-tolerant design: the smallest-margin failure (rotor 6) is not the
    one that drifts most (rotor 1); flying all reports rotor 1 and its error."""
    from modquad_gym.sim.fault_flight import fly_with_failure

    worst = fly_with_failure(ROTOR_TOLERANT, SCREWDRIVER, "rotor", seconds=1.1, failure="worst")
    every = fly_with_failure(ROTOR_TOLERANT, SCREWDRIVER, "rotor", seconds=1.1)
    r = every.summary()
    assert r["fault_failure"] == "all" and r["fault_failures_flown"] == 16
    errors = [e["max_position_error_m"] for e in r["fault_each"]]
    assert [e["rotors"] for e in r["fault_each"]] == [[k] for k in range(16)]
    assert r["fault_max_position_error_m"] == max(errors)
    assert r["fault_failed_rotors"] == r["fault_each"][int(np.argmax(errors))]["rotors"]
    assert r["fault_failed_rotors"] != list(worst.failure.columns)
    assert r["fault_max_position_error_m"] > worst.max_position_error_m
    one = fly_with_failure(ROTOR_TOLERANT, SCREWDRIVER, "rotor", seconds=1.1,
                           failure=r["fault_failed_rotors"][0] + 1)  # fmt: skip
    assert one.max_position_error_m == pytest.approx(r["fault_max_position_error_m"])
    assert one.summary()["fault_failure"] == r["fault_failed_rotors"][0] + 1
    # the worst margin stays the smallest over the failures (review 23 F3), whichever is flown
    smallest = min(e["margin"] for e in r["fault_each"])
    flown = r["fault_each"][int(np.argmax(errors))]["margin"]
    assert r["fault_worst_margin"] == pytest.approx(smallest) and flown > smallest + 0.05
    assert r["fault_worst_margin"] == pytest.approx(worst.summary()["fault_worst_margin"])
    assert r["fault_flown_margin"] == pytest.approx(flown)
    assert one.summary()["fault_worst_margin"] == pytest.approx(smallest)
    assert one.summary()["fault_flown_margin"] == pytest.approx(flown)
    from modquad_gym.sim.validate_fault import fault_markdown, intact_record

    assert intact_record(every)["worst_fault_margin"] == pytest.approx(smallest)
    assert intact_record(every)["fault_flown_margin"] == pytest.approx(flown)
    page = fault_markdown({**r, "intact_minimum": None, "fault_files": {}}, 4)
    assert "| worst margin | failed | its margin |" in page
    assert f"| yes | {smallest:.3g} | rotor " in page and f"| {flown:.3g} | 1 s |" in page


def test_bad_seconds_and_failure_choices_are_refused_naming_them():
    from modquad_gym.sim.fault_flight import fly_with_failure

    for seconds, words in ((0.001, "at least 1.02 s"), (61.0, "seconds"), (0.0, "seconds")):
        with pytest.raises(ValueError, match=words):
            fly_with_failure(ROTOR_TOLERANT, SCREWDRIVER, "rotor", seconds=seconds)
    for choice, words in ((0, "1..16"), (17, "1..16"), ("best", "'all', 'worst'"),
                          (True, "failure = True")):  # fmt: skip
        with pytest.raises(ValueError, match=words):
            fly_with_failure(ROTOR_TOLERANT, SCREWDRIVER, "rotor", failure=choice)
    with pytest.raises(ValueError, match="module number must lie in 1..4"):
        fly_with_failure(ROTOR_TOLERANT, SCREWDRIVER, "module", failure=5)
    with pytest.raises(ValueError, match="failure = 3"):
        fly_with_failure(ROTOR_TOLERANT, SCREWDRIVER, "rotor2", failure=3)


def _argv(tmp_path, *extra):
    return ["validate", "--task", "examples/screwdriver.json", "--out", str(tmp_path / "out"),
            "--max-hover-wrenches", "1", "--hover-seconds", "0.5", "--known-load-only",
            *extra]  # fmt: skip


def test_cli_fault_seconds_and_failure_refusals(tmp_path, capsys):
    from modquad_gym.cli import main

    for extra, words in ((["--fault", "rotor", "--fault-seconds", "0.5"], "[1.02, 60]"),
                         (["--fault", "rotor", "--fault-seconds", "61"], "--fault-seconds 61"),
                         (["--fault-seconds", "2"], "--fault-seconds"),
                         (["--failure", "worst"], "--failure"),
                         (["--fault", "rotor2", "--failure", "3"], "--failure 3")):  # fmt: skip
        assert main(_argv(tmp_path, *extra)) == 2
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and words in err, (extra, err)
    with pytest.raises(SystemExit) as exc:
        main(_argv(tmp_path, "--fault", "rotor", "--failure", "0"))
    assert exc.value.code == 2 and "--failure" in capsys.readouterr().err
    assert not (tmp_path / "out").exists()


def test_cli_numbered_failure_is_the_one_flown(tmp_path, capsys):
    from modquad_gym.cli import main

    argv = _argv(tmp_path, "--fault", "rotor", "--failure", "6", "--fault-seconds", "1.1",
                 "--json")  # fmt: skip
    assert main(argv) == 0
    record = json.loads(capsys.readouterr().out.strip().splitlines()[-1])
    assert record["fault_failed_rotors"] == [5] and record["fault_failure"] == 6
    assert record["intact_minimum"]["fault_failure"] == "worst"
    report = (tmp_path / "out" / "report.md").read_text()
    assert "(--failure 6)" in report and "| holds |" in report


def test_failure_fields_are_checked_naming_them():
    from modquad_gym import dynamics as dy
    from modquad_gym.sim.failure import Failure, flown_delay
    from modquad_gym.sim.fault_flight import hover_with_failure
    from modquad_gym.sim.track import fly_trajectory

    for columns, words in (((-1,), "columns: each must be an int"), ((1.7,), "got 1.7"),
                           ((1, 1), "a rotor given twice"), ((True,), "got True"),
                           ((), "columns is empty"),
                           (3, "columns must be a sequence")):  # fmt: skip
        with pytest.raises(ValueError, match=words):
            Failure(columns, 1.0, 0.0)
    with pytest.raises(ValueError, match="kind must be one of"):
        Failure((1,), 1.0, 0.0, "banana")
    assert str(Failure((1,), 1.0, -0.0).detection_delay_s) == "0.0"
    assert str(flown_delay(-0.0, None)) == "0.0"
    with pytest.raises(
        ValueError, match=r"rotor 99 is not one of the structure's 16 rotors \(0..15\)"
    ):
        hover_with_failure(ROTOR_TOLERANT, SCREWDRIVER.wrenches[0], Failure((99,), 0.5), 1.0)
    tolerant = mq.Structure([(0, 0), (1, 0), (1, 1)])
    with pytest.raises(ValueError, match=r"rotor 12 is not one of the structure's 12 rotors"):
        fly_trajectory(tolerant, dy.circle(speed=1.0, laps=0.25), failure=Failure((12,), 0.5))


def test_a_rotor_pinned_while_the_error_is_not_growing_is_said_so_with_the_remedy():
    """Judged not settled only for a rotor at a limit through the last window, the error not
    growing: the words say so and point to a longer flight (review 23 F1)."""
    t, e, sat = _series(lambda t: 0.01 + 0 * t, lambda t: t >= 0)  # flat, pinned at a limit
    pinned = settling(t, e, sat, 1.0)
    assert pinned.pinned_only and "(error not growing)" in pinned.words()
    assert pinned.words().startswith("not settled within 2 s: a working rotor still at a limit")
    t, e, sat = _series(lambda t: 0.001 * np.exp(t), lambda t: t >= 0)  # rising and pinned
    rising = settling(t, e, sat, 0.0)
    assert not rising.pinned_only and "not growing" not in rising.words()
    assert "still" not in rising.words()


def test_a_slow_recovery_cut_short_names_the_longer_flight_as_the_remedy():
    """planted_seed1's line, rotor 2 failing, 8 ms late: on the AMD machine saturated to 5 s
    after the failure, then settling (the review's 6 and 12 s flights hold); flown 3 s it is not
    settled, and says why."""
    from modquad_gym.sim.fault_flight import fly_with_failure

    r = fly_with_failure(LINE6, PLANTED, "rotor", failure=2, detection_delay_s=0.008,
                         seconds=3.0).summary()  # fmt: skip
    verdict_agrees_with_its_flight(r)
    if not disturbed(r):
        return
    assert r["fault_within_5cm"] is False and r["fault_last_window_saturated_fraction"] == 1.0
    assert r["fault_why_not"].startswith("not settled within 3 s: a working rotor still at a")
    assert "(error not growing); a longer --fault-seconds" in r["fault_why_not"]
