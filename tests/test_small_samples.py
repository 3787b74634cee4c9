"""Intervals over too few values: the bootstrap interval's edge inputs, and how every report that
prints intervals shows one run, seed or task (no interval, no goal judged on one) and a seed
left out."""

from __future__ import annotations

import math

import numpy as np
import pytest

from modquad_gym.scoring.stats import interval, iqm, mean


def _mean(x):
    return float(np.mean(x))


def test_one_value_has_no_interval_and_a_stratum_of_one_is_not_an_error():
    """One value (one seed) gives the point with NaN bounds, not a zero-width "95 % CI"; a
    stratum of one beside a longer one (a seed missing from a suite) likewise, not scipy's
    error."""
    point, low, high = interval([np.array([0.5])], _mean)
    assert point == 0.5 and math.isnan(low) and math.isnan(high)
    point, low, high = interval([np.array([0.5]), np.array([0.2, 0.4])], iqm)
    assert point == pytest.approx(iqm(np.array([0.5, 0.2, 0.4])))
    assert math.isnan(low) and math.isnan(high)
    point, low, high = interval([np.array([0.5]), np.array([0.7])], _mean)  # one seed, 2 suites
    assert point == pytest.approx(0.6) and math.isnan(low) and math.isnan(high)
    assert interval([np.array([0.3, 0.3])], _mean) == (0.3, 0.3, 0.3)  # two seeds that agree


@pytest.mark.parametrize(
    "columns, words",
    [
        ([], "columns: no column of scores"),
        ([np.array([])], "columns: column 1 of 1 holds no value"),
        ([np.array([0.5, 0.6]), np.array([])], "columns: column 2 of 2 holds no value"),
        ([np.array([0.5, np.nan, 0.3])], "columns: column 1 of 1: value 2 is nan"),
        ([np.array([0.1, 0.2]), np.array([0.5, np.inf])], "column 2 of 2: value 2 is inf"),
    ],
)
def test_bad_columns_are_one_line_naming_the_column(columns, words):
    with pytest.raises(ValueError) as exc:
        interval(columns, _mean)
    assert words in str(exc.value) and "\n" not in str(exc.value)


def test_the_rl_stage_gains_of_one_run_print_no_interval():
    from benchmarks.rl_stage import GAINS, gains

    cols = {c for pair in GAINS.values() for c in pair}
    row = {c: 0.9 for c in cols} | {"held-out optimal, kept": 0.85}
    table = {g["gain (over cloned)"]: g for g in gains([row])}
    assert table["held-out optimal"]["95 % CI"] == "n/a (1 run)"
    assert table["held-out optimal"]["mean"] == "-5.00 pt"
    assert all(g["95 % CI"] == "n/a (1 run)" for g in table.values())


def test_the_rl_stage_gains_of_two_runs_print_their_range_not_an_interval():
    """Two runs' percentile bootstrap is their range (about half coverage): no 95 % CI."""
    from benchmarks.rl_stage import GAINS, gains

    cols = {c for pair in GAINS.values() for c in pair}
    rows = [{c: 0.9 for c in cols} | {"held-out optimal, kept": k} for k in (0.87, 0.91)]
    table = {g["gain (over cloned)"]: g for g in gains(rows)}
    assert table["held-out optimal"]["95 % CI"] == "n/a (2 runs)"
    assert table["held-out optimal"]["per run"] == "-3.0 +1.0"


def _scale_rows(found_by_seed: dict[str, list[int | None]]) -> list[dict]:
    """Rows of :mod:`benchmarks.scale_seeds` for band 16: greedy solves three tasks with 10
    modules; each seed's answers (None: not solved)."""
    tasks = ["t0", "t1", "t2"]
    rows = [{"band": 16, "family": "planted", "task": t, "method": "greedy", "seed": "",
             "found": 10, "seconds": 1.0} for t in tasks]  # fmt: skip
    for seed, found in found_by_seed.items():
        rows += [{"band": 16, "family": "planted", "task": t, "method": "ppo", "seed": seed,
                  "found": f, "seconds": 0.5} for t, f in zip(tasks, found)]  # fmt: skip
    return rows


def test_scale_seeds_counts_a_seed_it_leaves_out_and_gives_one_seed_no_interval():
    """A seed that solves none of greedy's tasks has no module difference: the band's figure
    says over how many seeds it is (it said nothing, while the row said seeds = 5)."""
    from benchmarks.scale_seeds import band_summary

    rows = _scale_rows({"0": [10, 11, 10], "1": [None, None, None], "2": [11, 11, 10]})
    summary = band_summary(rows, 16)
    assert summary["seeds"] == 3
    assert summary["ppo_minus_greedy_modules"].endswith(" (2 of 3 seeds)")
    assert "of" not in summary["ppo_over_greedy_seconds"]  # every seed has a time
    one = band_summary(_scale_rows({"0": [10, 11, 10], "1": [None, None, None]}), 16)
    assert one["ppo_minus_greedy_modules"] == "+0.33 n/a (1 seed) (1 of 2 seeds)"


def test_scale_seeds_refuses_one_seed_folder(tmp_path):
    from benchmarks.scale_seeds import seed_models

    (tmp_path / "seed-0").mkdir()
    (tmp_path / "seed-0" / "model.zip").write_bytes(b"")
    with pytest.raises(ValueError, match=r"^--runs: 1 seed \(.*seed-0\); .* at least 2"):
        seed_models(tmp_path, "--runs")


def test_a_difference_over_one_task_shows_no_interval_but_is_still_judged():
    """scale_models, prune and fallback: a family and band cell where one task is answered by
    both has no interval (NaN bounds, shown as n/a); the prune goal judges it on that task's
    difference."""
    from benchmarks.prune import _listed, goal_lines
    from benchmarks.scale_models import shown, versus_greedy

    rows = [{"band": 16, "family": "planted", "task": "t0", "method": m, "found": f,
             "seconds": 1.0} for m, f in (("greedy", 10), ("ppo", 11))]  # fmt: skip
    v = versus_greedy(rows, "ppo")
    assert v["minus_greedy_modules"] == 1 and math.isnan(v["low"]) and math.isnan(v["high"])
    assert shown([v])[0]["low"] == "n/a (1 task)"
    cell = {"method": "ppo", "rival": "greedy", "band": 16, "family": "planted", "missed": 0,
            "both": 1, "difference": 1.0, "low": v["low"], "high": v["high"]}  # fmt: skip
    assert _listed([cell]) == ": planted-16 (+1 n/a (1 task), missed 0)"
    assert goal_lines([cell])[0].endswith("NOT met")  # one task worse is worse


def test_the_coverage_of_two_seeds_is_about_half():
    """The simulation behind docs/benchmarks.md's warning: with 2 seeds the interval is the
    range of the two values, which holds the true mean half the time."""
    from benchmarks.interval_coverage import coverage

    row = coverage(2, 200, mean, np.random.default_rng(1))  # the benchmark's aggregate
    assert 35 <= row["coverage_pct"] <= 65 and row["trials"] == 200
