"""The flight's path picture marks its start so that a closed path (a circle ends where it
started) still shows it: a larger ring around the end's dot, not a dot under it."""

from __future__ import annotations

import numpy as np
from matplotlib.colors import to_rgba

from modquad_gym.sim.track import TrackResult
from modquad_gym.sim.track_pictures import track_path_figure


def test_a_closed_path_shows_its_start_around_its_end():
    t = np.linspace(0.0, 1.0, 50)
    circle = np.stack([np.cos(2 * np.pi * t), np.sin(2 * np.pi * t), np.ones_like(t)], axis=1)
    n = len(t)
    res = TrackResult(t=t, desired=circle, flown=circle + 1e-3,
                      attitude=np.tile([1.0, 0, 0, 0], (n, 1)), attitude_error=np.zeros(n),
                      inputs=np.zeros((n, 4)), saturated=np.zeros(n, bool),
                      wrench_ff=np.zeros((n, 6)), f_max=1.0)  # fmt: skip
    fig = track_path_figure(res, "circle")
    try:
        ax = fig.axes[0]
        marks = {c.get_label(): c for c in ax.collections}
        start, end = marks["start"], marks["end"]
        assert np.allclose(start.get_offsets(), end.get_offsets())  # the same point, drawn
        faces = start.get_facecolor()  # hollow: the end's dot shows through
        assert len(faces) == 0 or faces[:, 3].max() == 0
        assert np.allclose(start.get_edgecolor()[0], to_rgba("tab:green"))
        assert start.get_sizes()[0] > 2 * end.get_sizes()[0]  # a ring around it
    finally:
        import matplotlib.pyplot as plt

        plt.close(fig)
