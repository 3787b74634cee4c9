"""``modquad score``: without the [viz] extra one line naming it, before any work; the Python
door checks its options as the command line does; each method scored once; the report's words."""

from __future__ import annotations

import importlib.util

import pytest

from modquad_gym.cli import main as cli_main


def test_score_without_matplotlib_says_so_before_scoring(tmp_path, monkeypatch, capsys):
    real = importlib.util.find_spec

    def find_spec(name, *args):
        return None if name == "matplotlib" else real(name, *args)

    monkeypatch.setattr(importlib.util, "find_spec", find_spec)
    solved = []
    monkeypatch.setattr("modquad_gym.scoring.agents.run_benchmark",
                        lambda *a, **k: solved.append(a) or [])  # fmt: skip
    argv = ["score", "--methods", "greedy", "--limit", "1", "--out", str(tmp_path / "s")]
    assert cli_main(argv) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "modquad_gym[viz]" in err[0]
    assert not solved and not (tmp_path / "s").exists()


def test_score_options_are_checked_as_the_command_line_checks_them(tmp_path, capsys):
    """score_options refuses, in the command line's words, what the command line refuses: 0
    validation tasks, a limit below 1, a method name where a list of them goes."""
    from modquad_gym.scoring.options import score_options

    cases = [({"validation": 0}, ["--validation", "0"], "--validation: must be in 1..10000"),
             ({"limit": 0}, ["--limit", "0"], "--limit: must be in 1..1000000, got 0"),
             ({"limit": -1}, ["--limit", "-1"], "--limit: must be in 1..1000000, got -1"),
             ({"methods": "greedy"}, None, "--methods: a list of values")]  # fmt: skip
    for given, argv, words in cases:
        with pytest.raises(ValueError, match=words):
            score_options(**given)
        if argv is not None:
            with pytest.raises(SystemExit):
                cli_main(["score", *argv, "--out", str(tmp_path / "s")])
            assert f"argument {words}" in capsys.readouterr().err
    assert score_options(limit=2, methods=["greedy"]).limit == 2


def test_validation_with_limit_is_refused_by_both_doors(tmp_path, capsys, monkeypatch):
    from modquad_gym.scoring.agents import score
    from modquad_gym.scoring.options import score_options

    monkeypatch.setattr("modquad_gym.scoring.agents.validation_suite", _no_work)
    words = "give --limit or --validation N, not both"
    with pytest.raises(ValueError, match=words):
        score(score_options(validation=2, limit=1, methods=["greedy"], out=tmp_path), "x")
    argv = ["score", "--methods", "greedy", "--validation", "2", "--limit", "1", "--out",
            str(tmp_path / "s")]  # fmt: skip
    assert cli_main(argv) == 2 and words in capsys.readouterr().err


def _no_work(*args, **kwargs):
    raise AssertionError("the work started")


def test_a_method_is_scored_once_under_one_name(monkeypatch):
    """``ppo-k0`` is ``ppo`` (no sampled rollout) and ``ppo-k08`` is ``ppo-k8``: scored once."""
    from modquad_gym.scoring.agents import chosen_methods
    from modquad_gym.scoring.options import score_options
    from modquad_gym.scoring.tiers import get_tier

    args = score_options(methods=["ppo", "ppo-k0", "ppo-k08", "ppo-k8", "greedy"])
    assert chosen_methods(args, get_tier("current")) == ["ppo", "ppo-k8", "greedy"]


def test_the_report_names_the_budget_the_optima_were_certified_at(tmp_path):
    from modquad_gym.scoring.agents import main

    out = tmp_path / "s"
    argv = ["--tier", "fault", "--n-max", "5", "--methods", "greedy", "--limit", "1",
            "--out", str(out), "--no-progress"]  # fmt: skip
    assert main(argv) == 0
    text = (out / "benchmark.md").read_text()
    assert "exhaustive search with n_max = 10" in text
    assert "optimum is <= n_max = 5 (the budget scored here)" in text


def test_the_module_as_a_script_stops_in_one_line(capsys):
    from modquad_gym.scoring.agents import script

    assert script(["--tier", "nope", "--out", "/nonexistent/x"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err == ["modquad score: error: --tier: unknown tier 'nope'; choose one of current, "
                   "large, mixed, dynamic, fault"]  # fmt: skip
