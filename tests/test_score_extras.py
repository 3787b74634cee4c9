"""``modquad score`` without the [viz] extra: one line naming it, before any work."""

from __future__ import annotations

import importlib.util

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
