"""Pictures of a MuJoCo validation: the structure (MuJoCo render or matplotlib), the bench's
rotor inputs (paper Fig. 7), measured against commanded wrench, and a hover's errors and inputs."""

from __future__ import annotations

import os

os.environ.setdefault("MUJOCO_GL", "egl")  # before mujoco is first imported: headless rendering

from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

from modquad_gym.core.extras import import_optional
from modquad_gym.core.outputs import save_figure  # noqa: E402
from modquad_gym.geometry.structure import Structure  # noqa: E402
from modquad_gym.sim.hover import HoverResult  # noqa: E402
from modquad_gym.sim.model import HOME_HEIGHT, SimModel, build_model  # noqa: E402
from modquad_gym.sim.wrench_stand import BenchResult  # noqa: E402
from modquad_gym.viz.raster import SPIN_COLOURS, module_fill  # noqa: E402

BENCH_HOLD_S = 0.5
"""Seconds each wrench is held in the rotor-input plot (the paper commands one every 500 ms)."""

MAX_LINES = 32
"""Most rotors drawn one line each in a rotor-input panel; more (e.g. 256 rotors of a 64-module
structure) are drawn as a heat map, rotor x time, which stays readable."""


OUTSIDE = {
    "loc": "upper left",
    "bbox_to_anchor": (1.005, 1.0),
    "borderaxespad": 0.0,
    "fontsize": "small",
}
"""Legend placement of the time-series panels: beside the axes, never over a saturated line."""


def _plt():
    matplotlib = import_optional("matplotlib")

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def render_structure(
    structure: Structure | SimModel,
    path: str | Path,
    width: int = 800,
    height: int = 600,
    backend: str = "auto",
) -> str:
    """Write a picture of the structure to ``path``; return the backend used.

    ``backend="auto"`` tries MuJoCo's offscreen renderer (``MUJOCO_GL``, EGL by default) and falls
    back to a matplotlib drawing when no GL context can be made; ``"mujoco"`` or ``"matplotlib"``
    force one.
    """
    if backend not in ("auto", "mujoco", "matplotlib"):
        raise ValueError(f"unknown backend {backend!r}; choose auto, mujoco or matplotlib")
    sim = structure if isinstance(structure, SimModel) else build_model(structure)
    if backend in ("auto", "mujoco"):
        try:
            _render_mujoco(sim, Path(path), width, height)
            return "mujoco"
        except Exception:
            if backend == "mujoco":
                raise
    _render_matplotlib(sim.structure, Path(path))
    return "matplotlib"


def _render_mujoco(sim: SimModel, path: Path, width: int, height: int) -> None:
    mujoco = import_optional("mujoco")

    data = sim.new_data()
    renderer = mujoco.Renderer(sim.model, height, width)
    try:
        cam = mujoco.MjvCamera()
        cam.lookat[:] = [0.0, 0.0, HOME_HEIGHT]
        cam.distance = 2.0 * float(sim.model.stat.extent) + 0.6
        cam.azimuth = 135.0
        cam.elevation = -35.0
        renderer.update_scene(data, camera=cam)
        img = renderer.render()
    finally:
        renderer.close()
    _plt().imsave(path, img)


def _render_matplotlib(structure: Structure, path: Path) -> None:
    """The structure in 3-D: module outlines filled as in every picture (:func:`module_fill`),
    each rotor's thrust axis coloured by spin (:data:`SPIN_COLOURS`, as ``modquad show``)."""
    from matplotlib.lines import Line2D

    plt = _plt()
    fig = plt.figure(figsize=(6, 5))
    ax = fig.add_subplot(projection="3d")
    half = structure.side / 2
    for i, c in enumerate(structure.module_centres):
        xs = c[0] + np.array([-half, half, half, -half, -half])
        ys = c[1] + np.array([-half, -half, half, half, -half])
        ax.plot(xs, ys, np.zeros(5), color=module_fill(structure, i), lw=2.5 if i == 0 else 1.5)
    spins = structure.rotor_spins
    p, d = structure.rotor_positions, structure.rotor_directions
    for pk, dk, sk in zip(p, d, spins, strict=True):
        colour = SPIN_COLOURS[1 if sk > 0 else -1]
        ax.quiver(*pk, *dk, length=0.12, color=colour, arrow_length_ratio=0.3)
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.set_zlabel("z [m]")
    ax.set_title(f"{structure.n_modules} modules: thrust axes by spin")
    ax.legend(handles=[Line2D([], [], color=SPIN_COLOURS[k], label=f"spin {k:+d}")
                       for k in (1, -1)], loc="upper left", fontsize="small")  # fmt: skip
    lim = np.abs(p).max() + half
    ax.set_xlim(-lim, lim)
    ax.set_ylim(-lim, lim)
    ax.set_zlim(-lim / 2, lim / 2)
    fig.tight_layout()
    save_figure(fig, path, dpi=120)
    plt.close(fig)


def inputs_panel(fig, ax, t: np.ndarray, u: np.ndarray, f_max: float, step: bool = False) -> None:
    """Rotor inputs u (N, m) over times t on ``ax``: one line per rotor with f_max dotted, or,
    past :data:`MAX_LINES` rotors, a heat map (rotor x time, 0 to f_max) with a colour bar.
    ``step``: u[i] holds from t[i] to t[i + 1] (len(t) = N + 1)."""
    if u.shape[1] > MAX_LINES:
        edges = t if step else np.r_[t, t[-1] + (t[-1] - t[-2] if len(t) > 1 else 1.0)]
        img = ax.pcolormesh(edges, np.arange(u.shape[1] + 1) - 0.5, u.T, vmin=0.0, vmax=f_max,
                            cmap="viridis", shading="flat")  # fmt: skip
        fig.colorbar(img, ax=ax, label="rotor input [N]", pad=0.01)
        ax.set_ylabel(f"rotor (of {u.shape[1]})")
        return
    if step:
        ax.step(t, np.vstack([u, u[-1:]]), where="post", lw=1.0)
    else:
        ax.plot(t, u, lw=0.8)
    ax.axhline(f_max, ls=":", color="k", lw=1.5, label="f_max")
    ax.axhline(0.0, ls=":", color="0.5", lw=1.0)
    ax.set_ylim(-0.05 * f_max, 1.1 * f_max)
    ax.set_ylabel("rotor input [N]")
    ax.legend(**OUTSIDE)


def plot_rotor_inputs(results: list[BenchResult], path: str | Path) -> None:
    """Paper Fig. 7: rotor inputs per commanded wrench (held 500 ms each), f_max dotted."""
    plt = _plt()
    fig, axes = plt.subplots(len(results), 1, figsize=(9, 3.2 * len(results)), squeeze=False)
    for ax, res in zip(axes[:, 0], results, strict=True):
        t = np.arange(len(res.u) + 1) * BENCH_HOLD_S
        inputs_panel(fig, ax, t, res.u, res.f_max, step=True)
        n_lim = int(res.at_limit.sum())
        ax.set_title(f"{res.allocation}: {n_lim}/{len(res.u)} wrenches with a rotor at a limit")
    axes[-1, 0].set_xlabel("time [s] (one task wrench every 500 ms)")
    fig.tight_layout()
    save_figure(fig, path, dpi=120)
    plt.close(fig)


BENCH_MIN_SPAN = 0.1
"""Least span of a bench panel's axes, as a share of the largest commanded force (or torque) of
any component: a component that stays (nearly) constant, zero included, shows its points on
the diagonal at the scale of the task, not its 1e-13 floating-point noise blown up to fill the
panel."""


def bench_limits(
    commanded: np.ndarray, measured: np.ndarray, scale: float | None = None
) -> tuple[float, float]:
    """Shared (lo, hi) of a bench panel's x and y axes: the data's range, widened to at least
    :data:`BENCH_MIN_SPAN` of ``scale`` (default: the largest commanded magnitude here; at
    least 1e-6) about its middle."""
    both = np.concatenate([np.ravel(commanded), np.ravel(measured)])
    lo, hi = float(both.min()), float(both.max())
    scale = max(float(np.abs(commanded).max()) if scale is None else scale, 1e-6)
    span = max(hi - lo, BENCH_MIN_SPAN * scale)
    mid = 0.5 * (lo + hi)
    return mid - 0.55 * span, mid + 0.55 * span


def plot_bench_wrench(results: list[BenchResult], path: str | Path) -> None:
    """Measured (load cell) against commanded wrench, one panel per component, x and y on one
    scale with a floor (:func:`bench_limits`): a constant component is a point on the
    diagonal, not noise."""
    plt = _plt()
    names = ["f_x [N]", "f_y [N]", "f_z [N]", "tau_x [Nm]", "tau_y [Nm]", "tau_z [Nm]"]
    fig, axes = plt.subplots(2, 3, figsize=(11, 6.5))
    markers = {"exact": "o", "pinv_clip": "x"}
    commanded = np.vstack([r.commanded for r in results])
    measured = np.vstack([r.measured for r in results])
    for j, ax in enumerate(axes.flat):
        block = commanded[:, :3] if j < 3 else commanded[:, 3:]  # forces, or torques
        lo, hi = bench_limits(commanded[:, j], measured[:, j], float(np.abs(block).max()))
        for res in results:
            ax.plot(
                res.commanded[:, j],
                res.measured[:, j],
                markers.get(res.allocation, "."),
                ms=4,
                fillstyle="none",
                label=f"{res.allocation} (max rel. err {res.max_error:.1e})",
            )
        ax.plot([lo, hi], [lo, hi], color="0.6", lw=1, zorder=0, label="measured = commanded")
        ax.set_xlim(lo, hi)
        ax.set_ylim(lo, hi)
        ax.ticklabel_format(useOffset=False)
        ax.set_title(names[j])
        ax.set_xlabel("commanded")
        ax.set_ylabel("measured")
    axes[0, 0].legend(fontsize=7)
    fig.tight_layout()
    save_figure(fig, path, dpi=120)
    plt.close(fig)


def plot_hover(res: HoverResult, path: str | Path, title: str = "hover") -> None:
    """Position and attitude error (log scale) and rotor inputs over time, f_max dotted."""
    plt = _plt()
    fig, axes = plt.subplots(3, 1, figsize=(9, 8), sharex=True)
    floor = 1e-9
    axes[0].semilogy(res.time, np.maximum(res.position_error, floor), lw=1)
    axes[0].axhline(0.01, ls="--", color="tab:red", lw=1, label="1 cm")
    axes[0].set_ylabel("position error [m]")
    axes[0].legend(**OUTSIDE)
    axes[1].semilogy(res.time, np.maximum(res.attitude_error, floor), lw=1, color="tab:purple")
    axes[1].set_ylabel("attitude error [rad]")
    inputs_panel(fig, axes[2], res.time, res.u, res.f_max)
    axes[2].set_xlabel("time [s]")
    starts = res.time[np.flatnonzero(np.diff(res.segment)) + 1] if len(res.time) else []
    for ax in axes:
        for t in starts:
            ax.axvline(t, color="0.85", lw=0.8, zorder=0)
    axes[0].set_title(
        f"{title}: saturated {100 * res.saturated_fraction:.1f}% of control steps (task "
        f"segments, take-off excluded), {int(res.diverged.sum())} segment(s) diverged",
        fontsize="medium",
    )
    fig.tight_layout()
    save_figure(fig, path, dpi=120)
    plt.close(fig)
