"""The library's writers (core.outputs and the Python savers) and ``modquad show --out``: an
existing file is replaced only on demand, a Python caller is told ``force=True`` (a command
``--force``), a folder or a place that takes no file is refused before the work, and ``force``
removes only what a command recorded, never through a symbolic link."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pytest

import modquad_gym as mq
from modquad_gym.cli import main
from modquad_gym.core.outputs import (
    OutputError,
    check_output_dir,
    check_output_file,
    claim_output_dir,
    write_csv,
    write_text,
)

PROC = Path("/proc")


def _one_error_line(capsys, argv: list[str]) -> str:
    """``modquad argv`` exits 2 with one error line and no traceback; that line."""
    assert main(argv) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "Traceback" not in err, err
    return err


# ----------------------------------------------------------------------------- core.outputs
def test_force_unlinks_a_recorded_name_that_became_a_link_never_its_target(tmp_path):
    """A recorded report.md that is now a link to the user's notes: the link goes, the notes
    stay; a recorded file reached through a linked folder is not followed out of the folder."""
    out, elsewhere = tmp_path / "out", tmp_path / "elsewhere"
    elsewhere.mkdir()
    (elsewhere / "f.txt").write_text("the user's file outside")
    with claim_output_dir(out, ("report.md",)) as claim:
        write_text(claim.path("report.md"), "first run")
        write_text(claim.path("sub/f.txt"), "first run's")
    (out / "my_notes.md").write_text("mine")
    (out / "report.md").unlink()
    (out / "report.md").symlink_to("my_notes.md")
    (out / "sub" / "f.txt").unlink()
    (out / "sub").rmdir()
    (out / "sub").symlink_to(elsewhere)
    with claim_output_dir(out, ("report.md",), force=True):
        pass
    assert (out / "my_notes.md").read_text() == "mine"
    assert not os.path.lexists(out / "report.md")  # the recorded entry itself went
    assert (elsewhere / "f.txt").read_text() == "the user's file outside"


def test_force_keeps_a_recorded_file_the_run_reads(tmp_path):
    """``keep``: a model the new run continues is not removed with the earlier run's files."""
    out = tmp_path / "run"
    with claim_output_dir(out, ("model.zip",)) as claim:
        write_text(claim.path("model.zip"), "the model to continue")
        write_text(claim.path("old.csv"), "old")
    with claim_output_dir(out, ("model.zip",), force=True, keep=(out / "model.zip",)):
        assert (out / "model.zip").read_text() == "the model to continue"
        assert not (out / "old.csv").exists()


@pytest.mark.skipif(not PROC.is_dir(), reason="needs /proc")
def test_a_place_that_takes_no_file_is_refused_even_where_os_access_says_yes(monkeypatch):
    """As root, ``os.access`` says /proc is writable: the check tries to create a file."""
    monkeypatch.setattr(os, "access", lambda *a, **k: True)
    with pytest.raises(OutputError, match="--out: cannot create folder /proc/modquad-out"):
        check_output_dir(PROC / "modquad-out", ("report.md",))
    with pytest.raises(OutputError, match="folder /proc is not writable"):
        check_output_file(PROC / "cert.json", what="path")


def test_the_writable_check_leaves_no_file_behind(tmp_path):
    check_output_dir(tmp_path / "new", ("a.csv",))
    check_output_file(tmp_path / "b.json")
    assert list(tmp_path.iterdir()) == []


def test_write_csv_of_no_rows_names_the_file(tmp_path):
    with pytest.raises(ValueError, match=r"empty\.csv: no rows to write"):
        write_csv([], tmp_path / "empty.csv")
    assert not (tmp_path / "empty.csv").exists()
    write_csv([{"a": 1}, {"a": 2, "b": 3}], tmp_path / "grown.csv")  # every row's columns
    assert (tmp_path / "grown.csv").read_text().splitlines() == ["a,b", "1,", "2,3"]


def test_a_python_caller_is_told_force_true_a_command_force(tmp_path):
    """check_output_dir words its advice as check_output_file does: by who calls."""
    (tmp_path / "report.md").write_text("mine")
    with pytest.raises(OutputError, match=r"out_dir: .*use force=True"):
        check_output_dir(tmp_path, ("report.md",), what="out_dir")
    with pytest.raises(OutputError, match=r"--out: .*use --force"):
        check_output_dir(tmp_path, ("report.md",))


# ---------------------------------------------------------------------------- Python savers
def test_save_structure_figure_refuses_an_existing_file_and_a_folder(tmp_path):
    pytest.importorskip("matplotlib")
    from modquad_gym.viz.drawing import save_structure_figure

    s = mq.Structure([(0, 0), (1, 0)])
    mine = tmp_path / "thesis_figure.png"
    mine.write_text("my precious figure")
    with pytest.raises(OutputError, match=r"path: .*thesis_figure\.png exists .*force=True"):
        save_structure_figure(s, mine)
    assert mine.read_text() == "my precious figure"
    (tmp_path / "afolder").mkdir()
    with pytest.raises(OutputError, match="is a folder"):
        save_structure_figure(s, tmp_path / "afolder")
    assert save_structure_figure(s, mine, force=True) == str(mine)
    assert mine.read_bytes().startswith(b"\x89PNG")


def test_save_structure_page_names_its_argument_not_a_cli_option(tmp_path):
    pytest.importorskip("plotly")
    from modquad_gym.viz.interactive import save_structure_page

    page = tmp_path / "p.html"
    page.write_text("mine")
    with pytest.raises(OutputError) as err:
        save_structure_page(mq.Structure([(0, 0)]), page)
    assert str(err.value).startswith("path: ") and "force=True" in str(err.value)
    assert "--" not in str(err.value)


def _certified():
    from modquad_gym.search.problem import SearchProblem

    W = np.array([[0.0, 0.0, 5.0, 0.0, 0.0, 0.0]])
    problem = SearchProblem.build(W, n_max=3)
    return mq.exhaustive_search.solve(problem), problem


def test_certificate_writer_checks_its_path_before_the_proof(tmp_path, monkeypatch):
    """A dangling link, an existing file, a parent that is a file: OutputError before
    ``make`` (the proof) runs, worded for Python."""
    from modquad_gym.search import certificates

    result, problem = _certified()

    def boom(*args, **kwargs):
        raise AssertionError("the proof was made before the path was checked")

    monkeypatch.setattr(certificates, "make", boom)
    (tmp_path / "dangling.json").symlink_to(tmp_path / "nowhere.json")
    with pytest.raises(OutputError, match="symbolic link.*force=True"):
        certificates.write(result, problem, tmp_path / "dangling.json")
    assert (tmp_path / "dangling.json").is_symlink()
    (tmp_path / "mine.json").write_text("mine")
    with pytest.raises(OutputError, match=r"path: .*mine\.json exists \(use force=True"):
        certificates.write(result, problem, tmp_path / "mine.json")
    (tmp_path / "afile").write_text("x")
    with pytest.raises(OutputError, match="afile exists and is not a folder"):
        certificates.write(result, problem, tmp_path / "afile" / "proof.json")


# ----------------------------------------------------------------------- modquad show --out
def test_show_refuses_an_out_that_is_a_folder_or_a_device_before_adding_png(tmp_path, capsys):
    pytest.importorskip("matplotlib")
    folder = tmp_path / "afolder"
    folder.mkdir()
    err = _one_error_line(capsys, ["show", "--cells", "[[0,0]]", "--out", str(folder)])
    assert "--out" in err and "afolder" in err and "not a regular file" in err
    assert not (tmp_path / "afolder.png").exists()
    existed = os.path.lexists("/dev/null.png")
    try:
        err = _one_error_line(capsys, ["show", "--cells", "[[0,0]]", "--out", "/dev/null"])
        assert "/dev/null" in err and "not a regular file" in err
        assert os.path.lexists("/dev/null.png") == existed
    finally:  # the old rule wrote a file into /dev
        if not existed and os.path.lexists("/dev/null.png"):
            os.unlink("/dev/null.png")


def test_show_force_replaces_the_picture(tmp_path, capsys):
    pytest.importorskip("matplotlib")
    out = tmp_path / "s.png"
    out.write_text("old")
    assert main(["show", "--cells", "[[0,0],[1,0]]", "--out", str(out), "--force"]) == 0
    assert out.read_bytes().startswith(b"\x89PNG")
