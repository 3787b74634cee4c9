"""The interactive page: one self-contained HTML file that a real browser (headless Chromium)
renders without console errors and without any network request."""

from __future__ import annotations

import shutil

import numpy as np
import pytest

from modquad_gym import Structure, TaskRequirement
from modquad_gym.cli import main
from modquad_gym.geometry.module import STOCK_TYPES as T

pytest.importorskip("plotly")

CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")
CHROMIUM_FLAGS = ["--headless=new", "--no-sandbox", "--disable-gpu",
                  "--disable-background-networking", "--disable-extensions", "--no-first-run",
                  "--use-angle=swiftshader", "--enable-unsafe-swiftshader"]  # fmt: skip
"""Headless, no GPU: WebGL (plotly's 3-D scenes) on SwiftShader, the software renderer."""


def test_page_is_self_contained_and_labels_the_projections():
    from modquad_gym.viz.interactive import structure_figure, structure_page

    s = Structure([(0, 0), (1, 0), (0, 1)], modules=[T["t45"], T["flat"], T["t45m"]])
    task = TaskRequirement([[0, 0, 2.0, 0, 0, 0.05], [20.0, 0, 2.0, 0, 0, 0]], kind="external",
                           f_max=2.0, name="push")  # fmt: skip
    page = structure_page(s, task)
    assert page.startswith("<!DOCTYPE html>") and "<script src=" not in page
    assert "Plotly.newPlot" in page and len(page) > 1_000_000  # plotly.js inline
    fig = structure_figure(s, task)
    titles = [a.text for a in fig.layout.annotations]
    assert titles[1] == "feasible forces [N]: projection of the 6-D set"
    assert titles[2] == "feasible torques [N m]: projection of the 6-D set"
    names = {t.name for t in fig.data}
    assert {"task wrench, feasible (6-D)", "task wrench, infeasible (6-D)"} <= names
    cones = [t for t in fig.data if t.type == "cone"]
    assert len(cones) == 1 and len(cones[0].u) == 12  # one thrust direction per rotor
    np.testing.assert_allclose(
        np.c_[cones[0].u, cones[0].v, cones[0].w] / (0.4 * s.side), s.rotor_directions, atol=1e-3
    )


def test_show_html_opens_in_headless_chromium(tmp_path):
    sync_api = pytest.importorskip("playwright.sync_api")
    if CHROMIUM is None:
        pytest.skip("no chromium (apt-get install chromium; .ci/run installs it)")
    page_path = tmp_path / "view.html"
    assert main(["show", "--task", "example:screwdriver", "--html", str(page_path)]) == 0
    assert not (tmp_path / "structure.png").exists()  # --html alone writes only the page
    assert main(["show", "--task", "example:screwdriver", "--html", str(page_path)]) == 2
    errors, requests = [], []
    with sync_api.sync_playwright() as p:
        browser = p.chromium.launch(executable_path=CHROMIUM, args=CHROMIUM_FLAGS)
        try:
            page = browser.new_page(viewport={"width": 1500, "height": 800})
            page.on("console", lambda m: errors.append(m.text) if m.type == "error" else None)
            page.on("pageerror", lambda e: errors.append(str(e)))
            page.on("request", lambda r: requests.append(r.url))
            page.goto(page_path.as_uri())
            page.wait_for_selector(".js-plotly-plot .gl-container canvas", timeout=60_000)
            page.wait_for_timeout(500)
            shot = tmp_path / "shot.png"
            page.screenshot(path=str(shot))
            n_scenes = page.evaluate("document.querySelector('.js-plotly-plot')._fullLayout"
                                     "._subplots.gl3d.length")  # fmt: skip
        finally:
            browser.close()
    assert errors == []
    assert [url for url in requests if not url.startswith("file:")] == []
    assert n_scenes == 3
    from PIL import Image

    img = np.asarray(Image.open(shot).convert("RGB"), dtype=float)
    plots = img[200:700]  # below the page's heading: the three 3-D views
    assert plots.std() > 20 and len(np.unique(plots.reshape(-1, 3), axis=0)) > 200
