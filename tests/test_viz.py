"""Pictures: each drawing function produces a non-empty picture; the force and torque hulls are
exact; the labels say what a projection shows and in which units."""

from __future__ import annotations

import time

import numpy as np
import pytest

from modquad_gym import Structure, TaskRequirement, allocate
from modquad_gym.geometry.module import STOCK_TYPES
from modquad_gym.tasks import PaperTasks, ScrewdriverTask
from modquad_gym.viz.drawing import (
    draw_projection,
    draw_rotor_inputs,
    draw_structure,
    draw_torque_projection,
    force_zonotope_vertices,
    save_structure_figure,
    structure_image,
    torque_zonotope_vertices,
)
from modquad_gym.viz.zonotope import hull_faces, projection_vertices, units

CELLS = [(0, 0), (1, 0), (1, 1), (2, 1), (0, -1)]


def _non_white_fraction(rgb: np.ndarray) -> float:
    rgb = np.asarray(rgb, dtype=float)
    if rgb.max() <= 1.0:
        rgb = rgb * 255.0
    return float((rgb[..., :3] < 250).any(axis=-1).mean())


def _png_pixels(path) -> np.ndarray:
    from matplotlib.image import imread

    img = imread(str(path))
    assert img.ndim == 3 and img.shape[0] > 100 and img.shape[1] > 100
    return img


def _axes_pixels(ax) -> np.ndarray:
    canvas = ax.figure.canvas
    canvas.draw()
    return np.asarray(canvas.buffer_rgba())


def test_draw_structure(tmp_path):
    s = Structure(CELLS)
    ax = draw_structure(s, title="five")
    assert ax.get_title() == "five"
    assert len(ax.patches) >= s.n_modules + 4 * s.n_modules  # squares and rotors (and arrows)
    x0, x1 = ax.get_xlim()
    assert x0 < s.module_centres[:, 0].min() and x1 > s.module_centres[:, 0].max()
    assert 0.02 < _non_white_fraction(_axes_pixels(ax)) < 0.9
    path = tmp_path / "top.png"
    ax.figure.savefig(path)
    assert _non_white_fraction(_png_pixels(path)) > 0.02


@pytest.mark.parametrize("space", ["force", "torque"])
def test_projection_vertices_match_the_support_function(space):
    rows = slice(0, 3) if space == "force" else slice(3, 6)
    flat = STOCK_TYPES["flat"]  # every thrust along z: a flat force projection (a segment)
    for s in (Structure([(0, 0)]), Structure([(0, 0), (1, 0)]), Structure(CELLS),
              Structure([(0, 0), (1, 0)], module=flat)):  # fmt: skip
        A = s.configuration_matrix()
        for f_max in (1.0, 2.0):
            V = projection_vertices(A, space, f_max)
            D = np.random.default_rng(0).normal(size=(3000, 3))
            exact = np.maximum(D @ A[rows], 0.0).sum(axis=1) * f_max
            assert np.allclose((D @ V.T).max(axis=1), exact, atol=1e-9)
    assert np.array_equal(torque_zonotope_vertices(A), projection_vertices(A, "torque"))
    assert np.array_equal(force_zonotope_vertices(A), projection_vertices(A, "force"))
    assert hull_faces(projection_vertices(A, "force")) is None  # the flat type's segment


def test_projection_labels_say_what_and_which_units():
    s = Structure(CELLS)
    normalised = PaperTasks(n_wrenches=5)(np.random.default_rng(0))
    ax = draw_projection(s, "force", task=normalised)
    assert ax.get_title() == "feasible forces: projection of the 6-D set"
    assert ax.get_xlabel() == r"$f_x$ [$f_\mathrm{max}$]"  # f_max with a subscript
    legend = {t.get_text() for t in ax.get_legend().get_texts()}
    feasible, infeasible = "task wrench, feasible (6-D)", "task wrench, infeasible (6-D)"
    assert feasible in legend and legend <= {feasible, infeasible, "vertex of the projection"}
    external = TaskRequirement([[0, 0, 2.0, 0, 0, 0.05]], kind="external", f_max=2.0)
    ax = draw_projection(s, "torque", task=external)
    assert ax.get_zlabel() == r"$\tau_z$ [N m]"
    assert units(TaskRequirement([[0, 0, 2.0, 0, 0, 0]], f_max=3.0)) == ("N", "N m")


def test_draw_torque_projection(tmp_path):
    s = Structure(CELLS)
    task = PaperTasks(n_wrenches=20)(np.random.default_rng(0))
    ax = draw_torque_projection(s, f_max=1.0, wrenches=task.wrenches)
    assert ax.name == "3d"
    assert len(ax.collections) >= 2  # the hull and the scatters
    assert _non_white_fraction(_axes_pixels(ax)) > 0.02
    with pytest.raises(ValueError):
        draw_torque_projection(s, wrenches=np.ones((2, 5)))


def test_structure_image_shape_determinism_and_status():
    s = Structure(CELLS)
    img = structure_image(s)
    assert img.shape == (256, 256, 3) and img.dtype == np.uint8
    assert 0.05 < _non_white_fraction(img) < 0.9
    assert np.array_equal(img, structure_image(s))
    small = structure_image(Structure([(0, 0)]), size=(64, 96))
    assert small.shape == (64, 96, 3) and _non_white_fraction(small) > 0.02
    status = np.array([True, False, True, True])
    with_status = structure_image(s, size=(120, 160), wrench_status=status)
    bottom = with_status[-3:].reshape(-1, 3)
    green = np.all(bottom == (44, 160, 44), axis=1).any()
    red = np.all(bottom == (214, 39, 40), axis=1).any()
    assert green and red
    margins = structure_image(s, size=(120, 160), wrench_status=np.array([0.3, -0.1, 0.0, 1.0]))
    assert np.array_equal(margins, with_status)


def test_structure_image_is_fast():
    s = Structure([(i, j) for i in range(3) for j in range(2)] + [(3, 0)])
    structure_image(s)
    t0 = time.perf_counter()
    for _ in range(10):
        structure_image(s)
    per_call = (time.perf_counter() - t0) / 10
    assert per_call < 0.1, f"structure_image took {per_call * 1e3:.1f} ms"


def test_structure_image_rejects_bad_input():
    with pytest.raises(ValueError):
        structure_image(Structure([(0, 0)]), size=(8, 8))
    with pytest.raises(ValueError):
        structure_image(Structure([(0, 0)]), size=256)
    with pytest.raises(ValueError):
        structure_image([(0, 0)])


@pytest.mark.parametrize("with_task", [False, True])
def test_save_structure_figure(tmp_path, with_task):
    s = Structure([(0, 0), (1, 0), (2, 0)])
    task = ScrewdriverTask()(np.random.default_rng(0)) if with_task else None
    path = save_structure_figure(s, tmp_path / "fig.png", task=task)
    img = _png_pixels(path)
    assert _non_white_fraction(img) > 0.02
    if with_task:
        assert img.shape[1] > 2.5 * img.shape[0]  # top view, forces, torques side by side


def test_draw_rotor_inputs(tmp_path):
    s = Structure([(0, 0), (1, 0), (2, 0)])
    task = ScrewdriverTask()(np.random.default_rng(0))
    U = np.array([allocate(s.configuration_matrix(), w)[0] for w in task.wrenches])
    ax = draw_rotor_inputs(U, f_max=1.0)
    assert len(ax.lines) == U.shape[1] + 2  # one per rotor, f_max and zero lines
    assert ax.get_ylim()[1] >= 1.0
    path = tmp_path / "u.png"
    ax.figure.savefig(path)
    assert _non_white_fraction(_png_pixels(path)) > 0.01
    with pytest.raises(ValueError):
        draw_rotor_inputs(np.zeros((0, 4)))
    with pytest.raises(ValueError):
        draw_rotor_inputs(U, f_max=0.0)
