"""Results over training seeds: the IQM, the stratified bootstrap interval, the report."""

from __future__ import annotations

import csv
import dataclasses
import shutil
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from modquad_gym.policy import DEFAULT_MODEL
from modquad_gym.policy.models import shipped_model
from modquad_gym.scoring.agents import SEARCH_METHODS
from modquad_gym.scoring.seed_scores import SeedScore, summary
from modquad_gym.scoring.seeds import main
from modquad_gym.scoring.seeds_report import goal_lines
from modquad_gym.scoring.stats import interval, iqm


def test_iqm_is_the_mean_of_the_middle_half():
    assert iqm(np.arange(8.0)) == pytest.approx(np.mean([2, 3, 4, 5]))
    assert iqm(np.array([0.0, 1, 1, 1, 100])) == pytest.approx(1.0)  # an outlier seed
    assert iqm(np.array([[1.0, 2], [3, 4]])) == pytest.approx(2.5)  # pools seeds x suites


@settings(max_examples=25, deadline=None)
@given(st.lists(st.lists(st.floats(-1e3, 1e3), min_size=2, max_size=30), min_size=1,
                max_size=3), st.integers(0, 99))  # fmt: skip
def test_the_one_pass_bootstrap_gives_the_per_resample_interval(columns, seed):
    """iqm and the mean are bootstrapped in one call over every resample (stats.ROWS): the same
    interval, to the bit, as one call per resample (an aggregate it does not know: a lambda)."""
    from modquad_gym.scoring.stats import mean

    cols = [np.array(c) for c in columns]
    for aggregate in (iqm, mean, np.mean):
        per_resample = lambda x, f=aggregate: f(x)  # noqa: E731
        got = interval(cols, aggregate, reps=200, seed=seed)
        assert got == interval(cols, per_resample, reps=200, seed=seed), aggregate


@settings(max_examples=25, deadline=None)
@given(st.lists(st.floats(0, 1), min_size=3, max_size=8), st.lists(st.floats(0, 1), min_size=3,
       max_size=8))  # fmt: skip
def test_interval_brackets_the_point_and_stays_in_the_data_range(a, b):
    point, low, high = interval([np.array(a), np.array(b)], lambda x: float(np.mean(x)), reps=200)
    assert point == pytest.approx(np.mean(a + b))
    lo, hi = min(a + b), max(a + b)
    assert lo - 1e-12 <= low <= high <= hi + 1e-12


def test_interval_is_stratified_by_suite():
    """Resampling within each suite keeps both suites in every resample: a suite always at 0
    and one always at 1 give a pooled mean of exactly 0.5 (unstratified resampling would not)."""
    cols = [np.zeros(5), np.ones(5)]
    assert interval(cols, lambda x: float(np.mean(x)), reps=300) == (0.5, 0.5, 0.5)
    noisy = [np.array([0.0, 0.1, 0.2, 0.1, 0.0]), np.array([0.9, 1.0, 0.8, 1.0, 0.9])]
    point, low, high = interval(noisy, lambda x: float(np.mean(x)), reps=500)
    assert 0.44 < low < point < high < 0.56


def rliable_interval(scores: np.ndarray, reps: int, seed: int) -> tuple[float, float, float]:
    """rliable's definitions written out (``metrics.aggregate_iqm`` and
    ``library.get_interval_estimates`` with ``StratifiedBootstrap``, percentile method, no task
    bootstrap): scores (runs x tasks), runs resampled with replacement within each task, the
    IQM of the whole resampled matrix, the 2.5 and 97.5 percentiles."""
    from scipy import stats

    rng = np.random.default_rng(seed)
    runs, tasks = scores.shape
    rows = rng.integers(0, runs, size=(reps, runs, tasks))
    draws = stats.trim_mean(scores[rows, np.arange(tasks)].reshape(reps, -1), 0.25, axis=1)
    point = float(stats.trim_mean(scores, 0.25, axis=None))
    return point, float(np.percentile(draws, 2.5)), float(np.percentile(draws, 97.5))


def test_iqm_and_interval_follow_rliables_definitions():
    """Five seeds x three suites: the same IQM exactly, the same interval within the Monte Carlo
    error of 2000 resamples each (rliable itself is not a dependency: it pulls arch, pandas,
    seaborn and absl for these twenty lines)."""
    scores = np.random.default_rng(3).beta(8, 2, size=(5, 3))
    columns = [scores[:, j] for j in range(3)]
    point, low, high = interval(columns, iqm, reps=2000, seed=1)
    ref_point, ref_low, ref_high = rliable_interval(scores, reps=2000, seed=2)
    assert point == ref_point
    assert low == pytest.approx(ref_low, abs=0.01) and high == pytest.approx(ref_high, abs=0.01)
    assert high - low > 0.05  # a real interval, not a degenerate one


def _score(seed, method, suite, success, optimal, evaluated=5.0, seconds=0.01):
    return SeedScore(str(seed), method, suite, 10, success, optimal, evaluated, seconds)


def test_goals_are_judged_on_the_lower_end():
    scores = [_score(s, "ppo", "p", 0.99, 0.85 + 0.02 * s) for s in range(5)]
    assert summary(scores, "optimal", "ppo")["seeds"] == 5
    lines = "\n".join(goal_lines(scores, "current"))
    assert "| ppo | success | 98 % |" in lines and "| met |" in lines
    assert "| ppo | optimal | 90 % |" in lines and "NOT met (lower end" in lines


def test_configuration_goals_take_the_pessimistic_end():
    """A share of the exhaustive search's configurations, one named search, or (no goal given)
    every search but random; met only when the interval's upper end is within it."""
    from modquad_gym.scoring.agents_report import config_limit

    searches = {"exhaustive": 200.0, "centrosymmetric": 60.0, "greedy": 50.0, "random": 5.0}
    assert config_limit(0.05, searches)[0] == pytest.approx(10.0)
    assert config_limit("centrosymmetric", searches)[0] == pytest.approx(60.0)
    limit, words = config_limit(None, searches)
    assert limit == pytest.approx(50.0) and limit < 50.0 and "greedy" in words
    # milp's count is its answers only (usually 1): not a rival of the same kind
    assert config_limit(None, {**searches, "milp": 1.0}) == (limit, words)
    assert words.endswith("the fewest but random and milp")
    assert config_limit(0.05, {"greedy": 1.0})[0] is None
    scores = [_score(s, "ppo", "p", 0.99, 0.9) for s in range(5)]
    scores += [_score(0, m, "p", 1.0, 1.0, evaluated=e) for m, e in searches.items()]
    lines = "\n".join(goal_lines(scores, "mixed"))  # configs: fewer than every search but random
    assert "| ppo | configs / task | < greedy" in lines


def test_report_on_copies_of_the_shipped_model(tmp_path, capsys):
    if not DEFAULT_MODEL.is_file():
        pytest.skip("no default model")
    for seed in (0, 1):
        shutil.copytree(DEFAULT_MODEL.parent, tmp_path / "runs" / f"seed-{seed}")
    out = tmp_path / "report"
    # one task a suite: the rows, per (seed, method, suite), are as many as with more
    argv = [str(tmp_path / "runs"), "--limit", "1", "--methods", "ppo", "--out", str(out),
            "--no-progress"]  # fmt: skip
    assert main(argv) == 0
    text = (out / "seeds.md").read_text()
    assert "over 2 training seeds" in text and "| ppo | 2 |" in text
    rows = (out / "seeds.csv").read_text().splitlines()
    searches = len(SEARCH_METHODS)
    assert len(rows) == 1 + 2 * 2 + searches * 2  # header, ppo x 2 seeds x 2 suites, searches x 2
    assert (out / "seeds.png").stat().st_size > 1000
    with pytest.raises(SystemExit) as exc:  # an existing report is never replaced unasked
        main(argv)
    assert exc.value.code == 2 and "--out" in capsys.readouterr().err


def test_bad_runs_folder_is_one_line(tmp_path, capsys):
    with pytest.raises(SystemExit) as exc:
        main([str(tmp_path)])
    assert exc.value.code == 2 and "no seed-*/model.zip" in capsys.readouterr().err
    for seed in (0, 1):
        (tmp_path / f"f{seed}" / "seed-3").mkdir(parents=True)
        (tmp_path / f"f{seed}" / "seed-3" / "model.zip").write_bytes(b"")
    with pytest.raises(SystemExit):
        main([str(tmp_path / "f0"), str(tmp_path / "f1")])
    assert "seed 3 in both" in capsys.readouterr().err


def test_fault_tier_scores_designs_that_survive_the_failure(tmp_path):
    """On the fault tier every method designs for the failure and is judged by the failure's
    optima (the first task's is 8 modules, its intact optimum 6): the exhaustive search is
    optimal with 8, and milp, which cannot honour it, is left out."""
    model = shipped_model("fault")
    if not model.is_file():
        pytest.skip("no fault model")
    for seed in (0, 1):  # a report over seeds takes two at least
        shutil.copytree(model.parent, tmp_path / "runs" / f"seed-{seed}")
    out = tmp_path / "report"
    argv = [str(tmp_path / "runs"), "--tier", "fault", "--limit", "1", "--methods", "ppo",
            "--out", str(out), "--no-progress"]  # fmt: skip
    assert main(argv) == 0
    rows = {r["method"]: r for r in csv.DictReader((out / "seeds.csv").open())}
    assert "milp" not in rows and {"ppo", "exhaustive", "greedy"} <= set(rows)
    assert float(rows["exhaustive"]["optimal"]) == 1.0
    assert float(rows["exhaustive"]["modules"]) == 8.0
    text = (out / "seeds.md").read_text()
    assert "designs for a rotor failure" in text
    assert "sets no goals" in text and "| method | metric | goal |" not in text  # no empty table


def _runs(tmp_path, **seeds):
    """A folder of ``seed-S`` copies of shipped models (``seed0="fault"``) or of junk."""
    for name, model in seeds.items():
        run = tmp_path / "runs" / name.replace("seed", "seed-")
        if model == "junk":
            run.mkdir(parents=True)
            (run / "model.zip").write_bytes(b"not a model")
            continue
        if not shipped_model(model).is_file():
            pytest.skip(f"no {model} model")
        shutil.copytree(shipped_model(model).parent, run)
    return tmp_path / "runs"


def _refused(capsys, argv, *words):
    with pytest.raises(SystemExit) as exc:
        main(argv)
    err = capsys.readouterr().err.strip().splitlines()
    assert exc.value.code == 2 and "Traceback" not in "\n".join(err)
    assert all(w in err[-1] for w in words), err[-1]


@pytest.fixture()
def no_work(monkeypatch):
    """Fails the test if any task is solved."""

    def solve(*args, **kwargs):
        raise AssertionError("the work started")

    monkeypatch.setattr("modquad_gym.scoring.seeds.run_benchmark", solve)


@pytest.mark.parametrize("method", ["ppox", "ppo-guided-b0", "ppo-kx", "exhaustive"])
def test_a_bad_method_is_one_line_before_any_work(tmp_path, capsys, no_work, method):
    runs = _runs(tmp_path, seed0="fault")
    argv = [str(runs), "--tier", "fault", "--methods", method, "--limit", "1", "--out",
            str(tmp_path / "o")]  # fmt: skip
    _refused(capsys, argv, "--methods", repr(method) if method != "exhaustive" else method)


def test_a_bad_seed_folder_is_named_before_any_work(tmp_path, capsys, no_work):
    """A model.zip that is not a model, a model trained for another tier (its config.json) and
    a seed folder without model.zip: each refused in one line naming the seed folder."""
    runs = _runs(tmp_path, seed0="fault", seed1="junk")
    argv = [str(runs), "--tier", "fault", "--methods", "ppo", "--out", str(tmp_path / "o")]
    _refused(capsys, argv, "seed-1", "not a MaskablePPO model")
    shutil.rmtree(runs / "seed-1")
    shutil.copytree(shipped_model("mixed").parent, runs / "seed-1")
    _refused(capsys, argv, "seed-1", "trained for tier 'mixed'", "--tier fault")
    shutil.rmtree(runs / "seed-1")
    (runs / "seed-1").mkdir()
    _refused(capsys, argv, "seed-1", "no model.zip")
    assert not (tmp_path / "o").exists()


def test_the_python_door_checks_as_the_command_line(tmp_path, capsys, monkeypatch):
    """score_runs refuses what the command line refuses, in its words; a method given twice
    (``ppo-k0`` is ``ppo``) is scored once under one name, through both doors."""
    from modquad_gym.scoring.seeds import score_runs

    cases = [({"methods": ["exhaustive"]}, "learned methods only"),
             ({"methods": "greedy"}, "--methods: a list"),
             ({"limit": 0}, "--limit: must be in 1..1000000, got 0"),
             ({"limit": -1}, "--limit: must be in 1..1000000, got -1")]  # fmt: skip
    for kwargs, words in cases:
        with pytest.raises(ValueError, match=words):
            score_runs({}, "current", **kwargs)
    _refused(capsys, [str(tmp_path), "--limit", "0"], "--limit: must be in 1..1000000, got 0")
    chosen = []
    monkeypatch.setattr("modquad_gym.scoring.seeds.scored",
                        lambda runs, tier, methods, *a: chosen.append(methods) or [])  # fmt: skip
    monkeypatch.setattr("modquad_gym.scoring.seeds.write_report", lambda *a: tmp_path / "r.md")
    (tmp_path / "r.md").write_text("")
    runs = _runs(tmp_path, seed0="current", seed1="current")
    models = {p.name.removeprefix("seed-"): p / "model.zip" for p in sorted(runs.iterdir())}
    assert score_runs(models, "current", ["ppo", "ppo-k0", "ppo", "ppo-k08"]) == []
    argv = [str(runs), "--methods", "ppo", "ppo-k0", "ppo", "ppo-k08", "--out", str(tmp_path / "o")]
    assert main(argv) == 0
    assert chosen == [["ppo", "ppo-k8"]] * 2


def test_one_seed_is_refused_naming_runs_before_any_work(tmp_path, capsys, no_work):
    """One seed has no interval: the command refuses it (it printed a zero-width "95 % CI" and
    judged the tier's goals on it), as does the Python door."""
    from modquad_gym.scoring.seeds import score_runs

    runs = _runs(tmp_path, seed0="current")
    argv = [str(runs), "--methods", "ppo", "--out", str(tmp_path / "o")]
    _refused(capsys, argv, "RUNS: 1 seed", "seed-0", "at least 2")
    assert not (tmp_path / "o").exists()
    with pytest.raises(ValueError, match="RUNS: 1 seed"):
        score_runs({"0": runs / "seed-0" / "model.zip"}, "current", ["ppo"])


def _two_suites(tasks_a=40, tasks_b=60):
    """Five seeds of ppo on two suites of unequal size, the searches once."""
    scores = []
    for s in range(5):
        scores += [
            SeedScore(str(s), "ppo", "a", tasks_a, 1.0, 0.95 + 0.01 * s, 20.0 + s, 0.2),
            SeedScore(str(s), "ppo", "b", tasks_b, 0.9, 0.70 + 0.02 * s, 5.0, 0.05),
        ]
    scores += [
        SeedScore("-", "exhaustive", "a", tasks_a, 1.0, 1.0, 30.0, 0.02),
        SeedScore("-", "exhaustive", "b", tasks_b, 1.0, 1.0, 10.0, 0.01),
    ]
    return scores


def test_the_seeds_report_and_the_leaderboard_give_one_figure_for_the_same_seeds():
    """Each seed's score is pooled over the tier's tasks (suites weighted by their task counts)
    before the statistics over seeds, as the leaderboard counts it: the seeds report's mean is
    the leaderboard's, interval included (it pooled the seeds x suites scores unweighted)."""
    from benchmarks.leaderboard_entries import over_seeds
    from modquad_gym.scoring.tiers import get_tier

    scores = _two_suites()
    records = [{k: str(v) for k, v in vars(s).items() if v is not None} for s in scores]
    board = {e.method: e for e in over_seeds(records, get_tier("current"), "", {})}["ppo"]
    for metric in ("success", "optimal", "evaluated"):
        mine = summary(scores, metric, "ppo")
        assert mine["mean"] == pytest.approx(getattr(board, metric)), metric
    pooled = [(40 * (0.95 + 0.01 * s) + 60 * (0.70 + 0.02 * s)) / 100 for s in range(5)]
    assert summary(scores, "optimal", "ppo")["mean"][0] == pytest.approx(np.mean(pooled))
    assert summary(scores, "optimal", "ppo")["iqm"][0] == pytest.approx(iqm(np.array(pooled)))


def test_the_guided_sentence_divides_like_by_like():
    """configurations and seconds per task over the same tasks on both sides (the report
    divided a seeds x suites IQM by a task-weighted mean)."""
    scores = [dataclasses.replace(s, method="ppo-guided") if s.method == "ppo" else s
              for s in _two_suites()]  # fmt: skip
    line = goal_lines(scores, "mixed")[-1]
    configs = iqm(np.array([(40 * (20.0 + s) + 60 * 5.0) / 100 for s in range(5)]))
    seconds = (40 * 0.2 + 60 * 0.05) / 100
    assert f"{configs:.1f} [" in line
    assert f"{100 * configs / 18.0:.1f} % of the exhaustive search's 18.0" in line
    assert f"in {100 * seconds / 0.014:.0f} % of its time ({seconds:.3f} s vs 0.014 s" in line


def test_one_seed_in_python_gets_no_interval_and_no_verdict():
    scores = [_score(0, "ppo", "p", 0.99, 0.95)]
    lines = "\n".join(goal_lines(scores, "current"))
    assert "| ppo | optimal | 90 % | 95.0 % n/a (1 seed) | no verdict (no interval) |" in lines
    assert "[95.0 %, 95.0 %]" not in lines and "| met |" not in lines


def test_a_committed_report_re_renders_from_its_seeds_csv(tmp_path, capsys):
    """``python -m benchmarks.seeds_rerender``: the tables as the scorer now writes them, from
    seeds.csv alone; the scoring run's command, machine and runs kept; --force asked for; a
    folder that is not a seeds report refused in one line."""
    from benchmarks.seeds_rerender import main as rerender
    from modquad_gym.scoring.seeds_report import report_tables

    src = Path(__file__).resolve().parents[1] / "results" / "seeds_current"
    folder = tmp_path / "seeds_current"
    folder.mkdir()
    for name in ("seeds.csv", "seeds.md"):
        shutil.copy(src / name, folder / name)
    old = (folder / "seeds.md").read_text()
    with pytest.raises(SystemExit) as exc:
        rerender([str(folder)])
    assert exc.value.code == 2 and "--force" in capsys.readouterr().err
    assert rerender([str(folder), "--force"]) == 0
    text = (folder / "seeds.md").read_text()
    rows = list(csv.DictReader((folder / "seeds.csv").open()))
    tables = report_tables([SeedScore.from_record(r) for r in rows], "current")
    assert "\n".join(tables) in text
    made = old.splitlines()[2].split(" Re-rendered from")[0]
    assert text.splitlines()[2].startswith(made) and "seeds_rerender" in text.splitlines()[2]
    assert "`runs/exact-seeds/seed-4`" in text and (folder / "seeds.png").stat().st_size > 1000
    assert rerender([str(folder), "--force"]) == 0  # again: one re-rendering sentence
    assert (folder / "seeds.md").read_text() == text
    (folder / "seeds.md").write_text("# something else\n")
    with pytest.raises(SystemExit) as exc:
        rerender([str(folder), "--force"])
    err = capsys.readouterr().err.strip().splitlines()
    assert exc.value.code == 2 and "not a seeds report" in err[-1] and str(folder) in err[-1]
