"""Pictures readable at 3 and 64 modules: the env's ``rgb_array`` frame fills the frame with the
structure and keeps the rotors' spin colours visible; the saved top view grows with the
structure; the interactive page summarises its structure instead of listing it."""

from __future__ import annotations

import numpy as np
import pytest

from modquad_gym import Structure
from modquad_gym.viz.drawing import INCHES_PER_MODULE, TOP_VIEW_INCHES, top_view_inches
from modquad_gym.viz.raster import ARROW_COLOUR, SPIN_COLOURS, structure_image

ZIGZAG_41 = [(k // 2 + k % 2, k // 2) for k in range(41)]
"""41 modules in a staircase: long and thin, the shape of the frame that was a red zigzag."""

BLOCK_64 = [(i, j) for i in range(8) for j in range(8)]


def _rgb(colour: str) -> np.ndarray:
    return np.array([int(colour[k : k + 2], 16) for k in (1, 3, 5)])


def _fraction(img: np.ndarray, colour: str) -> float:
    return float(np.all(img == _rgb(colour), axis=-1).mean())


def _drawn_box(img: np.ndarray) -> tuple[int, int]:
    """(height, width) in pixels of the non-white part."""
    rows, cols = np.nonzero((img < 250).any(axis=-1))
    return rows.max() - rows.min() + 1, cols.max() - cols.min() + 1


@pytest.mark.parametrize("cells", [ZIGZAG_41, BLOCK_64], ids=["zigzag41", "block64"])
def test_large_frame_fills_the_frame_and_shows_spins(cells):
    img = structure_image(Structure(cells), size=(256, 256))
    assert img.shape == (256, 256, 3)
    h, w = _drawn_box(img)
    assert max(h, w) >= 0.9 * 256  # the structure's extent fills the frame
    spins = [_fraction(img, SPIN_COLOURS[k]) for k in (1, -1)]
    assert min(spins) > 0.01, spins  # both spin colours visible
    assert _fraction(img, ARROW_COLOUR) < 0.2 * min(spins)  # arrows do not cover them


def test_small_frame_keeps_its_arrows_and_is_not_blown_up():
    img = structure_image(Structure([(0, 0), (1, 0), (0, 1)]), size=(256, 256))
    assert _fraction(img, ARROW_COLOUR) > 0.002  # thrust arrows drawn at this size
    h, w = _drawn_box(img)
    assert max(h, w) <= 0.5 * 256  # three modules: at most 2 of the view's 5 sides, plus arrows
    assert min(_fraction(img, SPIN_COLOURS[k]) for k in (1, -1)) > 0.005


def test_top_view_grows_with_the_structure():
    lo, hi = TOP_VIEW_INCHES
    small = top_view_inches(Structure([(0, 0), (1, 0), (0, 1)]))
    assert max(small) == pytest.approx(lo)
    wide = top_view_inches(Structure([(i, j) for i in range(16) for j in range(4)]))
    assert wide == pytest.approx((INCHES_PER_MODULE * 16.5, INCHES_PER_MODULE * 4.5))
    line = top_view_inches(Structure([(i, 0) for i in range(64)]))
    assert max(line) == pytest.approx(hi) and line[1] < line[0]


def test_saved_top_view_is_readable_at_64_modules(tmp_path):
    from matplotlib.image import imread

    from modquad_gym.viz.drawing import save_structure_figure

    path = save_structure_figure(Structure(BLOCK_64), tmp_path / "top.png")
    img = imread(path)
    # 120 dpi: at least 0.45 inch (54 px) per module side, so a rotor is >= 13 px across
    assert img.shape[0] >= 8.5 * 54 and img.shape[1] >= 8.5 * 54


def test_page_header_summarises_the_structure():
    pytest.importorskip("plotly")
    from modquad_gym.viz.interactive import structure_page, structure_summary

    s = Structure(BLOCK_64)
    assert structure_summary(s) == (
        "64 modules (64 x T(eta=0.7854)), 19.2 kg; bounding box 8 x 8 cells (3.2 m x 3.2 m)"
    )
    page = structure_page(s)
    head = page[: page.index("<details>")]
    assert "T(eta=0.7854)" in head and head.count("T(eta") == 1  # no list of 64 types
    assert "(7, 7)" not in head  # the cells are folded into <details>
    assert len(page) < 2_300_000, len(page)  # plotly.js gzipped (4.8 MB as plotly inlines it)
    assert "DecompressionStream" in page and "<script src=" not in page


def test_page_at_64_modules_renders_in_headless_chromium(tmp_path):
    """The packed plotly.js unpacks and draws the three views (no error, no network)."""
    pytest.importorskip("plotly")
    sync_api = pytest.importorskip("playwright.sync_api")
    from tests.test_interactive import CHROMIUM, CHROMIUM_FLAGS

    if CHROMIUM is None:
        pytest.skip("no chromium (apt-get install chromium; .ci/run installs it)")
    from modquad_gym.viz.interactive import save_structure_page

    path = save_structure_page(Structure(BLOCK_64), tmp_path / "page.html")
    errors, requests = [], []
    with sync_api.sync_playwright() as p:
        browser = p.chromium.launch(executable_path=CHROMIUM, args=CHROMIUM_FLAGS)
        try:
            page = browser.new_page(viewport={"width": 1500, "height": 900})
            page.on("console", lambda m: errors.append(m.text) if m.type == "error" else None)
            page.on("pageerror", lambda e: errors.append(str(e)))
            page.on("request", lambda r: requests.append(r.url))
            page.goto(tmp_path.joinpath("page.html").as_uri())
            page.wait_for_selector(".js-plotly-plot .gl-container canvas", timeout=60_000)
            n_scenes = page.evaluate("document.querySelector('.js-plotly-plot')._fullLayout"
                                     "._subplots.gl3d.length")  # fmt: skip
        finally:
            browser.close()
    assert errors == [] and n_scenes == 3
    assert [url for url in requests if not url.startswith("file:")] == []
    assert path.endswith("page.html")


# ----------------------------------------------------------------------- the reports' plots
def test_benchmark_bars_have_y_labels_and_a_legend(tmp_path, monkeypatch):
    from matplotlib.figure import Figure

    from modquad_gym.scoring import agents_figures

    figures = []
    monkeypatch.setattr(agents_figures, "save_figure", lambda fig, *a, **k: figures.append(fig))
    summary = [
        {"method": m, "tasks": 10, "success_rate": 0.9, "optimal_share": 0.5,
         "mean_evaluated": 12.0, "mean_seconds": 0.05}
        for m in ("exhaustive", "greedy", "ppo")
    ]  # fmt: skip
    agents_figures.plot_bars(summary, tmp_path / "bars.png")
    (fig,) = figures
    assert isinstance(fig, Figure)
    assert all(ax.get_ylabel() for ax in fig.axes)
    labels = {t.get_text() for t in fig.legends[0].get_texts()}
    assert labels == {"search", "learned (ppo and variants)"}
    assert fig.axes[0].get_ylim() == (0, 105)  # shares from zero


def test_learning_curve_keeps_the_full_success_axis(tmp_path):
    from matplotlib.image import imread

    from modquad_gym.scoring.agents_figures import plot_learning_curve

    evals = tmp_path / "evaluations.npz"
    rng = np.random.default_rng(0)
    np.savez(evals, timesteps=np.arange(0, 5000, 1000), results=1.6 + rng.normal(0, 0.01, (5, 8)),
             successes=np.ones((5, 8)))  # fmt: skip
    path = plot_learning_curve(evals, tmp_path / "curve.png")
    assert imread(path).shape[1] > 1000


def test_seed_intervals_start_at_zero_and_show_a_zero_width_interval(tmp_path, monkeypatch):
    from modquad_gym.scoring import seeds_report as seeds
    from modquad_gym.scoring.seed_scores import SeedScore

    figures = []
    monkeypatch.setattr(seeds, "save_figure", lambda fig, path: figures.append(fig) or path)
    scores = [
        SeedScore(str(k), m, "suite", 10, 1.0 if m == "ppo-guided" else 0.98 + 0.005 * k,
                        0.9, 5.0 + k, 0.1)
        for k in range(5) for m in ("ppo", "ppo-guided")
    ]  # fmt: skip
    seeds.plot(scores, tmp_path / "seeds.png")
    (fig,) = figures
    success, share, configs = fig.axes
    assert success.get_xlim() == (0, 105) and share.get_xlim() == (0, 105)
    assert configs.get_xlim()[0] == 0
    dots = [line for line in success.lines if line.get_marker() == "o"]
    assert len(dots) == 2  # ppo-guided's zero-width interval is still a dot
    assert any("100.0 [100.0, 100.0]" in t.get_text() for t in success.texts)


def test_scale_gap_compares_methods_on_the_same_solved_tasks(tmp_path):
    from benchmarks.scale_report import common_solved, plot

    def row(band, task, method, found, gap):
        return {"band": band, "task": task, "method": method, "found": found,
                "gap_to_bound": gap}  # fmt: skip

    rows = [row(16, "a", "ppo", 10, 1), row(16, "b", "ppo", "none", ""),
            row(16, "a", "ppo-guided", 10, 1), row(16, "b", "ppo-guided", 12, 3),
            row(32, "c", "ppo", 20, 0), row(32, "c", "ppo-guided", 20, 0)]  # fmt: skip
    assert common_solved(rows, ["ppo", "ppo-guided"]) == {16: ["a"], 32: ["c"]}
    plot(rows, tmp_path / "gap.png")  # ppo and ppo-guided equal: side by side, both drawn
    assert (tmp_path / "gap.png").stat().st_size > 10_000


def test_bench_axes_never_zoom_into_rounding_noise():
    from modquad_gym.sim.pictures import bench_limits

    commanded = np.zeros(5)  # a component the task never asks for
    measured = np.array([1e-13, -2e-13, 0.0, 3e-14, 0.0])
    lo, hi = bench_limits(commanded, measured)
    assert hi - lo >= 1e-7  # not 1e-13
    lo, hi = bench_limits(commanded, measured, scale=3.5)  # at the scale of the other forces
    assert hi - lo >= 0.35 and lo < 0 < hi
    lo, hi = bench_limits(np.array([3.0, 3.0]), np.array([3.0 + 1e-13, 3.0]))
    assert hi - lo >= 0.1 * 3.0 and lo < 3.0 < hi


def test_grid_layout_is_readable_at_the_docs_width(tmp_path):
    """The docs show a picture about 700 px wide: the grid layout's text then keeps >= 70 % of
    its size at 120 dpi (10 pt text 12 px or more)."""
    from matplotlib.image import imread

    from modquad_gym.tasks import ScrewdriverTask
    from modquad_gym.viz.drawing import save_structure_figure

    task = ScrewdriverTask()(np.random.default_rng(0))
    s = Structure([(0, 0), (1, 0), (0, 1)])
    grid = imread(save_structure_figure(s, tmp_path / "grid.png", task=task, layout="grid"))
    assert grid.shape[1] <= 700 / 0.7 + 1
    with pytest.raises(ValueError, match="layout"):
        save_structure_figure(s, tmp_path / "x.png", task=task, layout="column")


def test_figures_find_the_training_run_a_report_names():
    from pathlib import Path

    from benchmarks.figures import training_run

    made = "Made by `modquad score --model m/model.zip --train-dir runs/a --out x`."
    assert training_run(made) == Path("runs/a")
    assert training_run("model: `modquad_gym/data/models/ppo_default/model.zip` (trained") == Path(
        "modquad_gym/data/models/ppo_default"
    )
    assert training_run("no model") is None


def test_committed_paper_rotor_inputs_is_what_the_benchmark_draws(tmp_path):
    """results/paper_rotor_inputs.png (paper Fig. 7) is the picture ``benchmarks.paper`` draws
    now from the same task (seed 0, the first with both answers): its axis labels are those of
    ``viz.drawing.draw_rotor_inputs`` (thrust in N), not an older drawing's. A stale label moves
    every panel and changes ~7 % of the pixels. Only the left panels (pinv + clip, a unique
    least-squares answer) are compared: the right ones draw the most centred exact allocation,
    an LP whose optimal face holds many allocations, and HiGHS returns another vertex on another
    CPU (the centrosymmetric panel's max u: 0.914 on the AMD machine that drew the committed
    picture, 0.908 on an Intel one)."""
    from pathlib import Path

    from PIL import Image

    from benchmarks.paper import run

    run(1, tmp_path)
    name = "paper_rotor_inputs.png"
    committed = Path(__file__).resolve().parents[1] / "results" / name
    old, new = (np.asarray(Image.open(p).convert("RGB")).astype(int)
                for p in (committed, tmp_path / name))  # fmt: skip
    assert old.shape == new.shape
    left = old.shape[1] // 2
    assert (np.abs(old[:, :left] - new[:, :left]) > 32).any(axis=-1).mean() < 0.01
