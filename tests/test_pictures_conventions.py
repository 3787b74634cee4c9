"""The pictures' shared conventions: words number modules, rotors, task rows and segments from 1;
a mixed tier's structures figure draws each module's type; one spin colour in every renderer;
legends beside the data, not over it; the grid layout keeps a wide top view inside its figure."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from modquad_gym.geometry.module import palette
from modquad_gym.geometry.structure import Structure
from modquad_gym.viz.raster import FIRST_COLOUR, MODULE_COLOUR, SPIN_COLOURS

pytest.importorskip("matplotlib")


def test_page_hover_numbers_modules_and_rotors_from_one():
    pytest.importorskip("plotly")
    from modquad_gym.viz.interactive import structure_traces

    traces = structure_traces(Structure([(0, 0), (1, 0)]))
    text = [t for tr in traces for t in (tr.text or ()) if isinstance(t, str)]
    modules = {t.split(",")[0] for t in text if t.startswith("module")}
    rotors = {t.split(":")[0] for t in text if t.startswith("rotor")}
    assert {m.split(" (")[0] for m in modules} == {"module 1", "module 2"}, modules
    assert "rotor 1 (module 1)" in rotors and "rotor 8 (module 2)" in rotors, rotors
    assert not any(t.startswith(("module 0", "rotor 0")) for t in text)


def test_page_fills_modules_as_the_top_view():
    pytest.importorskip("plotly")
    from modquad_gym.viz.interactive import structure_traces

    meshes = [
        t for t in structure_traces(Structure([(0, 0), (1, 0), (2, 0)])) if t.type == "mesh3d"
    ]
    assert {t.name: t.color for t in meshes} == {
        "first module": FIRST_COLOUR,
        "module": MODULE_COLOUR,
    }
    mixed = Structure([(0, 0), (1, 0)], modules=palette("flat,t45"))
    names = [t.name for t in structure_traces(mixed)]
    assert "first module (thick outline)" in names and "module flat" in names


def test_validate_words_number_task_rows_and_segments_from_one():
    from modquad_gym.cli.validate import summary_lines
    from modquad_gym.sim.report_markdown import _demo_lines, _segment_table

    demo = {"from_task_row": 0, "diverged": False, "stop_time_s": None, "stop_reason": None,
            "gamma": 1.3, "saturated_fraction": 1.0, "max_position_error_m": 0.5,
            "max_attitude_error_rad": 0.1}  # fmt: skip
    assert "Task row 1 scaled" in "\n".join(_demo_lines(demo, 1.3))
    assert any("task row 1 scaled" in line for line in summary_lines({"infeasible_demo": demo}))
    seg = {"gamma": 0.5, "max_position_error_m": 0.0, "max_attitude_error_rad": 0.0,
           "saturated_fraction": 0.0, "stop_reason": None}  # fmt: skip
    hover = SimpleNamespace(segment_metrics=[{**seg, "segment": k} for k in (-1, 0, 1)])
    firsts = [row.split("|")[1].strip() for row in _segment_table(hover, None)[2:]]
    assert firsts == ["take-off", "1", "2"]


def _captured(monkeypatch, module) -> list:
    figures: list = []
    monkeypatch.setattr(module, "save_figure", lambda fig, *a, **k: figures.append(fig))
    return figures


def test_mixed_tier_structures_figure_draws_the_types(monkeypatch, tmp_path):
    from matplotlib.patches import FancyArrow

    from modquad_gym.scoring import agents_figures
    from modquad_gym.scoring.scores import Row

    figures = _captured(monkeypatch, agents_figures)
    types = palette("t45,t45m,flat")
    flat = Row("s", "t", 2, "exhaustive", True, 2, 1, 1, 0.1, [[0, 0, 2], [1, 0, 2]])
    agents_figures.plot_structures([flat], tmp_path / "s.png", modules=types)
    (ax,) = figures[0].axes
    assert not [p for p in ax.patches if isinstance(p, FancyArrow)]  # flat: no tilts drawn
    labels = [t.get_text() for t in figures[0].legends[0].get_texts()]
    assert {"module t45", "module t45m", "module flat"} <= set(labels), labels
    tilted = Row("s", "t", 2, "exhaustive", True, 2, 1, 1, 0.1, [[0, 0, 1], [1, 0, 0]])
    agents_figures.plot_structures([tilted], tmp_path / "t.png", modules=types)
    assert len([p for p in figures[1].axes[0].patches if isinstance(p, FancyArrow)]) == 8
    shape = Row("s", "t", 2, "exhaustive", True, 2, 1, 1, 0.1, [[0, 0], [1, 0]])  # no types
    agents_figures.plot_structures([shape], tmp_path / "u.png", modules=types)
    assert not [p for p in figures[2].axes[0].patches if isinstance(p, FancyArrow)]
    assert "not recorded" in figures[2].legends[0].get_title().get_text()


def test_one_spin_colour_in_every_renderer(monkeypatch, tmp_path):
    from matplotlib.colors import to_hex

    from modquad_gym.sim import pictures

    s = Structure([(0, 0), (1, 0)])
    figures = _captured(monkeypatch, pictures)
    monkeypatch.setattr(pictures._plt(), "close", lambda fig: None)
    pictures._render_matplotlib(s, tmp_path / "s.png")
    seen = {to_hex(c.get_color()[0]) for c in figures[0].axes[0].collections}  # the quivers
    assert seen == set(SPIN_COLOURS.values()), seen
    pytest.importorskip("mujoco")
    from modquad_gym.sim.model import build_model
    from modquad_gym.viz.raster import rgba

    sim = build_model(s)
    for k, spin in enumerate(s.rotor_spins):
        disc = sim.model.geom(f"disc{k}")
        assert np.allclose(disc.rgba, rgba(SPIN_COLOURS[1 if spin > 0 else -1], 0.9), atol=1e-6)


def test_time_series_legends_stand_beside_the_axes():
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    from modquad_gym.sim.pictures import inputs_panel

    fig = Figure(figsize=(6, 3))
    FigureCanvasAgg(fig)
    ax = fig.add_subplot()
    inputs_panel(fig, ax, np.linspace(0, 1, 5), np.ones((5, 4)), 1.0)
    r = fig.canvas.get_renderer()
    assert ax.get_legend().get_window_extent(r).x0 >= ax.get_window_extent(r).x1


def test_grid_layout_keeps_a_wide_top_view_inside_the_figure(monkeypatch, tmp_path):
    from modquad_gym.viz import drawing

    figures = _captured(monkeypatch, drawing)
    s = Structure([(i, j) for i in range(16) for j in range(8)])
    W = np.array([[0.0, 0.0, 20.0, 0.0, 0.0, 0.0], [1.0, 0.0, 30.0, 0.0, 0.0, 0.0]])
    drawing.save_structure_figure(s, tmp_path / "g.png", task=W, layout="grid")
    fig = figures[0]
    fig.set_dpi(120)
    fig.canvas.draw()
    box = fig.axes[0].get_tightbbox(fig.canvas.get_renderer())  # the top view with its legend
    assert box.x0 >= -0.5 and box.x1 <= fig.bbox.width + 0.5, (box, fig.bbox.width)


def test_mujoco_render_keeps_the_first_module_apart_from_the_others():
    """The first module is told from the others in MuJoCo's render itself (its lighting washed
    the pale picture fills to white), by the mean colour of each module's rendered pixels."""
    mujoco = pytest.importorskip("mujoco")
    from modquad_gym.sim.model import build_model

    sim = build_model(Structure([(0, 0), (1, 0), (0, 1), (1, 1)]))
    data = sim.new_data()
    mujoco.mj_forward(sim.model, data)
    try:
        renderer = mujoco.Renderer(sim.model, 240, 320)
    except Exception as exc:  # no GL context on this machine
        pytest.skip(f"no offscreen GL: {exc}")
    cam = mujoco.MjvCamera()
    cam.lookat[:], cam.distance, cam.azimuth, cam.elevation = [0, 0, 1], 2.0, 135.0, -35.0
    renderer.update_scene(data, camera=cam)
    img = renderer.render().astype(float)
    renderer.enable_segmentation_rendering()
    renderer.update_scene(data, camera=cam)
    seg = renderer.render()
    renderer.close()
    means = []
    for i in range(4):
        gid = mujoco.mj_name2id(sim.model, mujoco.mjtObj.mjOBJ_GEOM, f"module{i}")
        mask = (seg[..., 0] == gid) & (seg[..., 1] == int(mujoco.mjtObj.mjOBJ_GEOM))
        assert mask.sum() > 500, (i, mask.sum())
        means.append(img[mask].mean(axis=0))
    others = np.mean(means[1:], axis=0)
    assert np.abs(means[0] - others).max() > 30, (means[0], others)
    assert means[0][1] > means[0][0] + 30, means[0]  # green: its green channel above its red
