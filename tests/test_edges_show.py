"""Pictures at every size (issue 34): ``modquad show`` searches like ``modquad solve``
(``--method``, ``--n-max`` to 128, ``--time-limit``); at 16-64 modules the figure stays readable
(short title, task points drawn over a translucent feasible set, legend beside the top view);
the flight's error plot is scaled to the data with the goal as a reference; MuJoCo renders have
a sky and a floor; ``modquad validate`` prints a short summary, not the raw record."""

from __future__ import annotations

import argparse
import json

import numpy as np
import pytest

from modquad_gym import Structure, TaskRequirement
from modquad_gym.cli import build_parser, main
from modquad_gym.viz.drawing import draw_projection, draw_structure
from modquad_gym.viz.titles import MAX_TITLE_NAME, TITLE_WIDTH, figure_title
from modquad_gym.viz.zonotope import EXACT_DRAWN_ROTORS, drawn_vertices, projection_vertices


def _task(tmp_path, fz: float, name: str = "lift") -> str:
    path = tmp_path / f"{name}.json"
    path.write_text(json.dumps({"wrenches": [[0, 0, fz, 0, 0, 0]], "name": name}))
    return str(path)


def _subparser(name: str) -> argparse.ArgumentParser:
    sub = next(a for a in build_parser()._actions if isinstance(a, argparse._SubParsersAction))
    return sub.choices[name]


def _options(parser) -> dict:
    return {a.dest: a for a in parser._actions}


# ------------------------------------------------------------------------------------ show
def test_show_takes_the_search_options_of_solve():
    show, solve = _options(_subparser("show")), _options(_subparser("solve"))
    for dest in ("method", "n_max", "time_limit", "model", "seed"):
        assert show[dest].choices == solve[dest].choices, dest
        assert show[dest].default == solve[dest].default, dest
        assert show[dest].type is solve[dest].type, dest  # the same parsers, not copies


def test_show_with_greedy_and_n_max_128_writes_the_picture(tmp_path, capsys):
    png = tmp_path / "greedy.png"
    argv = [
        "show",
        "--task",
        _task(tmp_path, 30.0),
        "--method",
        "greedy",
        "--n-max",
        "128",
        "--time-limit",
        "600",
        "--out",
        str(png),
    ]  # fmt: skip  (cold numba: compile first; 128: the searches' limit, no lower one of show's)
    assert main(argv) == 0
    out = capsys.readouterr().out
    assert "method greedy" in out and "11 modules" in out and png.stat().st_size > 10_000


def test_show_draws_a_62_module_answer(tmp_path, capsys):
    png = tmp_path / "big.png"
    argv = ["show", "--task", _task(tmp_path, 175.0), "--n-max", "64", "--time-limit", "600",
            "--out", str(png)]  # fmt: skip
    assert main(argv) == 0
    assert "62 modules (certified minimum)" in capsys.readouterr().out
    assert png.stat().st_size > 10_000


def test_show_refuses_n_max_beyond_the_searches_before_any_work(tmp_path, capsys):
    png = tmp_path / "no.png"
    argv = ["show", "--task", _task(tmp_path, 30.0), "--n-max", "129", "--out", str(png)]
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert "--n-max 129" in err and "128" in err and not png.exists()


# ------------------------------------------------------------------------- figure at scale
def test_projection_draws_task_points_over_a_translucent_set():
    from mpl_toolkits.mplot3d.art3d import Path3DCollection, Poly3DCollection

    s = Structure([(i, j) for i in range(4) for j in range(4)])  # 16 modules, 64 rotors
    rng = np.random.default_rng(0)
    W = np.c_[rng.uniform(-1, 1, (12, 2)), rng.uniform(5, 20, 12), rng.uniform(-0.5, 0.5, (12, 3))]
    task = TaskRequirement(W)
    ax = draw_projection(s, "torque", task=task)
    assert ax.computed_zorder is False  # drawn in zorder, not by depth: the points stay on top
    hulls = [c for c in ax.collections if isinstance(c, Poly3DCollection)]
    points = [c for c in ax.collections if isinstance(c, Path3DCollection)]
    assert len(hulls) == 1 and hulls[0].get_alpha() < 0.5
    assert points and all(p.get_zorder() > hulls[0].get_zorder() for p in points)
    assert sum(len(p.get_offsets()) for p in points) == len(W)  # only the task's points
    assert all(p.get_edgecolor().size and p.get_sizes().max() >= 15 for p in points)


def test_drawn_vertices_of_a_large_projection_are_true_vertices():
    s = Structure([(i, j) for i in range(3) for j in range(3)])  # 36 rotors: sampled
    A = s.configuration_matrix()
    assert A.shape[1] > EXACT_DRAWN_ROTORS
    exact = projection_vertices(A, "torque")
    V, is_exact = drawn_vertices(A, "torque")
    assert not is_exact and 50 < len(V) < len(exact)
    d = np.abs(V[:, None, :] - exact[None, :, :]).max(axis=2).min(axis=1)
    assert d.max() < 1e-9  # every drawn vertex is a vertex of the projection
    small, small_exact = drawn_vertices(Structure([(0, 0), (1, 0)]).configuration_matrix(), "force")
    assert small_exact and len(small) > 0


def test_top_view_legend_lies_beside_the_structure():
    s = Structure([(i, j) for i in range(5) for j in range(5)])  # fills its axes
    ax = draw_structure(s)
    ax.figure.canvas.draw()
    renderer = ax.figure.canvas.get_renderer()
    legend = ax.get_legend().get_window_extent(renderer)
    assert legend.x0 >= ax.get_window_extent(renderer).x1  # right of the axes, over no module


def test_figure_title_is_cut_and_wrapped():
    long = "planted[" + ";".join(f"{i},{-i}" for i in range(47)) + "]"
    title = figure_title(long)
    lines = title.splitlines()
    assert all(len(line) <= TITLE_WIDTH for line in lines) and len(lines) <= 3
    assert "..." in title and long[: MAX_TITLE_NAME - 3] in title.replace("\n", " ")
    assert figure_title("screwdriver").startswith("task screwdriver: points")


# --------------------------------------------------------------------------- flight plots
def _flight(error_m: float):
    from modquad_gym.sim.track import TrackResult

    t = np.linspace(0.0, 2.0, 101)
    desired = np.c_[t, np.zeros_like(t), np.ones_like(t)]
    flown = desired + np.c_[np.zeros_like(t), error_m * np.sin(np.pi * t / 2), np.zeros_like(t)]
    level = np.tile([1.0, 0, 0, 0], (101, 1))
    return TrackResult(t=t, desired=desired, flown=flown, attitude=level,
                       attitude_error=np.zeros(101), inputs=np.ones((101, 4)),
                       saturated=np.zeros(101, bool), wrench_ff=np.zeros((101, 6)),
                       f_max=2.0)  # fmt: skip


def _at(line, y: float) -> bool:
    """A horizontal line at ``y`` (not a legend's empty proxy)."""
    ydata = np.asarray(line.get_ydata(), dtype=float)
    return ydata.size > 0 and bool(np.allclose(ydata, y))


def test_flight_error_plot_follows_the_data():
    from modquad_gym.sim.pictures import _plt
    from modquad_gym.sim.track_pictures import GOAL_ERROR_CM, track_path_figure

    plt = _plt()
    fig = track_path_figure(_flight(0.001), title="small")  # 0.1 cm against the 5 cm goal
    try:
        ax = fig.axes[-1]
        assert 0.1 < ax.get_ylim()[1] < 0.2  # a 0.1 cm error fills the panel
        assert not [ln for ln in ax.lines if _at(ln, GOAL_ERROR_CM)]
        labels = [t.get_text() for t in ax.get_legend().get_texts()]
        assert any("goal 5 cm (off this scale: 50x" in label for label in labels)
    finally:
        plt.close(fig)
    fig = track_path_figure(_flight(0.03), title="large")  # 3 cm: the goal line in view
    try:
        ax = fig.axes[-1]
        assert GOAL_ERROR_CM < ax.get_ylim()[1] < 2 * GOAL_ERROR_CM
        assert [ln for ln in ax.lines if _at(ln, GOAL_ERROR_CM)]
    finally:
        plt.close(fig)


def test_flight_title_is_cut(tmp_path):
    from modquad_gym.sim.pictures import _plt
    from modquad_gym.sim.track_pictures import track_path_figure

    fig = track_path_figure(_flight(0.001), title="x" * 200)
    try:
        assert len(fig._suptitle.get_text()) <= MAX_TITLE_NAME
    finally:
        _plt().close(fig)


# --------------------------------------------------------------------------- MuJoCo scene
def test_model_has_a_sky_and_a_checker_floor():
    mujoco = pytest.importorskip("mujoco")
    from modquad_gym.sim.model import build_model

    model = build_model(Structure([(0, 0), (1, 0)])).model
    types = {int(t) for t in model.tex_type}
    assert int(mujoco.mjtTexture.mjTEXTURE_SKYBOX) in types
    floor = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_GEOM, "floor")
    material = model.geom_matid[floor]
    assert material >= 0 and model.mat_texuniform[material]
    rgb = int(mujoco.mjtTextureRole.mjTEXROLE_RGB)
    assert model.mat_texid[material, rgb] >= 0


def test_render_shows_a_blue_sky(tmp_path):
    pytest.importorskip("mujoco")
    from matplotlib.image import imread

    from modquad_gym.sim.pictures import render_structure

    path = tmp_path / "r.png"
    if render_structure(Structure([(0, 0)]), path, width=160, height=120) != "mujoco":
        pytest.skip("no GL context for MuJoCo here")
    top = imread(str(path))[:3, :, :3].reshape(-1, 3)
    assert top.mean() > 0.3 and (top[:, 2] > top[:, 0]).mean() > 0.9  # not black: blue sky


# --------------------------------------------------------------------------- validate
RECORD = {
    "n_modules": 12, "cells": [[i, 0] for i in range(12)], "modules": ["t45"] * 12,
    "mass_kg": 3.6, "task_kind": "total", "n_wrenches": 80, "n_feasible": 80,
    "min_margin": 0.12, "bench_max_error": 4e-14, "bench_max_error_pinv_clip": 0.3,
    "bench_pinv_clip_wrenches_missed": 7, "hover_seconds_per_wrench": 2.0,
    "hover_wrenches": 20, "hover_max_position_error_m": 9.5e-7,
    "hover_max_attitude_error_rad": 1e-8, "saturated_fraction": 0.0,
    "hover_diverged_segments": 0, "hover_segments_within_1cm": 20,
    "hover_takeoff": {"segment": -1, "gamma": 0.0}, "hover_unknown_load_max_position_error_m": 0.02,
    "hover_unknown_load_segments": [{"segment": 0, "gamma": 0.5}] * 20,
    "files": {"report": "/tmp/v/report.md", "hover": "/tmp/v/hover.png"},
}  # fmt: skip


def test_validate_prints_a_short_summary_and_json_unchanged(capsys):
    from modquad_gym.cli.validate import show

    args = argparse.Namespace(json=False, task="t.json", method="anytime")
    assert show(args, RECORD) == 0
    lines = capsys.readouterr().out.splitlines()
    assert len(lines) <= 8 and not any("{" in line for line in lines)  # no raw dicts
    text = "\n".join(lines)
    assert "12 modules" in text and "..." in text  # cells cut, all in validation.json
    assert "0.00095 mm" in text and "2 cm" in text and "7 wrenches missed" in text
    assert "wrote /tmp/v: report.md, hover.png" in text
    args.json = True
    show(args, RECORD)
    assert json.loads(capsys.readouterr().out) == {"task": "t.json", "method": "anytime",
                                                   **RECORD}  # fmt: skip
