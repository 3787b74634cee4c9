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
