"""`python -m benchmarks.dynamics`: its rows, report and refusal to overwrite (flights stubbed: the
flight itself is tested in test_track.py)."""

import numpy as np
import pytest

import modquad_gym as mq
from benchmarks import dynamics as bench
from modquad_gym import dynamics as dy


def test_static_task_is_the_motion_at_rest():
    task = dy.push(1.0, 0.5, 3.0, payload=dy.Payload(0.2, (0, 0, -0.1)), rate=20)
    rest = bench.static_task(task)
    s = mq.Structure([(0, 0), (1, 0)])
    W = rest.rotor_wrenches(s)
    weight = (s.mass + 0.2) * mq.GRAVITY
    np.testing.assert_allclose(W[:, 2], weight, rtol=1e-12)
    np.testing.assert_allclose(W[:, 0], task.exerted[:, 0], atol=1e-12)


def test_bench_writes_its_report_and_refuses_to_overwrite(tmp_path, monkeypatch, capsys):
    monkeypatch.setattr(
        bench,
        "flight",
        lambda s, task: {"max_err_cm": 0.1, "rms_err_cm": 0.05, "saturated_pct": 0.0,
                         "diverged": False} if s is not None else dict.fromkeys(
            ("max_err_cm", "rms_err_cm", "saturated_pct", "diverged")),
    )  # fmt: skip
    argv = ["--circle-speeds", "1", "2.2", "--eight-speeds", "--push-forces", "2"]
    bench.main([*argv, "--out", str(tmp_path)])
    text = (tmp_path / "report.md").read_text()
    assert text.startswith("# Designing for a motion") and "python -m benchmarks.dynamics" in text
    assert "cores, no GPU" in text and (tmp_path / "modules_vs_speed.png").stat().st_size > 0
    rows = (tmp_path / "dynamics.csv").read_text().splitlines()
    assert len(rows) == 4  # header + 3 rows
    assert "| circle r=1 m | speed_m_s | 2.2 |" in text  # beyond any structure: none
    with pytest.raises(SystemExit):
        bench.main([*argv, "--out", str(tmp_path)])
    assert "--force" in capsys.readouterr().err


def test_heterogeneous_figure_says_why_it_is_empty(tmp_path):
    """No task a mix satisfies within n_max (e.g. ``--n-max 2``): the figure is one panel that
    says so (a figure of height 0 could not be saved)."""
    from benchmarks.heterogeneous_report import figure

    rows = [{"workload": "planted", "task": 0, "n_mixed": "none", "saved": "n/a"}]
    assert figure(rows, {}, 2, tmp_path / "h.png") == []
    assert (tmp_path / "h.png").stat().st_size > 0
