"""The picture of a trajectory's flight through a failure marks where the trajectory ends and
the hold after it begins (a vertical line on both time-axis panels, its words at the top of the
error panel, off the other marks' words); a hover's picture has no such mark. Checked on the
figure's artists (no pixels)."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

import modquad_gym as mq
from modquad_gym import dynamics as dy

pytest.importorskip("mujoco")
pytest.importorskip("matplotlib")

from modquad_gym.sim import fault_pictures  # noqa: E402
from modquad_gym.sim.fault_flight import fly_with_failure  # noqa: E402
from modquad_gym.sim.fault_pictures import END, time_marks  # noqa: E402
from modquad_gym.sim.validate_fault import validate_with_failure  # noqa: E402

LINE = dy.line(0.3, 1.0, hold=0.3, rate=20.0)  # 1.92 s, then the hold
SQUARE = mq.Structure([(0, 0), (1, 0), (0, 1), (1, 1)])
WORDS = "trajectory ends, hold"


def _vertical_lines(ax) -> list[tuple[float, str]]:
    """(time, colour) of each vertical line in ``ax``."""
    return [(float(x[0]), line.get_color()) for line in ax.lines
            if len(x := np.atleast_1d(line.get_xdata())) == 2 and x[0] == x[1]]  # fmt: skip


@pytest.mark.parametrize("dynamic", [True, False], ids=["trajectory", "hover"])
def test_the_picture_marks_the_trajectory_end_only_for_a_trajectory(monkeypatch, tmp_path,
                                                                    dynamic):  # fmt: skip
    """Through ``validate_with_failure`` (as ``modquad validate --fault``): the found
    structure's picture and the intact minimum's."""
    figures = []
    monkeypatch.setattr(fault_pictures, "save_figure", lambda fig, path, **_: figures.append(fig))
    task = LINE if dynamic else mq.TaskRequirement.load("examples/screwdriver.json")
    validate_with_failure(SQUARE, task, "rotor", intact=mq.Structure([(0, 0), (1, 0), (0, 1)]),
                          out_dir=tmp_path, failure="worst", seconds=1.1)  # fmt: skip
    assert len(figures) == 2
    end = LINE.trajectory.duration
    for fig in figures:
        ax_err, ax_u = fig.axes[1], fig.axes[2]  # the 3-D path, the error, the inputs
        words = {t.get_text().strip(): t for t in ax_err.texts}
        assert "rotor fails" in words  # the failure's mark, as before
        for ax in (ax_err, ax_u):
            ends = [x for x, colour in _vertical_lines(ax) if colour == END]
            assert ends == ([pytest.approx(end)] if dynamic else []), ends
        assert (WORDS in words) == dynamic, sorted(words)
        if dynamic:
            mark = words.pop(WORDS)
            assert mark.get_position()[0] == pytest.approx(end)
            box, panel = mark.get_window_extent(), ax_err.get_window_extent()
            assert panel.x0 <= box.x0 and box.x1 <= panel.x1  # within the panel
            assert not any(box.overlaps(t.get_window_extent()) for t in words.values())


def test_time_marks_only_for_a_trajectory_flown_past_its_end():
    flight = fly_with_failure(SQUARE, LINE, "rotor", failure="worst", seconds=1.1)
    end = LINE.trajectory.duration
    assert flight.run.t[-1] > end + 0.5  # the hold

    def words(f, end_s):
        return [m.words.strip() for m in time_marks(f, end_s)]

    assert words(flight, end)[-1] == WORDS
    assert time_marks(flight, end)[-1].time_s == end
    assert WORDS not in words(flight, None)  # the end not given
    trimmed = replace(flight, run=replace(flight.run, t=flight.run.t[flight.run.t <= end]))
    assert WORDS not in words(trimmed, end)  # no hold after the end
    assert WORDS not in words(replace(flight, flight="hover"), end)
