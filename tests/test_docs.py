"""The documentation site: it builds with warnings as errors, every page is in its navigation,
the generated pages hold what they promise, and every ``python`` code block of the docs runs."""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs"
PAGES = sorted(p.relative_to(DOCS).as_posix() for p in DOCS.rglob("*.md"))
TUTORIALS = [
    f"docs/{page}" for page in PAGES if re.search(r"^```python$", (DOCS / page).read_text(), re.M)
] + ["README.md"]
"""Pages with ``python`` code blocks, by path from the repository's root: they run (a schematic
snippet is fenced ``py`` instead)."""


@pytest.fixture(scope="module")
def site(tmp_path_factory) -> Path:
    pytest.importorskip("mkdocstrings")
    out = tmp_path_factory.mktemp("site")
    env = {**os.environ, "NO_MKDOCS_2_WARNING": "1", "PYTHONPATH": str(ROOT)}
    run = subprocess.run([sys.executable, "-m", "mkdocs", "build", "--strict", "--site-dir",
                          str(out)], cwd=ROOT, env=env, capture_output=True, text=True,
                         timeout=600)  # fmt: skip
    assert run.returncode == 0, run.stderr[-3000:]
    return out


def test_docs_build_strictly_with_every_page_in_the_nav(site):
    html = (site / "index.html").read_text()
    links = re.findall(r'<a href="([^"#]*)" class="md-nav__link', html)
    linked = {link.strip("./") for link in links}  # "getting-started/design/" -> without slashes
    for page in PAGES:
        target = "" if page == "index.md" else page.removesuffix(".md")
        assert target in linked, f"docs/{page} is not in the site's navigation"


def test_generated_pages_hold_every_environment_and_command(site):
    from modquad_gym.cli import COMMANDS
    from modquad_gym.envs import ENV_IDS

    for env_id in ENV_IDS:
        page = (site / "environments" / env_id / "index.html").read_text()
        assert "Observation space" in page and "Version history" in page and "Rewards" in page
    cli = (site / "cli" / "index.html").read_text()
    for name in (*COMMANDS, "task generate", "task example"):
        assert f"modquad {name}</code>" in cli, name
    assert "python -m benchmarks.oracle</code>" in cli
    assert "results/example_structure.png" in (site / "index.html").read_text()
    assert (site / "results" / "example_structure.png").is_file()


@pytest.mark.parametrize("page", TUTORIALS)
def test_docs_python_blocks_run(page, tmp_path, monkeypatch, capsys):
    """A page's ``python`` blocks (the README's too) run in order in one namespace, as a reader
    would run them, in an empty folder (no repository files at hand)."""
    monkeypatch.chdir(tmp_path)
    namespace = {"__name__": "__docs__"}
    blocks = re.findall(r"^```python\n(.*?)^```", (ROOT / page).read_text(), re.S | re.M)
    assert blocks, page
    for i, block in enumerate(blocks):
        exec(compile(block, f"{page} python block {i + 1}", "exec"), namespace)


def test_docs_name_only_commands_that_exist():
    """The README and the docs name the benchmarks as the scripts they are
    (``python -m benchmarks.NAME``, issue 33): every one named exists, and no removed
    ``modquad bench NAME`` is left (``modquad bench agents`` is ``modquad score``'s deprecated
    name; the changelog keeps the history)."""
    from benchmarks.common import scripts

    pages = [ROOT / "README.md", *(DOCS / p for p in PAGES if p != "changelog.md")]
    known = scripts()  # parses every benchmark file: once, not per name
    for page in pages:
        text = page.read_text()
        for name in re.findall(r"python -m benchmarks\.([a-z_0-9]+)", text):
            assert name in known, (page.name, name)
        for name in re.findall(r"modquad bench ([a-z-]+)", text):
            assert name == "agents", (page.name, name)


def shell_commands(page: Path) -> list[str]:
    """The command lines of a page's ``bash``/``sh`` blocks (continuations joined, comments
    dropped)."""
    blocks = re.findall(r"^```(?:bash|sh)[^\n]*\n(.*?)^```", page.read_text(), re.S | re.M)
    lines = (line for block in blocks for line in block.replace("\\\n", " ").splitlines())
    return [c for c in (" ".join(re.sub(r"\s#\s.*$", "", ln).split()) for ln in lines) if c]


def test_docs_commands_that_rewrite_a_committed_report_say_force():
    """A documented command that reproduces a committed report writes where that report is, in
    results/; every such script refuses to replace files without ``--force`` (nothing lost), so
    without it the docs' command stops at once with exit 2 in a fresh clone (the wheel check,
    benchmarks/wheel_check.sh, found ten). Seeds reports go to RUNS/report unless told; the
    leaderboard rewrites the committed page from the committed data unless told (it refuses
    only an --out that holds files)."""
    report = re.compile(
        r"^(python -m benchmarks\.\w+|python -m modquad_gym\.scoring\.seeds|modquad score)\b"
    )
    missing = []
    for page in [ROOT / "README.md", *(DOCS / p for p in PAGES)]:
        for command in shell_commands(page):
            if not (found := report.match(command)):
                continue
            args = command.split()
            out = args[args.index("--out") + 1] if "--out" in args else "results"
            if found.group(1).endswith(("seeds", "leaderboard")) and "--out" not in args:
                continue
            if (out == "results" or out.startswith("results/")) and "--force" not in args:
                missing.append(f"{page.relative_to(ROOT)}: {command}")
    assert not missing, missing


def test_pages_in_a_browser_show_the_home_picture_readable_and_the_numbers_inline(site):
    """Headless Chromium at a laptop's width: the home picture is shown at least 650 px wide
    and at most 1.5 times smaller than drawn (its 10 pt text >= 11 px); a quoted result sits in
    its sentence (a marker opening a line would have ended the paragraph)."""
    sync_api = pytest.importorskip("playwright.sync_api")
    from tests.test_interactive import CHROMIUM, CHROMIUM_FLAGS

    if CHROMIUM is None:
        pytest.skip("no chromium (apt-get install chromium; .ci/run installs it)")
    with sync_api.sync_playwright() as p:
        browser = p.chromium.launch(executable_path=CHROMIUM, args=CHROMIUM_FLAGS)
        try:
            page = browser.new_page(viewport={"width": 1280, "height": 900})
            page.goto((site / "index.html").as_uri())
            shown, drawn = page.evaluate(
                "() => { const i = document.querySelector('img[src*=\"example_structure\"]');"
                " return [i.clientWidth, i.naturalWidth]; }"
            )
            page.goto((site / "results" / "index.html").as_uri())
            sentence = page.evaluate(
                "() => [...document.querySelectorAll('p')].map(p => p.innerText)"
                ".find(t => t.includes('beats the greedy rule'))"
            )
        finally:
            browser.close()
    assert shown >= 650 and drawn <= 1.5 * shown, (shown, drawn)
    assert re.search(r"is optimal on \d+\.\d % \[[\d.]+, [\d.]+\] \(mean of 5 seeds", sentence)
