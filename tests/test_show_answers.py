"""``modquad show`` draws every answer the searches give: a dynamic task's (its wrenches depend on
the structure), up to the searches' 128 modules, and none (one line, exit 2, as export); its
``--cells`` count from 1 and take a type per cell; the PNG and the HTML page stay readable (thrust
arrows seen at 64 modules, projections as tall as a tall top view, no colliding tick labels,
subscripts in the page, its views not cut at 1400 pixels)."""

from __future__ import annotations

import json

import numpy as np
import pytest

from modquad_gym import Structure, TaskRequirement
from modquad_gym.cli import main
from modquad_gym.geometry.module import STOCK_TYPES as T
from modquad_gym.viz import drawing


def _one_error_line(capsys, argv: list[str]) -> str:
    assert main(argv) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "Traceback" not in err, err
    return err


def _saved_figure(monkeypatch, tmp_path, structure, task, layout="row"):
    """The matplotlib figure ``save_structure_figure`` saves (drawn, not written)."""
    figures = []
    monkeypatch.setattr(drawing, "save_figure", lambda fig, *a, **k: figures.append(fig))
    drawing.save_structure_figure(structure, tmp_path / "x.png", task=task, layout=layout)
    (fig,) = figures
    fig.canvas.draw()
    return fig


# ---------------------------------------------------------------------- answers show draws
def test_show_draws_a_dynamic_tasks_answer(tmp_path, capsys):
    """The wrenches of a dynamic task depend on the structure: drawn, not a traceback."""
    from modquad_gym.tasks import load_task
    from modquad_gym.viz.interactive import projection_traces

    circle = tmp_path / "circle.json"
    assert main(["task", "motion", "--kind", "circle", "--radius", "1", "--speed", "1",
                 "--rate", "20", "--out", str(circle)]) == 0  # fmt: skip
    png = tmp_path / "circle.png"
    assert main(["show", "--task", str(circle), "--n-max", "8", "--out", str(png)]) == 0
    assert png.stat().st_size > 10_000 and "optimal" in capsys.readouterr().out
    task, s = load_task(circle), Structure([(0, 0), (1, 0), (0, 1)])
    points = [t for t in projection_traces(s, "force", task) if t.name.startswith("task")]
    drawn = np.concatenate([np.c_[t.x, t.y, t.z] for t in points])
    assert len(drawn) == task.n_wrenches  # the rotors' wrenches for this structure
    assert np.allclose(np.sort(drawn, axis=0), np.sort(task.rotor_wrenches(s)[:, :3], axis=0),
                       atol=1e-4)  # fmt: skip


def test_show_draws_128_modules_with_their_projections(tmp_path, capsys):
    cells = [(i, j) for i in range(16) for j in range(8)]
    task = tmp_path / "lift.json"
    task.write_text(json.dumps({"wrenches": [[0, 0, 300, 0, 0, 0]], "name": "lift"}))
    png = tmp_path / "big.png"
    argv = ["show", "--cells", json.dumps(cells), "--task", str(task), "--out", str(png)]
    assert main(argv) == 0
    assert png.stat().st_size > 50_000 and capsys.readouterr().err == ""


def test_show_without_an_answer_writes_nothing_and_fails_as_export(tmp_path, capsys):
    png, out = tmp_path / "z.png", tmp_path / "z.json"
    argv = ["--task", "example:screwdriver", "--method", "exhaustive", "--n-max", "2"]
    err = _one_error_line(capsys, ["show", *argv, "--out", str(png)])
    assert "found no structure of up to 2 modules" in err
    assert err.endswith("nothing to draw, no file written")
    assert not png.exists()
    assert "nothing to export" in _one_error_line(capsys, ["export", *argv, "--out", str(out)])


def test_cells_count_from_one_and_take_a_type_per_cell(tmp_path, capsys):
    err = _one_error_line(capsys, ["show", "--cells", "[[0,0],[1.5,0]]"])
    assert "cell #2 [1.5, 0]" in err  # the second cell, as task-file rows count
    png = tmp_path / "mixed.png"
    argv = ["show", "--cells", "[[0,0],[1,0],[2,0]]", "--modules", "t45,flat,t45", "--out"]
    assert main([*argv, str(png)]) == 0 and png.exists()  # a type on two cells
    assert "modules=['t45', 'flat', 't45']" in capsys.readouterr().out


# ---------------------------------------------------------------------------- the picture
def test_thrust_arrows_are_seen_at_64_modules(tmp_path):
    from matplotlib.image import imread

    from modquad_gym.viz.raster import ARROW_COLOUR, SPIN_COLOURS

    cells = [(i, j) for i in range(8) for j in range(8)]
    img = imread(drawing.save_structure_figure(Structure(cells), tmp_path / "top.png"))[..., :3]

    def share(colour: str) -> float:
        rgb = np.array([int(colour[k : k + 2], 16) for k in (1, 3, 5)]) / 255
        return float((np.abs(img - rgb).max(axis=-1) < 0.08).mean())

    assert share(ARROW_COLOUR) > 0.15 * share(SPIN_COLOURS[1])  # was 0.05: thin slivers


def test_projections_stack_beside_a_tall_top_view(monkeypatch, tmp_path):
    """A tall structure's two projections fill the column beside it, not a quarter of it."""
    s = Structure([(0, j) for j in range(30)] + [(i, 29) for i in range(1, 6)])
    fig = _saved_figure(monkeypatch, tmp_path, s, TaskRequirement([[0, 0, 30.0, 0, 0, 0]]))
    top, force, torque = (ax.get_position() for ax in fig.axes)
    assert force.y0 > torque.y1 - 0.01 and abs(force.x0 - torque.x0) < 0.01  # one column
    assert force.height > 0.35 and torque.height > 0.35  # each about half the figure's height
    assert force.x0 > top.x1


MIXED_38 = (
    [(-i, 0) for i in range(23)] + [(0, -1), (0, 1), (-22, 1), (-22, -1), (-22, -2), (-22, 2),
    (-22, 3), (0, 2), (0, -2), (1, 0), (-22, 4), (0, -3), (-22, 5), (-22, -3), (-23, -3)]
)  # fmt: skip
"""The greedy answer to mixed-64-0 of the review: 10 m x 3.6 m, 23 + 1 t45 and 14 flat."""


def _visible_tick_labels(axis, renderer) -> list:
    lo, hi = sorted(axis.get_view_interval())
    return [tick.label1.get_window_extent(renderer)
            for loc, tick in zip(axis.get_majorticklocs(), axis.get_major_ticks())
            if lo <= loc <= hi and tick.label1.get_text()]  # fmt: skip


def test_projection_tick_labels_do_not_run_into_each_other(monkeypatch, tmp_path):
    """The torque projection's x tick "50" and y tick "-200" met at their shared corner."""
    s = Structure(MIXED_38, modules=[T["t45"]] * 23 + [T["flat"]] * 14 + [T["t45"]])
    task = TaskRequirement([[0, 0, 100.0, 0, 0, 0]])
    fig = _saved_figure(monkeypatch, tmp_path, s, task, layout="grid")
    renderer = fig.canvas.get_renderer()
    for ax in fig.axes[1:]:
        boxes = [_visible_tick_labels(a, renderer) for a in (ax.xaxis, ax.yaxis, ax.zaxis)]
        assert all(len(b) >= 2 for b in boxes)
        for i in range(3):
            for j in range(i + 1, 3):
                assert not any(a.overlaps(b) for a in boxes[i] for b in boxes[j]), ax.get_title()


# ---------------------------------------------------------------------------- the page
def test_page_titles_use_subscripts_and_short_axes_few_ticks():
    pytest.importorskip("plotly")
    from modquad_gym.viz.interactive import structure_figure

    s = Structure(MIXED_38, modules=[T["t45"]] * 23 + [T["flat"]] * 14 + [T["t45"]])
    fig = structure_figure(s, TaskRequirement([[0, 0, 100.0, 0, 0, 0]]))
    titles = [fig.layout[f"scene{k}"][f"{a}axis"].title.text for k in (2, 3) for a in "xyz"]
    assert titles[0] == "f<sub>x</sub> [f<sub>max</sub>]"
    assert titles[5] == "τ<sub>z</sub> [f<sub>max</sub>·m]"
    assert not any("_" in t for t in titles)
    assert "[f<sub>max</sub>]" in fig.layout.annotations[1].text
    scene = fig.layout.scene  # the structure view: 10.4 m long, 4.4 m wide
    assert scene.xaxis.nticks == 7 and scene.yaxis.nticks <= 3


def test_page_views_are_not_cut_in_a_narrow_window(tmp_path):
    """A 3-D view fills its height: taller than its third of the page, it was cut at the sides
    (the z axis titles at 1400 px). The page sets its height from its width."""
    pytest.importorskip("plotly")
    sync_api = pytest.importorskip("playwright.sync_api")
    from tests.test_interactive import CHROMIUM, CHROMIUM_FLAGS

    if CHROMIUM is None:
        pytest.skip("no chromium (apt-get install chromium; .ci/run installs it)")
    from modquad_gym.viz.interactive import save_structure_page

    path = save_structure_page(Structure([(0, 0), (1, 0)]), tmp_path / "page.html")
    shapes = {}
    with sync_api.sync_playwright() as p:
        browser = p.chromium.launch(executable_path=CHROMIUM, args=CHROMIUM_FLAGS)
        try:
            page = browser.new_page(viewport={"width": 1000, "height": 900})
            page.goto(tmp_path.joinpath("page.html").as_uri())
            page.wait_for_selector(".js-plotly-plot .gl-container canvas", timeout=60_000)
            size = ("(() => { const l = document.querySelector('.js-plotly-plot')._fullLayout;"
                    " return [l._size.w * (l.scene2.domain.x[1] - l.scene2.domain.x[0]),"
                    " l._size.h]; })()")  # fmt: skip
            shapes[1000] = page.evaluate(size)
            page.set_viewport_size({"width": 1400, "height": 900})  # the review's window
            page.wait_for_timeout(500)
            shapes[1400] = page.evaluate(size)
        finally:
            browser.close()
    for width, (w, h) in shapes.items():
        assert h <= 1.0 * w, (width, w, h)  # a view no taller than wide: nothing cut
    assert shapes[1400][1] > shapes[1000][1]  # resizing the window resizes the views
    assert path.endswith("page.html")
