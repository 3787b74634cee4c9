"""Pictures of a flight along a trajectory: the 3D path desired vs flown, the rotor inputs over
time (as in the paper's Fig. 8) and an animation (GIF).

Large structures stay readable: past :data:`~modquad_gym.sim.pictures.MAX_LINES` rotors the
inputs are drawn as a heat map (rotor x time) with the envelope (min, max) over rotors instead of
one line per rotor, and the animation's camera backs off with the structure's extent.
"""

from __future__ import annotations

import os

os.environ.setdefault("MUJOCO_GL", "egl")  # before mujoco is first imported: headless rendering

from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

from modquad_gym.core.extras import import_optional
from modquad_gym.core.outputs import save_figure  # noqa: E402
from modquad_gym.dynamics import quaternions as quat  # noqa: E402
from modquad_gym.sim.model import SimModel  # noqa: E402
from modquad_gym.sim.pictures import _plt, inputs_panel  # noqa: E402
from modquad_gym.sim.track import TrackResult  # noqa: E402
from modquad_gym.viz.titles import short_name  # noqa: E402

GIF_FPS = 12
"""Frames per second of the animation."""

GOAL_ERROR_CM = 5.0
"""The position-error goal drawn as a reference in the flight's error plot (centimetres)."""

GOAL_IN_VIEW = 3.0
"""The goal line is drawn when it lies within this many times the largest error; a goal further
above would squash the data to a flat line at zero, so the legend names it instead."""


def error_panel(ax, t: np.ndarray, error_cm: np.ndarray, goal_cm: float = GOAL_ERROR_CM) -> None:
    """Position error over time on ``ax``, its y-axis scaled to the data (0 to the largest error
    and a margin) with the goal as a reference: a dashed line where it lies within
    :data:`GOAL_IN_VIEW` times the largest error, else a legend entry saying how far above."""
    error_cm = np.asarray(error_cm, dtype=float)
    finite = error_cm[np.isfinite(error_cm)]
    peak = float(finite.max()) if finite.size else 0.0
    ax.plot(t, error_cm, color="tab:blue", lw=1, label="position error")
    top = 1.15 * peak
    if goal_cm <= GOAL_IN_VIEW * peak:
        ax.axhline(goal_cm, ls="--", color="tab:red", lw=1, label=f"goal {goal_cm:g} cm")
        top = max(top, 1.15 * goal_cm)
    else:  # a legend entry, placed where the data is not
        above = f"{goal_cm / peak:,.0f}x the largest error" if peak > 0 else "no error"
        ax.plot([], [], ls="--", color="tab:red", lw=1,
                label=f"goal {goal_cm:g} cm (off this scale: {above})")  # fmt: skip
        top = top if peak > 0 else goal_cm
    ax.set_ylim(0.0, top * 1.12)  # headroom for the legend
    ax.legend(loc="best", fontsize=8)


def plot_track_path(res: TrackResult, path: str | Path, title: str = "") -> None:
    """Write :func:`track_path_figure` to ``path``."""
    fig = track_path_figure(res, title)
    save_figure(fig, path, dpi=120)
    _plt().close(fig)


def track_path_figure(res: TrackResult, title: str = ""):
    """The COM's path in 3D, desired (dashed) and flown, with start (a ring) and end marked, and
    the position error over time (:func:`error_panel`: scaled to the data, the goal a reference);
    a pyplot figure (close it)."""
    plt = _plt()
    fig = plt.figure(figsize=(10, 4.8))
    ax = fig.add_subplot(1, 2, 1, projection="3d")
    d, f = res.desired, res.flown
    ax.plot(*d.T, "--", color="0.45", lw=1.5, label="desired")
    ax.plot(*f.T, color="tab:blue", lw=1.2, label="flown")
    ax.scatter(*d[-1], color="tab:red", s=25, label="end", depthshade=False)
    ax.scatter(
        *d[0],
        facecolors="none",
        edgecolors="tab:green",
        s=90,
        linewidths=1.8,
        label="start",
        depthshade=False,
    )  # a ring over the end: a closed path shows both
    span = max(float(np.ptp(d, axis=0).max()), 0.2)
    centre = (d.max(axis=0) + d.min(axis=0)) / 2
    for axis, c in zip((ax.set_xlim, ax.set_ylim, ax.set_zlim), centre):
        axis(c - span / 2 - 0.05, c + span / 2 + 0.05)
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.set_zlabel("z [m]")
    ax.legend(loc="upper left", fontsize=8)
    ax2 = fig.add_subplot(1, 2, 2)
    error_panel(ax2, res.t, 100 * res.position_error)
    ax2.set_xlabel("time [s]")
    ax2.set_ylabel("position error [cm]")
    ax2.set_title(
        f"max {100 * res.max_position_error_m:.2g} cm, rms {100 * res.rms_position_error_m:.2g} cm"
    )
    fig.suptitle(short_name(title) or "trajectory: desired vs flown")
    fig.tight_layout()
    return fig


def plot_track_inputs(res: TrackResult, path: str | Path, title: str = "") -> None:
    """Rotor inputs over the flight (paper Fig. 8), f_max dotted; a heat map for many rotors."""
    plt = _plt()
    u, f_max = res.inputs, res.f_max
    fig, axes = plt.subplots(2, 1, figsize=(9, 6.5), sharex=True,
                             gridspec_kw={"height_ratios": [3, 1]})  # fmt: skip
    ax = axes[0]
    inputs_panel(fig, ax, res.t, u, f_max)
    sat = res.saturated
    ax.set_title(
        (short_name(title) + ": " if title else "")
        + f"rotor inputs, saturated {100 * res.saturated_fraction:.1f}% of control steps"
    )
    env = axes[1]
    env.fill_between(res.t, u.min(axis=1), u.max(axis=1), color="tab:blue", alpha=0.3,
                     label="min-max over rotors")  # fmt: skip
    env.axhline(f_max, ls=":", color="k", lw=1.5, label="f_max")
    env.axhline(0.0, ls=":", color="0.5", lw=1.0)
    if sat.any():
        env.plot(res.t[sat], np.full(int(sat.sum()), f_max), "|", color="tab:red", ms=6,
                 label="saturated")  # fmt: skip
    env.set_ylim(-0.05 * f_max, 1.15 * f_max)
    env.set_ylabel("[N]")
    env.set_xlabel("time [s]")
    env.legend(loc="upper right", fontsize=7, ncol=3)
    fig.tight_layout()
    save_figure(fig, path, dpi=120)
    plt.close(fig)


def _frames(res: TrackResult, seconds_per_frame: float) -> np.ndarray:
    step = (
        max(1, int(round(seconds_per_frame / max(res.t[1] - res.t[0], 1e-9))))
        if len(res.t) > 1
        else 1
    )
    return np.arange(0, len(res.t), step)


def animate_track(sim: SimModel, res: TrackResult, path: str | Path, width: int = 480,
                  height: int = 360, backend: str = "auto") -> str:  # fmt: skip
    """Write a GIF of the flight (MuJoCo's offscreen renderer following the structure, or a
    matplotlib top view where no GL context can be made); return the backend used."""
    frames = _frames(res, 1.0 / GIF_FPS)
    if backend in ("auto", "mujoco"):
        try:
            images = _mujoco_frames(sim, res, frames, width, height)
        except Exception:
            if backend == "mujoco":
                raise
            images = None
        if images is not None:
            _write_gif(images, Path(path))
            return "mujoco"
    _write_gif(_matplotlib_frames(sim, res, frames), Path(path))
    return "matplotlib"


def _mujoco_frames(sim: SimModel, res: TrackResult, frames, width: int, height: int) -> list:
    mujoco = import_optional("mujoco")

    data = mujoco.MjData(sim.model)
    renderer = mujoco.Renderer(sim.model, height, width)
    images = []
    try:
        cam = mujoco.MjvCamera()
        cam.distance = 2.2 * float(sim.model.stat.extent) + 1.5
        cam.azimuth, cam.elevation = 135.0, -30.0
        for k in frames:
            data.qpos[:3], data.qpos[3:7] = res.flown[k], res.attitude[k]
            data.ctrl[:] = res.inputs[k]
            mujoco.mj_forward(sim.model, data)
            cam.lookat[:] = res.flown[k]
            renderer.update_scene(data, camera=cam)
            images.append(renderer.render().copy())
    finally:
        renderer.close()
    return images


def _matplotlib_frames(sim: SimModel, res: TrackResult, frames) -> list:
    plt = _plt()
    s = sim.structure
    half = s.side / 2
    corners = np.array([[-half, -half, 0], [half, -half, 0], [half, half, 0], [-half, half, 0],
                        [-half, -half, 0]])  # fmt: skip
    images = []
    pad = s.side * (1 + float(np.ptp(np.asarray(s.cells), axis=0).max()))
    lo = np.minimum(res.desired.min(axis=0), res.flown.min(axis=0)) - pad
    hi = np.maximum(res.desired.max(axis=0), res.flown.max(axis=0)) + pad
    for k in frames:
        fig, ax = plt.subplots(figsize=(4.8, 4.8), dpi=80)
        ax.plot(res.desired[:, 0], res.desired[:, 1], "--", color="0.6", lw=1)
        ax.plot(res.flown[: k + 1, 0], res.flown[: k + 1, 1], color="tab:blue", lw=1)
        R = quat.to_matrix(res.attitude[k])
        for c in s.module_centres:
            xy = (res.flown[k] + (c + corners) @ R.T)[:, :2]
            ax.plot(xy[:, 0], xy[:, 1], color="tab:green", lw=1)
        ax.set_xlim(lo[0], hi[0])
        ax.set_ylim(lo[1], hi[1])
        ax.set_aspect("equal")
        ax.set_title(f"t = {res.t[k]:.1f} s (top view)")
        fig.canvas.draw()
        images.append(np.asarray(fig.canvas.buffer_rgba())[..., :3].copy())
        plt.close(fig)
    return images


def _write_gif(images: list, path: Path) -> None:
    from PIL import Image

    from modquad_gym.core.outputs import atomic_write

    pics = [Image.fromarray(np.asarray(im, dtype=np.uint8)) for im in images]

    def write(tmp: Path) -> None:
        pics[0].save(tmp, format="GIF", save_all=True, append_images=pics[1:],
                     duration=int(1000 / GIF_FPS), loop=0)  # fmt: skip

    atomic_write(path, write)
