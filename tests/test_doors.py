"""The command line's doors after the review of /tmp/review/findings.md (items 1, 13-15, 17-20,
23): an option that cannot be honoured is refused in one line naming it, a message names the
option it is about, and one check serves every command."""

from __future__ import annotations

import json
import tempfile
from pathlib import Path

import numpy as np
import pytest
from test_hardening import assert_one_line_error, assert_rejected, run_main

from modquad_gym import dynamics as dy

SCREWDRIVER = "example:screwdriver"


def files(folder: Path) -> list[str]:
    return sorted(p.name for p in folder.iterdir())


def _no_search(monkeypatch) -> None:
    def boom(*args, **kwargs):
        raise AssertionError("a search started before the options were checked")

    monkeypatch.setattr("modquad_gym.cli.solve.cached_solver", boom)  # after SolveSpec.of


# ------------------------------------------------------------------ 1. task motion --heading
@pytest.mark.parametrize("kind", ["hover", "line", "figure-eight", "push"])
def test_heading_with_a_kind_that_has_none_is_refused(tmp_path, capsys, kind):
    """It was `KeyError: 'heading'` (a traceback, exit 1)."""
    out = tmp_path / "h.json"
    argv = ["task", "motion", "--kind", kind, "--heading", "tangent", "--out", str(out)]
    code, _, err = run_main(capsys, *argv)
    assert_one_line_error(code, err, f"--heading does not apply to --kind {kind}")
    assert not out.exists()


def test_heading_with_circle_is_taken(tmp_path, capsys):
    out = tmp_path / "c.json"
    argv = ["task", "motion", "--kind", "circle", "--heading", "tangent", "--rate", "10"]
    code, _, err = run_main(capsys, *argv, "--out", str(out))
    assert code == 0, err
    assert json.loads(out.read_text())["meta"]["heading"] == "tangent"


# ------------------------------------------------------------- 13. --option beside --cells
@pytest.mark.parametrize("command", ["export", "show"])
def test_option_beside_cells_is_refused(tmp_path, capsys, monkeypatch, command):
    """`--method`, `--seed`, `--time-limit` were refused there; `--option` was dropped."""
    _no_search(monkeypatch)
    out = tmp_path / ("z.json" if command == "export" else "z.png")
    argv = [command, "--cells", "[[0,0]]", "--option", "beam_width=8", "--out", str(out)]
    code, _, err = run_main(capsys, *argv)
    assert_one_line_error(code, err, "--option beam_width=8", "--cells")
    assert files(tmp_path) == []


# ---------------------------------------------------------------------- 14. show --layout
@pytest.mark.parametrize(
    "where",
    [
        ["--cells", "[[0,0]]", "--out", "d.png"],  # no task: the top view only
        ["--cells", "[[0,0]]", "--html", "k.html"],  # no PNG at all
        ["--task", SCREWDRIVER, "--cells", "[[0,0]]", "--html", "k.html"],
    ],
)
def test_layout_where_no_png_of_three_views_is_drawn_is_refused(tmp_path, capsys, monkeypatch,
                                                                where):  # fmt: skip
    monkeypatch.chdir(tmp_path)
    code, _, err = run_main(capsys, "show", *where, "--layout", "grid")
    assert_one_line_error(code, err, "--layout grid", "applies with --task to the PNG")
    assert files(tmp_path) == []


# ------------------------------------------------------------- 15. task generate --seed
def test_seed_for_a_kind_that_draws_nothing_is_refused(tmp_path, capsys):
    out = tmp_path / "g.json"
    argv = ["task", "generate", "--kind", "screwdriver", "--out", str(out)]
    code, _, err = run_main(capsys, *argv, "--seed", "5")
    assert_one_line_error(code, err, "--seed 5: --kind screwdriver draws nothing at random")
    assert not out.exists()
    code, said, err = run_main(capsys, *argv)  # not typed: written, and no seed claimed
    assert code == 0 and out.exists(), err
    assert "seed " not in said.split(":", 2)[-1]
    code, said, err = run_main(capsys, "task", "generate", "--kind", "paper", "--seed", "5",
                               "--out", str(tmp_path / "p.json"))  # fmt: skip
    assert code == 0 and "seed 5" in said, err


# --------------------------------------------- 17. a motion the sampling cannot represent
def test_a_line_shorter_than_its_samples_is_refused(tmp_path, capsys):
    """It wrote a task whose sampled acceleration peaked at 2e-9 m/s^2 (asked: 1e5)."""
    out = tmp_path / "la.json"
    argv = ["task", "motion", "--kind", "line", "--max-acceleration", "100000", "--f-max", "1e6"]
    code, _, err = run_main(capsys, *argv, "--out", str(out))
    assert_one_line_error(code, err, "--max-acceleration:", "0.011 s", "--rate 100", "raise --rate")
    assert not out.exists()
    with pytest.raises(ValueError, match=r"^max_acceleration: .* raise rate"):
        dy.line(2.0, 1e5)


def test_a_ramp_shorter_than_its_samples_is_refused(tmp_path, capsys):
    out = tmp_path / "c.json"
    code, _, err = run_main(capsys, "task", "motion", "--kind", "circle", "--rate", "1",
                            "--out", str(out))  # fmt: skip
    assert_one_line_error(code, err, "--rate:", "ramp", "raise --rate")
    assert not out.exists()
    with pytest.raises(ValueError, match=r"^rate: "):
        dy.figure_eight(rate=2)
    dy.circle(radius=0.5, laps=0.5, ramp=0.2, hold=0.1, rate=20.0)  # 4 intervals: the least


@pytest.mark.parametrize("accel", [2.0, 50.0, 300.0, 1000.0, 1400.0])
def test_an_accepted_line_shows_its_acceleration(accel):
    """Where the move spans the fewest sample intervals taken, its samples still peak near the
    asked acceleration (at least 85 %); the refused ones peaked anywhere down to 0."""
    try:
        task = dy.line(2.0, accel, rate=100.0)
    except ValueError as exc:
        assert "max_acceleration" in str(exc)
        return
    peak = np.abs(task.trajectory.acceleration).max()
    assert 0.85 * accel <= peak <= accel * (1 + 1e-9)


# ------------------------------------------------- 18. export --format against the suffix
@pytest.mark.parametrize(
    "name, fmt, named",
    [("b.xml", "json", "mjcf"), ("c.urdf", "mjcf", "urdf"), ("d.json", "urdf", "json")],
)
def test_export_format_against_the_suffix_is_refused(tmp_path, capsys, monkeypatch, name, fmt,
                                                     named):  # fmt: skip
    _no_search(monkeypatch)  # refused before the search
    for source in (["--cells", "[[0,0],[1,0]]"], ["--task", SCREWDRIVER]):
        argv = ["export", *source, "--out", str(tmp_path / name), "--format", fmt]
        code, _, err = run_main(capsys, *argv)
        assert_one_line_error(code, err, f"--format {fmt}", name, named)
        assert files(tmp_path) == []


def test_export_xml_takes_urdf_and_a_nameless_suffix_needs_format(tmp_path, capsys, monkeypatch):
    out = tmp_path / "robot.xml"
    code, _, err = run_main(capsys, "export", "--cells", "[[0,0]]", "--out", str(out),
                            "--format", "urdf")  # fmt: skip
    assert code == 0 and "<robot" in out.read_text(), err
    _no_search(monkeypatch)
    argv = ["export", "--task", SCREWDRIVER, "--out", str(tmp_path / "robot.txt")]
    code, _, err = run_main(capsys, *argv)  # said before the search, not after it
    assert_one_line_error(code, err, "--out", "robot.txt", "--format")
    with pytest.raises(AssertionError, match="a search started"):  # any other suffix: as asked
        run_main(capsys, *argv, "--format", "json")


# ------------------------------------------------------ 19. messages name their option
@pytest.mark.parametrize("out", [".", ""])
def test_show_out_without_a_file_name_names_out(tmp_path, capsys, monkeypatch, out):
    monkeypatch.chdir(tmp_path)
    code, _, err = run_main(capsys, "show", "--cells", "[[0,0]]", "--out", out)
    assert_one_line_error(code, err, "--out")
    assert "PosixPath" not in err and files(tmp_path) == []


def test_a_folder_that_takes_no_file_names_the_output(tmp_path, capsys, monkeypatch):
    """/proc takes no new file: the error named the temporary file (/proc/.version.png.X.tmp)."""

    make = tempfile.mkstemp

    def refuse(*args, **kwargs):
        if kwargs.get("prefix", "").startswith(".modquad-probe"):
            return make(*args, **kwargs)  # the folder check's probe passes (as root on /proc)
        raise FileNotFoundError(2, "No such file or directory", str(tmp_path / ".s.png.x.tmp"))

    monkeypatch.setattr(tempfile, "mkstemp", refuse)
    out = tmp_path / "s.png"
    code, _, err = run_main(capsys, "show", "--cells", "[[0,0]]", "--out", str(out), "--force")
    assert_one_line_error(code, err, str(out), "cannot create a file")
    assert ".tmp" not in err


@pytest.mark.parametrize(
    "argv, names",
    [
        (["export", "--task", SCREWDRIVER, "--method", "beam", "--option", "beam_width=0"],
         ["--option beam_width=0", "beam_width must be >= 1"]),
        (["export", "--task", SCREWDRIVER, "--method", "greedy", "--option", "prune=maybe"],
         ["--option prune=maybe", "a boolean (true/false)"]),
        (["export", "--task", SCREWDRIVER, "--method", "beam", "--option", "beam_width"],
         ["--option beam_width", "KEY=VALUE"]),
        (["task", "motion", "--kind", "hover", "--payload-mass", "1", "--payload-offset",
          "1e300,0,0"], ["--payload-offset"]),
    ],
)  # fmt: skip
def test_messages_name_the_option(tmp_path, capsys, monkeypatch, argv, names):
    _no_search(monkeypatch)  # an option's value is checked before the search
    code, _, err = run_main(capsys, *argv, "--out", str(tmp_path / "x.json"))
    assert_one_line_error(code, err, *names)
    assert "<class" not in err and "has no option" not in err and "--payload-mass" not in err
    assert files(tmp_path) == []


# ------------------------------------------------------- 20. export's structure-size limit
def test_export_takes_structures_up_to_the_searches_limit(tmp_path, capsys):
    from modquad_gym.search.problem import MAX_MODULES

    def cells(n):
        return json.dumps([[i % 20, i // 20] for i in range(n)])

    out = tmp_path / "big.json"
    code, _, err = run_main(capsys, "export", "--cells", cells(300), "--out", str(out))
    assert_one_line_error(code, err, "--cells", "300 modules", f"at most {MAX_MODULES}")
    assert "draw" not in err and not out.exists()
    code, _, err = run_main(capsys, "export", "--cells", cells(MAX_MODULES), "--out", str(out))
    assert code == 0 and json.loads(out.read_text())["n_modules"] == MAX_MODULES, err


# --------------------------------------------------------------- 23. one check of --f-max
@pytest.mark.parametrize(
    "argv",
    [
        ["export", "--cells", "[[0,0]]"],
        ["task", "generate", "--kind", "paper"],
        ["task", "motion", "--kind", "hover"],
    ],
)
@pytest.mark.parametrize("value", ["1e301", "1e308", "0", "-1"])
def test_f_max_is_checked_alike_everywhere(tmp_path, capsys, argv, value):
    out = tmp_path / "x.json"
    code, _, err = run_main(capsys, *argv, f"--f-max={value}", "--out", str(out))
    words = "outside 1e-300..1e12" if value.startswith("1e") else "must be positive"
    assert_rejected(code, err, "--f-max", words)
    assert not out.exists()


def test_export_at_the_largest_f_max_says_a_short_ratio(tmp_path, capsys):
    out = tmp_path / "x.json"
    argv = ["export", "--cells", "[[0,0]]", "--f-max", "1e12", "--out", str(out)]
    code, said, err = run_main(capsys, *argv)
    assert code == 0, err
    assert "thrust-to-weight 9.61e+11" in said and max(map(len, said.splitlines())) < 200
