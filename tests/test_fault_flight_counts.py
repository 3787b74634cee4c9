"""validate --fault counts the flights it will fly (every failure under --failure all) in its
up-front time check, and checks --failure K against the structure's size before any work it can
(review 23 flightnew F2, F5)."""

from __future__ import annotations

import argparse
import json

import pytest

import modquad_gym as mq
from modquad_gym.cli import validate_fault as vf

SCREWDRIVER = mq.TaskRequirement.load("examples/screwdriver.json")


def _args(**kw) -> argparse.Namespace:
    base = dict(fault="rotor2", failure="all", fault_margin=None, detection_delay=None,
                fault_seconds=None, n_max=7, modules=None, cells=None, task="t",
                allow_long=False)  # fmt: skip
    return argparse.Namespace(**{**base, **kw})


def test_the_failure_count_is_the_flights_count():
    from modquad_gym.sim.fault_flight import failure_columns

    for n in (1, 2, 5):
        s = mq.Structure([(i, 0) for i in range(n)])
        for fault in ("rotor", "module", "rotor2", "rotor+module"):
            assert vf.failures_at(fault, n) == len(failure_columns(s, fault)), (fault, n)


def test_the_up_front_estimate_counts_every_failure_flown():
    """screwdriver, rotor2, --failure all: both designs fly every pair of rotors of a structure
    of at least the force bound's size; --failure worst flies one each."""
    args = _args()
    n = vf.least_modules(args, SCREWDRIVER)
    assert 1 < n <= args.n_max
    pairs = vf.failures_at("rotor2", n)
    one = vf._flight_seconds(args, SCREWDRIVER)
    assert vf.fault_flights(args, n) == 2 * pairs
    assert vf.fault_seconds(args, SCREWDRIVER, n) == pytest.approx(2 * pairs * one)
    assert vf.fault_flights(_args(failure="worst"), n) == 2
    assert vf.fault_flights(_args(fault="rotor", failure=3), n) == 2  # K, then the worst


def _big_task(tmp_path):
    """A static task no fewer than 16 modules tolerate rotor2 for: its flights run past an hour."""
    path = tmp_path / "heavy.json"
    path.write_text(json.dumps({"name": "heavy", "f_max": 1.0,
                                "wrenches": [[0, 0, 40.0, 0, 0, 0]]}))  # fmt: skip
    return str(path)


def _no_search(monkeypatch):
    from modquad_gym.cli import solve

    def solver(*a, **k):
        raise AssertionError("searched")

    monkeypatch.setattr(solve, "solver", solver)


def test_a_run_whose_flights_run_too_long_is_refused_before_any_search(
    tmp_path, capsys, monkeypatch
):
    from modquad_gym.cli import main

    _no_search(monkeypatch)
    out = tmp_path / "out"
    argv = ["validate", "--task", _big_task(tmp_path), "--fault", "rotor2", "--n-max", "16",
            "--out", str(out), "--known-load-only", "--max-hover-wrenches", "1"]  # fmt: skip
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "flights through a rotor2 failure" in err, err
    assert "--failure worst" in err and "--allow-long" in err and not out.exists()


def test_a_numbered_failure_beyond_any_structure_is_refused_before_any_search(
    tmp_path, capsys, monkeypatch
):
    from modquad_gym.cli import main

    _no_search(monkeypatch)
    base = ["validate", "--task", "examples/screwdriver.json", "--out", str(tmp_path / "o")]
    assert main([*base, "--fault", "rotor", "--failure", "29"]) == 2  # 4 * 7 = 28 rotors
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "--failure 29" in err and "--n-max 7" in err, err
    assert main([*base, "--fault", "module", "--failure", "8"]) == 2
    assert "--failure 8" in capsys.readouterr().err


def test_a_numbered_failure_beyond_the_structure_found_is_refused_before_the_bench(
    tmp_path, capsys
):
    """The screwdriver's rotor design has 16 rotors: --failure 17 passes the --n-max check, is
    refused once the search has found it, and nothing is written."""
    from modquad_gym.cli import main

    out = tmp_path / "out"
    argv = ["validate", "--task", "examples/screwdriver.json", "--out", str(out),
            "--fault", "rotor", "--failure", "17", "--known-load-only"]  # fmt: skip
    assert main(argv) == 2
    err = capsys.readouterr().err.strip().splitlines()[-1]
    assert "--failure 17: the structure found has 16 rotors, numbered 1..16" in err, err
    assert not (out / "report.md").exists() and not (out / "validation.json").exists()


def test_the_flights_of_the_structure_found_are_checked_against_the_limit():
    """16 rotor failures of the found structure, and as many assumed for the intact minimum."""
    s = mq.Structure([(0, 0), (0, 1), (1, 0), (2, 0)])
    args = _args(fault="rotor")
    with pytest.raises(ValueError, match=r"32 flights .*\(--failure worst\) or give --allow-long"):
        vf.check_found(args, SCREWDRIVER, s, limit=1.0)
    vf.check_found(_args(fault="rotor", allow_long=True), SCREWDRIVER, s, limit=1.0)
    vf.check_found(args, SCREWDRIVER, s, limit=3600.0)
