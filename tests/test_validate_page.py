"""``report.md`` of ``modquad validate`` is composed once and written once, with
``validation.json``, for a static or dynamic task, with or without ``--fault``: the flights after
the validation's own (the trajectory, the failures) add their headline and sections to one page
(:class:`modquad_gym.sim.validation_files.ReportPage`) instead of reading the file back and
writing it again; the page keeps its sections in order, and a page written on its own keeps
the folder's rule (an existing one replaced only with ``force``)."""

from __future__ import annotations

import json
import re

import pytest
from test_validate_cli import _dynamic_task, _static_task, counted_writes

from modquad_gym.cli import main

FAULT = ["--fault", "rotor", "--failure", "worst", "--known-load-only"]
STATIC_HEADINGS = ["# MuJoCo validation", "## Wrench bench", "## Hover on", "## Pictures"]
TRACK, FAILURE = "## Flight along the trajectory", "## Flight through a rotor failure"


@pytest.mark.parametrize(
    "make_task, options, added",
    [
        (_static_task, [], []),
        (_static_task, FAULT, [FAILURE]),
        (_dynamic_task, [], [TRACK]),
        (_dynamic_task, FAULT, [TRACK, FAILURE]),
    ],
    ids=["static", "static-fault", "dynamic", "dynamic-fault"],
)
def test_report_md_is_one_page_written_once(tmp_path, capsys, monkeypatch, make_task, options,
                                            added):  # fmt: skip
    """report.md and validation.json are each written once, whole; the page has the
    validation's sections, then the trajectory's, then the failure's, each after a blank line,
    the Made-by line under the title and a dynamic task's headline in place of the static
    one; validation.json is the record the command prints."""
    from modquad_gym.sim import fault_flight

    monkeypatch.setattr(fault_flight, "FAULT_BEFORE_S", 0.2)  # short flights through a failure
    monkeypatch.setattr(fault_flight, "FAULT_SECONDS", 1.02)
    writes = counted_writes(monkeypatch)
    out = tmp_path / "out"
    argv = ["validate", "--task", str(make_task(tmp_path)), "--method", "exhaustive", "--n-max",
            "4", "--max-hover-wrenches", "1", "--hover-seconds", "0.2", *options, "--out",
            str(out)]  # fmt: skip
    assert main([*argv, "--json"]) == 0
    printed = json.loads(capsys.readouterr().out.strip().splitlines()[-1])
    assert writes.count(out / "report.md") == 1, writes
    assert writes.count(out / "validation.json") == 1, writes
    text = (out / "report.md").read_text()
    lines = text.splitlines()
    assert lines[2] == f"Made by `modquad {' '.join([*argv, '--json'])}`."
    headings = [x for x in lines if x.startswith(("# ", "## "))]
    assert len(headings) == len(STATIC_HEADINGS) + len(added), headings
    assert all(h.startswith(s) for h, s in zip(headings, STATIC_HEADINGS)), headings
    assert headings[len(STATIC_HEADINGS) :] == added
    for heading in added:  # each added section after the page, a blank line between
        assert f"\n\n{heading}\n" in text
    task_lines = [x for x in lines if x.startswith("Task: ")]
    dynamic = make_task is _dynamic_task
    assert len(task_lines) == 1 and task_lines[0].startswith("Task: dynamic") == dynamic
    saved = json.loads((out / "validation.json").read_text())
    assert saved["files"] == printed["files"] and ("fault" in saved) == bool(options)
    assert ("track_max_position_error_m" in saved) == dynamic


def test_a_page_written_on_its_own_keeps_the_folder_rule(tmp_path):
    """The page composes its parts in order; written outside a validation's hold it refuses an
    existing report.md (naming the folder's argument and --force's word) unless ``force``."""
    from modquad_gym.core.outputs import OutputError
    from modquad_gym.sim.validation_files import ReportPage

    def compose(task_line=None):
        return f"# title\n{task_line or 'Task: static'}\n"

    page = ReportPage().begin(tmp_path, False, compose)
    assert page.text() == "# title\nTask: static\n"
    page.task_line = "Task: dynamic"
    page.sections += ["## one\n", "## two\n"]
    assert page.text() == "# title\nTask: dynamic\n\n## one\n\n## two\n"
    (tmp_path / "report.md").write_text("mine")
    with pytest.raises(OutputError, match=r"out_dir: .* already holds report.md .*force"):
        page.write({"a": 1})
    assert (tmp_path / "report.md").read_text() == "mine"
    assert not (tmp_path / "validation.json").exists()
    page.force = True
    page.write({"a": 1})
    assert (tmp_path / "report.md").read_text() == page.text()
    assert json.loads((tmp_path / "validation.json").read_text()) == {"a": 1}
    with pytest.raises(ValueError, match="page: no validation has composed it"):
        ReportPage().write({})


def test_python_door_hands_its_page_to_the_caller(tmp_path):
    """``validate(page=...)`` writes the pictures, not the page: the caller writes report.md and
    validation.json once, the same bytes as ``validate`` writes alone; a page without
    ``out_dir``, or one of another type, is refused naming ``page`` before any simulation."""
    import modquad_gym as mq
    from modquad_gym.sim.validate import validate
    from modquad_gym.sim.validate_track import validate_trajectory
    from modquad_gym.sim.validation_files import ReportPage

    s = mq.Structure([(0, 0), (1, 0)])
    w = [[0.0, 0.0, 3.0, 0.0, 0.0, 0.0]]
    options = dict(f_max=1.0, hover_seconds=0.2, unknown_load=False, render=False)
    validate(s, w, out_dir=tmp_path / "alone", **options)
    page = ReportPage()
    report = validate(s, w, out_dir=tmp_path / "page", page=page, **options)
    assert not (tmp_path / "page" / "report.md").exists()
    assert (tmp_path / "page" / "hover.png").is_file()
    page.write(report.to_dict())
    for name in ("report.md", "validation.json"):
        alone = (tmp_path / "alone" / name).read_text().replace("alone", "page")
        assert (tmp_path / "page" / name).read_text() == alone, name
    with pytest.raises(ValueError, match="page: given without out_dir"):
        validate(s, w, page=ReportPage(), **options)
    with pytest.raises(ValueError, match="page must be a ReportPage or None, got str"):
        validate_trajectory(s, mq.dynamics.hover(0.4), out_dir=tmp_path / "x", page="x")
    assert not (tmp_path / "x").exists()


def test_a_page_is_one_validations(tmp_path):
    """A page a validation began is refused by the next validation, naming ``page``, before any
    simulation (its folder not made): its sections would go into the next one's report.md."""
    import modquad_gym as mq
    from modquad_gym.sim.validate import validate
    from modquad_gym.sim.validate_track import validate_trajectory
    from modquad_gym.sim.validation_files import ReportPage

    s = mq.Structure([(0, 0), (1, 0)])
    w = [[0.0, 0.0, 3.0, 0.0, 0.0, 0.0]]
    options = dict(f_max=1.0, hover_seconds=0.2, unknown_load=False, render=False)
    page = ReportPage()
    page.write(validate(s, w, out_dir=tmp_path / "a", page=page, **options).to_dict())
    used = re.escape(f"page: already holds the validation into {tmp_path / 'a'};")
    with pytest.raises(ValueError, match=used):
        validate(s, w, out_dir=tmp_path / "b", page=page, **options)
    with pytest.raises(ValueError, match=used):
        validate_trajectory(s, mq.dynamics.hover(0.4), out_dir=tmp_path / "b", page=page)
    with pytest.raises(ValueError, match=used):
        page.begin(tmp_path / "b", False, lambda task_line=None: "")
    assert not (tmp_path / "b").exists()
    assert page.folder == tmp_path / "a"
